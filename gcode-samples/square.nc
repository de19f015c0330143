(contourcheck sample: a 100 mm square with sharp corners at F1000 mm/min)
(Under G64 the corners are passed at the speed the corner rules allow; the axes' lag)
(rounds them. G61 on the last side makes the final corner an exact stop.)
G21 G17 G90 G94
G0 X0 Y0 Z5
G1 Z0 F300
G64 P0.01
G1 X100 F1000
Y100
X0
G61
Y0
G0 Z5
M2
