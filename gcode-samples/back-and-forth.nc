(contourcheck sample: each axis 200 mm out and back at F1000, exact stops at the ends)
(Long travel at constant speed: where scale and lead errors, proportional to position)
(or cyclic with it, show.)
G21 G17 G90 G94 G61
G0 X0 Y0
G1 X200 F1000
X0
Y200
Y0
M2
