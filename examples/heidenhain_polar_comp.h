%POLARCOMP G71 *
; The seed's two polar programs (HEIDENHAIN TNC 410 ISO, seed 001) with
; their radius compensation G42: the tool (T2, radius 3 mm) stays on the
; right of the polar lines and arcs, i.e. outside the hexagon and the
; circle. Polar blocks G10-G13 are compensated like Cartesian ones; the
; hexagon's outside corners are joined at the offset lines' intersection.
; Added to the seed: the tool call N105, G40 in the connecting rapid N170
; (the two programs are separate in the seed; without it the rapid would
; be compensated and joined to N190's line at a sharp corner) and G40 in
; the retract N220.
; Run: cnc plot examples/heidenhain_polar_comp.h --dialect heidenhain -o OUT.png
N100 G17 G90 G00 Z+2 *
N105 T2 *                        ; tool 2 from the mill's table: radius 3 mm
N110 M3 S2000 *
N120 I+45 J+45 *                 ; pole at (45, 45)
N130 G11 G42 R+30 H+0 F3000 *    ; entry: to (75, 45), offset 3 mm to the right
N140 H+60 *                      ; straight line to R30 at 60 degrees
N150 G91 H+60 *                  ; to 120 degrees
N160 G90 H+180 *                 ; to 180 degrees
N170 G40 G10 R+40 H+270 *        ; compensation off, rapid, polar
N180 I+25 J+25 *                 ; pole at (25, 25)
N190 G11 G42 R+20 H+0 F2500 *    ; entry: to (45, 25), offset 3 mm outwards
N200 G13 H+180 *                 ; CCW half circle to (5, 25), the tool on radius 23
N210 G91 G13 H+1080 Z-3 *        ; helix: three turns, 3 mm lower, compensated in the plane
N220 G40 G90 G00 Z+2 *           ; compensation off, retract
N230 M30 *
