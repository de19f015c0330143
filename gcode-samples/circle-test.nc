%
(contourcheck sample: ISO 230-4 style circular test)
(R100 mm at F1000 mm/min, counter-clockwise then clockwise, centre at X0 Y0.)
(Each circle is entered and left along its tangent, so that no corner slows the feed)
(on the circle itself; the quadrant crossings at X100 Y0, X0 Y100, X-100 Y0 and X0 Y-100)
(are where the axes reverse.)
O0230
N10 G21 G17 G90 G94 G40 G49 G80
N20 G64 P0.005
N30 G0 X100. Y-20. Z5.
N40 G1 Z0 F500
N50 G1 Y0 F1000           (tangential lead-in, +Y at the 0 degree point)
N60 G3 X100. Y0 I-100. J0 (full circle, counter-clockwise)
N70 G1 Y20.               (tangential lead-out)
N80 G1 Y0                 (back in along the tangent, now -Y)
N90 G2 X100. Y0 I-100. J0 (full circle, clockwise)
N100 G1 Y-20.             (lead-out)
N110 G0 Z5.
N120 M30
%
