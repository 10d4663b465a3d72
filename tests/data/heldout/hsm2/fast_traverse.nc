%
O1001 (FAST TRAVERSE 3400)
(hsm2 held-out: F120000 mm/min = 2 m/s, 5x the top training feed of 400 mm/s, two 3.4 m passes)
(at 15 deg, exact stop between them; at the 2 m/s2 and 40 m/s3 of a program the passes reach the feed)
(T2 | 10MM FLAT ENDMILL | H2)
N10 G21 G90 G17 G94
N20 G61 (EXACT STOP)
N30 G0 G54 X-1642.074 Y-439.992
N40 G1 Z-2. F300.
N50 G1 X1642.074 Y439.992 F120000.
N60 G1 X1626.545 Y497.948 F6000.
N70 G1 X-1657.603 Y-382.037 F120000.
N80 G0 Z10.
N90 M30
%
