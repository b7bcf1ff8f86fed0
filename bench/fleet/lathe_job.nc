" Fleet benchmark job (bench/fleet.sh), lathe, cnc836: a finishing profile
" with feed per revolution (G95, from lathe_profile.nc), then the M20 x 1.5
" thread in two passes (G33, from lathe_thread.nc). Both follow the
" spindle encoder over DDS. X is a diameter.
N10 G18 G90 M03 S1200 T0101
N20 G00 X20 Z2
N30 G95 G01 Z0 F0.15        " 0.15 mm/rev at 1200 rpm
N40 X30 Z-5
N50 Z-20
N60 G02 X50 Z-30 I10 K0
N70 G01 X60
N80 Z-45
N90 G94 G00 X30 Z5
N100                        " (the thread at S1200 too, as in the first measurements: a new S while the spindle turns was not commanded then; it is since 7fd6450)
N110 G00 X20 Z5
N120 G33 Z-30 F1.5          " first pass, pitch 1.5 mm/rev
N130 G00 X30
N140 Z5
N150 X20
N160 G33 Z-33 F1.5 J3       " second pass with its runout
N170
N180 X30 Z5
N190 M05
N200 M30
