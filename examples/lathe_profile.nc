" Finishing profile on the lathe, cnc836 dialect. X is a diameter,
" I and K are radius offsets of the arc centre from the start point.
" Run: cnc simulate examples/lathe_profile.nc --machine lathe
N10 G18 G90 M03 S1200 T0101
N20 G00 X20 Z2
N30 G95 G01 Z0 F0.15        " feed per revolution: 0.15 mm/rev at 1200 rpm
N40 X30 Z-5                 " chamfer (taper)
N50 Z-20
N60 G02 X50 Z-30 I10 K0     " arc R10
N70 G01 X60
N80 Z-45
N90 G94 G00 X200 Z20
N100 M05
N110 M30
