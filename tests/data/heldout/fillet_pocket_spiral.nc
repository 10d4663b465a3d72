%
(FILLET POCKET AND SPIRAL -- a pocketing program laid out as public CAM samples are:)
(an outer rectangle with R6 corner fillets, G02 R, then a spiral of full circles, G03 I)
(T3 | 6MM FLAT ENDMILL | H3)
G17 G21 G90 G94 G54
M3 S9000
G0 X-19. Y-20. Z5.
G1 Z-1. F150.
G1 X19. Y-20. F900.
G2 X25. Y-14. R6.
G1 X25. Y14.
G2 X19. Y20. R6.
G1 X-19. Y20.
G2 X-25. Y14. R6.
G1 X-25. Y-14.
G2 X-19. Y-20. R6.
G0 Z3.
G0 X12. Y0.
G1 Z-2. F150.
G3 X12. Y0. I-12. J0. F600.
G1 X9.5 Y0.
G3 X9.5 Y0. I-9.5 J0.
G1 X7. Y0.
G3 X7. Y0. I-7. J0.
G1 X4.5 Y0.
G3 X4.5 Y0. I-4.5 J0.
G0 Z5.
M5
M30
%
