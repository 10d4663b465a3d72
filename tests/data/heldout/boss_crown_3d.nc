%
O5200 (BOSS CROWN - 3D PASS)
G90 G21 G17 G94
G54
T7 M6 (8MM BALL)
S14000 M3
G0 G43 H7 Z20.
G0 X-30. Y-6.
G1 Z0. F500.
G64 P0.02
G1 X-10. Y-3. F1200.
(crown over the boss in the ZX plane, the tool moving +X)
G18 G3 X0. Z10. I10. K0.
G3 X10. Z0. I0. K-10.
G17 G1 X30. Y3.
(step over in Y, then back over the crown)
G1 Y9.
G1 X10.
G18 G2 X0. Z10. I-10. K0.
G2 X-10. Z0. I0. K-10.
G17 G1 X-30. Y12. Z1.
G0 Z20.
M5
M30
%
