(contourcheck sample: the paper's straight line at 60 degrees to X, F120 mm/min)
(Wang et al., section 3.1.1: x = F t cos 60, y = F t sin 60. 40 mm take 20 s.)
G21 G17 G90 G94 G61
G0 X0 Y0
G1 X20.0 Y34.641016 F120
M2
