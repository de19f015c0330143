(contourcheck sample: a slow circle, R10 mm at F100 mm/min)
(Each axis sweeps its speed through zero twice per turn at 100 mm/min peak: where)
(low-speed friction - stick-slip, Stribeck - shows in the error.)
G21 G17 G90 G94 G64
G0 X10 Y-3
G1 Y0 F100
G3 X10 Y0 I-10 J0
G1 Y3
M2
