%
(corner_rotated_30.nc -- the sharp-corner case's two 30 mm legs and 90 degree corner,)
(rotated by 30 degrees so that both axes move on both legs; mm, absolute, XY plane,)
(feed 1200 mm/min = 0.02 m/s, exact stop at the corner)
N10 G21 G90 G17 G61          (exact stop at every corner)
N20 G01 X25.981 Y15.000 F1200
N30 X10.981 Y40.981
%
