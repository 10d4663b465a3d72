%
O5000 (SIDE FILLETS G18 G19)
G90 G21 G17 G94
G54
T5 M6 (6MM BALL)
S15000 M3
G0 G43 H5 Z25.
G0 X-30. Y-20.
G1 Z15. F600.
G1 X-10. F1200.
(G18: quarter fillet in the ZX plane, from Z15 down to Z5 moving +X)
G18 G2 X0. Z5. I10. K0.
G1 X20.
(G18: back up, R form)
G3 X30. Z15. R10.
G17 G1 Y0.
(G19: quarter fillet in the YZ plane)
G19 G2 Y10. Z5. J10. K0.
G1 Y20.
G3 Y30. Z15. J0. K10.
G17 G0 Z25.
M5
M30
%
