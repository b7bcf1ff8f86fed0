%POLAR G71 *
; Polar lines and arcs about a pole (HEIDENHAIN TNC 410 ISO, seed 001).
; The seed's blocks also switch on radius compensation (G42); that comes
; with the compensation issue, so it is left out here.
; Run: cnc simulate examples/heidenhain_polar.h --dialect heidenhain
N100 G17 G90 G00 Z+2 *
N110 M3 S2000 *
N120 I+45 J+45 *                 ; pole at (45, 45)
N130 G11 R+30 H+0 F3000 *        ; to (75, 45)
N140 H+60 *                      ; straight line to R30 at 60 degrees
N150 G91 H+60 *                  ; to 120 degrees
N160 G90 H+180 *                 ; to 180 degrees
N170 G10 R+40 H+270 *            ; rapid, polar
N180 I+25 J+25 *                 ; pole at (25, 25)
N190 G11 R+20 H+0 F2500 *
N200 G13 H+180 *                 ; CCW half circle to (5, 25)
N210 G91 G13 H+1080 Z-3 *        ; helix: three turns, 3 mm lower
N220 G90 G00 Z+2 *
N230 M30 *
