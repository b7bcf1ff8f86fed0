" Finishing profile under tool-nose radius compensation, cnc836 dialect.
" The contour is programmed in drawing dimensions (X a diameter, I and K
" radius offsets of the arc centre); G42 keeps the nose circle of tool 1
" (offset 01: nose radius 0.8 mm, tool type 3, outside turning) on the
" right of the direction of travel, tangent to the contour. The slide
" follows the imaginary tip: the nose centre + 0.8 mm x (-1, -1).
" Run: cnc plot examples/lathe_compensation.nc --machine lathe -o OUT.png
N10 G18 G90 G94 M03 S1200 T0101
N20 G00 X40 Z5
N30 G42 G01 X16 Z2 F250     " entry: to the compensated start of the Z line
N40 Z-12                    " Z line, diameter 16
N50 X24 Z-20                " taper
N60 G03 X32 Z-24 I0 K-4     " convex arc R4
N70 G02 X40 Z-28 I4 K0      " concave arc R4
N80 G01 X56                 " face (shoulder)
N90 G40 G00 X70 Z-24        " exit: compensation off, tip on the programmed point
N100 X80 Z20
N110 M05
N120 M30
