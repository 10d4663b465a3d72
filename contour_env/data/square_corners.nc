%
(square_corners.nc -- 40 mm square with four sharp 90 degree corners)
(mm, absolute, XY plane; starts and ends at the origin, feed 1200 mm/min = 0.02 m/s)
N10 G21 G90 G17 G61          (exact stop at every corner)
N20 G01 X40.000 Y0.000 F1200
N30 X40.000 Y40.000
N40 X0.000 Y40.000
N50 X0.000 Y0.000
%
