%
(five_axis_tuning.nc: the tuning program of the five-axis pid baseline, scripts/five_axis_tune.py)
(not a named case: five joint-space blocks from home with x, y, z, A and C reversals;)
(x and y up to 0.25 m/s and 2 m/s^2, A and C up to 0.8 rad/s and 5 rad/s^2; mm and degrees)
G21 G90 G94
G01 X60 Y-40 Z10 A-12 C6 F15000
G01 X-50 Y30 Z-10 A-24 C-6 F18000
G01 X40 Y60 Z20 A-16 C8 F18000
G01 X-70 Y-20 Z0 A-6 C-8 F15000
G01 X0 Y0 Z5 A-19 C0 F12000
M30
%
