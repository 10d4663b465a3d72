%
O2001 (CORNER-BLEND: PART PROFILE, FRICTION TABLE)
(a part-like profile: corners of 15, 90, 120, 45 and 60 degrees, no leg axis-aligned)
(continuous-path mode G64 with a 0.01 mm path tolerance; mm; start at the origin)
G21 G90 G17 G94
G54
G64 P0.01
G01 X14.095 Y5.130 F1200.
X23.925 Y12.013
X13.601 Y26.758
X7.684 Y14.070
X-3.592 Y9.965
X-5.329 Y0.117
M30
%
