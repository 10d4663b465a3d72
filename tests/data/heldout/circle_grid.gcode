(CIRCLE GRID -- hole milling as a fabrication generator emits it: a 3 x 2 array)
(of R8 full circles, a rapid and a plunge between them; mm, absolute)
G90 (absolute mode)
G21 (metric mm)
F1200 (feed rate)
(circle x=-24 y=-10 r=8)
G0 X-32 Y-10 (rapid start)
G1 Z-1
G17 G2 X-32 Y-10 I8 J0 Z-1
G0 Z5
(circle x=0 y=-10 r=8)
G0 X-8 Y-10
G1 Z-1
G17 G2 X-8 Y-10 I8 J0 Z-1
G0 Z5
(circle x=24 y=-10 r=8)
G0 X16 Y-10
G1 Z-1
G17 G2 X16 Y-10 I8 J0 Z-1
G0 Z5
(circle x=24 y=14 r=8)
G0 X16 Y14
G1 Z-1
G17 G3 X16 Y14 I8 J0 Z-1
G0 Z5
(circle x=0 y=14 r=8)
G0 X-8 Y14
G1 Z-1
G17 G3 X-8 Y14 I8 J0 Z-1
G0 Z5
(circle x=-24 y=14 r=8)
G0 X-32 Y14
G1 Z-1
G17 G3 X-32 Y14 I8 J0 Z-1
G0 Z10
M30
