(contourcheck sample: a small circle for identification - R10 at F800, about 5 s)
(one turn each way: every quadrant change is a reversal of one axis, where friction)
(leaves its spikes. Record it with the commanded positions.)
G21 G17 G90 G94
G0 X10 Y0
G3 X10 Y0 I-10 J0 F800
G2 X10 Y0 I-10 J0
M2
