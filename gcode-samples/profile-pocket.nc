(contourcheck sample: a finishing pass around a pocket profile mixing lines and arcs)
(200 x 120 mm outline with R15 corners, a semicircular R30 notch in the top side,)
(entered by a tangential arc; F800 mm/min, continuous path mode.)
G21 G17 G90 G94 G40 G49
G0 X-15 Y-60 Z10
G1 Z-2 F200
G64 P0.01
G3 X0 Y-75 I15 J0 F800         (tangential R15 arc lead-in to the bottom side)
G1 X85
G3 X100 Y-60 I0 J15            (R15 corner)
G1 Y45
G3 X85 Y60 I-15 J0
G1 X30
G2 X-30 Y60 I-30 J0            (R30 notch, clockwise into the material side)
G1 X-85
G3 X-100 Y45 I0 J-15
G1 Y-60
G3 X-85 Y-75 I15 J0
G1 X0
G3 X15 Y-60 I0 J15             (tangential lead-out)
G0 Z10
M30
