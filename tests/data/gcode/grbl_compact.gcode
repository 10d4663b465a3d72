; grbl job exported by a hobby CAM
g21 g90 g17
g94
m3 s10000
g0 z6
g0 x10 y10
g1 z3 f200
g1x40y10f900
g1x40y40
g2x10y40r15
g1x10y10
g4p0.5
g0z6
g0x0y0
m5
m2
