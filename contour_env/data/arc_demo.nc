%
(arc_demo.nc -- lines and G02/G03 arcs in the XY plane, I/J and R forms)
(mm, absolute; I/J are incremental from the arc start point)
N10 G21 G90 G17
N20 G00 X10 Y0                 (rapid from the origin to the start of the contour)
N30 G01 X40 Y0 F900            (900 mm/min = 0.015 m/s)
N40 G03 X50 Y10 I0 J10         (CCW 90 deg, centre 40,10, I/J form)
N50 G01 Y30
N60 G03 X40 Y40 R10            (CCW 90 deg, centre 40,30, R > 0: shorter arc)
N70 G01 X35
N80 G02 X15 Y40 R10            (CW 180 deg notch, centre 25,40, R = half the chord)
N90 G01 X10
N100 G03 X0 Y30 I0 J-10        (CCW 90 deg, centre 10,30)
N110 G01 Y10
N120 G03 X10 Y0 R-10           (CCW 270 deg, centre 0,0, R < 0: longer arc)
N130 G00 X30 Y20               (rapid to the pocket)
N140 G02 X30 Y20 I-5 J0 F600   (CW full circle, centre 25,20, 600 mm/min)
N150 G00 X0 Y0                 (rapid home)
%
