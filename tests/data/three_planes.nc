%
(three_planes.nc -- a 10 mm radius full circle in each of the three principal planes)
(on three faces of a 30 mm cube: G17 XY at Z0, G18 ZX at Y0, G19 YZ at X0)
(mm, absolute; I/J/K incremental from the arc start; feed 1500 mm/min = 0.025 m/s)
(linking moves are G01 feed moves, exact stop at each sharp junction)
N10 G21 G90 G17 G61          (exact stop at every corner)
N20 G01 X5.000 Y15.000 Z0.000 F1500
N30 G17 G03 X5.000 Y15.000 I10.000 J0.000      (XY circle, centre 15,15,0, CCW)
N40 G01 X5.000 Y0.000 Z15.000
N50 G18 G02 X5.000 Z15.000 I10.000 K0.000      (ZX circle, centre 15,0,15, CW about +Y)
N60 G01 X0.000 Y5.000 Z15.000
N70 G19 G03 Y5.000 Z15.000 J10.000 K0.000      (YZ circle, centre 0,15,15, CCW about +X)
N80 G01 X0.000 Y0.000 Z0.000
%
