%SLOT G71 *
; Slot with round ends on the mill, HEIDENHAIN TNC ISO dialect.
; Run: cnc simulate examples/heidenhain_slot.h --machine mill --dialect heidenhain
N10 G17 G90 G00 X+10 Y+10 Z+5 *
N20 M3 S2500 *
N30 G01 Z-1.5 F250 *
N40 G01 X+60 F500 *
N50 G03 X+60 Y+30 I+0 J+10 *   ; half circle, tangent to both lines
N60 G01 X+10 *
N70 G03 X+10 Y+10 I+0 J-10 *
N80 G00 Z+5 *
N90 M5 *
N100 M30 *
