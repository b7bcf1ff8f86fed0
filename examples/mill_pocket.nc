" Pocket outline with rounded corners on the mill, cnc836 dialect.
" Run: cnc simulate examples/mill_pocket.nc --machine mill
N10 G17 G90 G94 M03 S3000 T1
N20 G00 X20 Y10 Z5
N30 G01 Z-2 F300
N40 X80 F900
N50 G03 X90 Y20 I0 J10      " tangent corner arcs: no stop
N60 G01 Y60
N70 G03 X80 Y70 I-10 J0
N80 G01 X20
N90 G03 X10 Y60 I0 J-10
N100 G01 Y20
N110 G03 X20 Y10 I10 J0
N120 G00 Z5
N130 G04 P0.5               " dwell 0.5 s
N140 M05
N150 M30
