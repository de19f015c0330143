%
(contourcheck sample: a helix and a circle in the ZX plane)
O0240
N10 G21 G17 G90 G94 G40 G49 G80
N20 G64 P0.005
N30 G0 X50. Y0 Z5.
N40 G1 Z0 F300
N50 G3 X50. Y0 Z-10. I-50. J0 P2 F1000 (helix: two turns down 10 mm)
N60 G1 X60.                (out of the helix, +X)
N70 G18 G3 Z-10. X60. K-20. I0 (full circle in ZX about X60 Z-30, entered along its tangent)
N80 G17 G0 Z5.
N90 M30
%
