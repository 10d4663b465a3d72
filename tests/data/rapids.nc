%
(rapids.nc -- a G00 rapid to the start of the cut, two cutting lines, a G00 rapid back)
(mm, absolute, XY plane; cutting feed 600 mm/min = 0.01 m/s, rapids at the same feed,)
(the highest F of the program; exact stop at every corner)
N10 G21 G90 G17 G61          (exact stop at every corner)
N20 G00 X5 Y0
N30 G01 X15 Y0 F600
N40 G01 X15 Y10
N50 G00 X0 Y0
%
