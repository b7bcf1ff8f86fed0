" Helix from the CNC836 manual (seed 000/003): 21 full circles and a half
" circle of radius 100 mm about (100, 0), Z rising 1.05 mm per turn.
" Run: cnc simulate examples/cnc836_helix.nc --machine mill
N5  X0 Y0 Z0 G00
N6  F3000
N10 Z1.05 G10                       " pitch 1.05 mm, Z dragged
N50 G09 G02 X0 Y0 I100 G73 L50 Q20  " helix start: full circle, 21 times
N60 X200. Y0 I100                   " half circle, still helix
N70 G98                             " helix end, its own block
N80 G01 X10 Y10 Z30                 " all axes move (G01: G02 is still modal)
