%
O2001 (CAM POST, CENTROID STYLE: G53 WITHOUT AXIS WORDS)
(written for the contour_env tests after FreeCAD's Centroid post output)
G90 G80 G40 G49
G53 G00 G17
G21
T1 M6
G54
S10000 M3
G0 X-20. Y-20.
G43 H1 Z15.
G0 Z5.
G1 Z2. F300.
G1 X20. F900.
G1 Y20.
G3 X10. Y30. I-10. J0.
G1 X-20.
G1 Y-20.
G0 Z15.
M5
G53 G00 G17 (no axis words: moves nothing)
M30
%
