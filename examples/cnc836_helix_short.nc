" The seed's helix, short (the golden recording in bags/ is of this one):
" three full circles and a half circle of radius 100 mm about (100, 0),
" Z rising 1.05 mm per turn (Z 3.675 at the end of N60), F the speed in
" the plane. The full 21-turn program is examples/cnc836_helix.nc.
N5  X0 Y0 Z0 G00
N6  F15000
N10 Z1.05 G10                       " pitch 1.05 mm, Z dragged
N50 G09 G02 X0 Y0 I100 G73 L50 Q2   " helix start: full circle, 3 times
N60 X200. Y0 I100                   " half circle, still helix
N70 G98                             " helix end, its own block
N80 G01 X10 Y10 Z30                 " all axes move (G01: G02 is still modal)
