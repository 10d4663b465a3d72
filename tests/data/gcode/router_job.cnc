(router controller job saved as .cnc, written for the contour_env tests)
G90 G21
M3 S18000
G0 Z5
G0 X10 Y10
G1 Z1 F200
G1 X60 F1200
G1 Y40
G1 X10
G1 Y10
G0 Z5
M5
M30
