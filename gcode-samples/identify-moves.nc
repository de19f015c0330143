(contourcheck sample: a short record for identification - about 5 s moving both axes)
(both ways, at three feeds, with an arc, so that lag, acceleration, friction at the)
(stops and reversals all show. Record it with the commanded positions.)
G21 G17 G90 G94
G0 X0 Y0
G1 X20 F1000
Y12 F600
G3 X8 Y12 I-6 J0 F800
G1 X0 Y0 F1000
M2
