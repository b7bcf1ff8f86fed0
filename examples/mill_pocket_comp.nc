" Pocket 100 x 60 with corner arcs R8 under cutter radius compensation,
" cnc836 dialect. The pocket is programmed in drawing dimensions; G41
" keeps the 10 mm end mill (tool 1, radius 5 mm) on the left of the
" direction of travel, i.e. inside the pocket (cut counter-clockwise).
" Run: cnc plot examples/mill_pocket_comp.nc --machine mill -o OUT.png
N10 G17 G90 G94 M03 S3000 T1
N20 G00 X50 Y50 Z5
N30 G01 Z-2 F300
N40 G41 X38 Y30 F1200       " entry: to the compensated start of the first side
N50 X122
N60 G03 X130 Y38 I0 J8      " tangent corner arcs R8 (offset: R3)
N70 G01 Y82
N80 G03 X122 Y90 I-8 J0
N90 G01 X38
N100 G03 X30 Y82 I0 J-8
N110 G01 Y38
N120 G03 X38 Y30 I8 J0
N130 G40 G01 X50 Y50        " exit: compensation off, back to the centre
N140 G00 Z5
N150 M05
N160 M30
