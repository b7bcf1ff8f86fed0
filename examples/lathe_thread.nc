" Thread M20 x 1.5 on the lathe in two passes, cnc836 dialect. X is a
" diameter. G33 follows the spindle encoder: every pass starts at the
" same spindle angle after the index pulse, so both cut the same groove.
" Run: cnc plot examples/lathe_thread.nc --machine lathe --thread OUT.png
N10 G18 G90 M03 S800 T0101
N20 G00 X20 Z5              " 5 mm before the part: room for the run-in
N30 G33 Z-30 F1.5           " first pass, pitch 1.5 mm/rev
N40 G00 X30                 " out of the groove
N50 Z5                      " back to the start
N60 X20
N70 G33 Z-33 F1.5 J3        " second pass, leaving the thread over the last 3 mm (runout, mc8: 30 deg on X)
N80                         " after a runout: an empty block
N90 X30 Z5                  " then a block with every axis
N100 M05
N110 M30
