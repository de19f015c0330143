%
(The circular test of circle-test.nc at half the radius: R50 mm at F1000 mm/min,)
(counter-clockwise then clockwise, centre at X0 Y0, each circle entered and left along)
(its tangent. The same speed and the same reversals at the quadrant crossings in half)
(the time, for the tests whose cause shows at speed and at the reversals.)
O0231
N10 G21 G17 G90 G94 G40 G49 G80
N20 G64 P0.005
N30 G0 X50. Y-20. Z5.
N40 G1 Z0 F500
N50 G1 Y0 F1000           (tangential lead-in, +Y at the 0 degree point)
N60 G3 X50. Y0 I-50. J0   (full circle, counter-clockwise)
N70 G1 Y20.               (tangential lead-out)
N80 G1 Y0                 (back in along the tangent, now -Y)
N90 G2 X50. Y0 I-50. J0   (full circle, clockwise)
N100 G1 Y-20.             (lead-out)
N110 G0 Z5.
N120 M30
%
