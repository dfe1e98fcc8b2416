r"""Dormand-Prince 8(5,3) (``DOP853``): one step and its dense output of order 7.

The explicit Runge-Kutta method of order 8 of Dormand and Prince, as in
Hairer's ``dop853.f`` (Hairer, Norsett and Wanner, *Solving ODE I*, II.10)
and scipy's ``DOP853``, whose coefficients these are
(``scipy/integrate/_ivp/dop853_coefficients.py``, printed here to double
precision):

* 12 stages per attempted step; the 13th, f(y1), only on an accepted step,
  where it is the next step's first stage (first same as last);
* the error estimate of ``dop853``: an order-5 estimate ``err5`` corrected by
  an order-3 one ``err3``, ``|h| ||err5||^2 / sqrt(||err5||^2 + 0.01
  ||err3||^2)`` (RMS norms over ``atol + rtol max(|y|, |y1|)``), with the
  step-size exponent 1/8;
* the continuous extension of order 7: three more stages (at c = 0.1, 0.2 and
  7/9), computed only after an accepted step whose dense output is used
  (event location, requested times);
* Hairer's stiffness test with the stages 12 and 13 (both at t + h): h |lambda|
  ~ h ||f(y1) - f(y12)|| / ||y1 - y12||, against the stability boundary 6.1.

The contracts of ``step_template`` and ``dense_template`` are those of
:mod:`phasemap._dopri5`.  Stage i of ``dop853.f`` (1-based) is row i - 1 of
the stage array ``K``; the systems are autonomous, so the nodes c_i are not
needed.
"""

from __future__ import annotations

import numpy as np

#: The integrator's name for the method (``simulate(method=...)``).
NAME = "DOP853"
DESCRIPTION = "Dormand-Prince 8(5,3), dense output of order 7"
#: Rows of the stage array: 12 stages, f(y1) and the 3 stages of the dense output.
N_STAGES = 16
#: The row of K that holds f(y1) after an accepted step.
FSAL = 12
#: Rows of the dense output.
N_DENSE = 8
#: Exponent of the step-size controller and of the initial step (dop853's 1/8).
EXPONENT = 1.0 / 8.0
#: Hairer's stiffness test: h |lambda| beyond this for 15 accepted steps (dop853.f).
STIFF_BOUND = 6.1

RHS = None  # the model's right-hand side, a compile-time global (phasemap.integrate)

# Coupling coefficients a_ij (1-based stages, as in dop853.f), nonzero only.
A2_1 = 0.05260015195876773
A3_1 = 0.0197250569845379
A3_2 = 0.0591751709536137
A4_1 = 0.02958758547680685
A4_3 = 0.08876275643042054
A5_1 = 0.2413651341592667
A5_3 = -0.8845494793282861
A5_4 = 0.924834003261792
A6_1 = 0.037037037037037035
A6_4 = 0.17082860872947386
A6_5 = 0.12546768756682242
A7_1 = 0.037109375
A7_4 = 0.17025221101954405
A7_5 = 0.06021653898045596
A7_6 = -0.017578125
A8_1 = 0.03709200011850479
A8_4 = 0.17038392571223998
A8_5 = 0.10726203044637328
A8_6 = -0.015319437748624402
A8_7 = 0.008273789163814023
A9_1 = 0.6241109587160757
A9_4 = -3.3608926294469414
A9_5 = -0.868219346841726
A9_6 = 27.59209969944671
A9_7 = 20.154067550477894
A9_8 = -43.48988418106996
A10_1 = 0.47766253643826434
A10_4 = -2.4881146199716677
A10_5 = -0.590290826836843
A10_6 = 21.230051448181193
A10_7 = 15.279233632882423
A10_8 = -33.28821096898486
A10_9 = -0.020331201708508627
A11_1 = -0.9371424300859873
A11_4 = 5.186372428844064
A11_5 = 1.0914373489967295
A11_6 = -8.149787010746927
A11_7 = -18.52006565999696
A11_8 = 22.739487099350505
A11_9 = 2.4936055526796523
A11_10 = -3.0467644718982196
A12_1 = 2.273310147516538
A12_4 = -10.53449546673725
A12_5 = -2.0008720582248625
A12_6 = -17.9589318631188
A12_7 = 27.94888452941996
A12_8 = -2.8589982771350235
A12_9 = -8.87285693353063
A12_10 = 12.360567175794303
A12_11 = 0.6433927460157636
A14_1 = 0.056167502283047954
A14_7 = 0.25350021021662483
A14_8 = -0.2462390374708025
A14_9 = -0.12419142326381637
A14_10 = 0.15329179827876568
A14_11 = 0.00820105229563469
A14_12 = 0.007567897660545699
A14_13 = -0.008298
A15_1 = 0.03183464816350214
A15_6 = 0.028300909672366776
A15_7 = 0.053541988307438566
A15_8 = -0.05492374857139099
A15_11 = -0.00010834732869724932
A15_12 = 0.0003825710908356584
A15_13 = -0.00034046500868740456
A15_14 = 0.1413124436746325
A16_1 = -0.42889630158379194
A16_6 = -4.697621415361164
A16_7 = 7.683421196062599
A16_8 = 4.06898981839711
A16_9 = 0.3567271874552811
A16_13 = -0.0013990241651590145
A16_14 = 2.9475147891527724
A16_15 = -9.15095847217987

# Weights b_i of the order-8 solution (stages 1, 6..12).
B1 = 0.054293734116568765
B6 = 4.450312892752409
B7 = 1.8915178993145003
B8 = -5.801203960010585
B9 = 0.3111643669578199
B10 = -0.1521609496625161
B11 = 0.20136540080403034
B12 = 0.04471061572777259

# Error estimators: order-5 (E5) and order-3 (E3 = b - bhh) weights.
E5_1 = 0.01312004499419488
E5_6 = -1.2251564463762044
E5_7 = -0.4957589496572502
E5_8 = 1.6643771824549864
E5_9 = -0.35032884874997366
E5_10 = 0.3341791187130175
E5_11 = 0.08192320648511571
E5_12 = -0.022355307863886294
E3_1 = -0.18980075407240762
E3_6 = 4.450312892752409
E3_7 = 1.8915178993145003
E3_8 = -5.801203960010585
E3_9 = -0.4226823213237919
E3_10 = -0.1521609496625161
E3_11 = 0.20136540080403034
E3_12 = 0.02265179219836082

# Dense output: rows 4..7 of the interpolant, weights of stages 1, 6..16.
D4_1 = -8.428938276109013
D4_6 = 0.5667149535193777
D4_7 = -3.0689499459498917
D4_8 = 2.38466765651207
D4_9 = 2.117034582445028
D4_10 = -0.871391583777973
D4_11 = 2.2404374302607883
D4_12 = 0.6315787787694688
D4_13 = -0.08899033645133331
D4_14 = 18.148505520854727
D4_15 = -9.194632392478356
D4_16 = -4.436036387594894
D5_1 = 10.427508642579134
D5_6 = 242.28349177525817
D5_7 = 165.20045171727028
D5_8 = -374.5467547226902
D5_9 = -22.113666853125306
D5_10 = 7.733432668472264
D5_11 = -30.674084731089398
D5_12 = -9.332130526430229
D5_13 = 15.697238121770845
D5_14 = -31.139403219565178
D5_15 = -9.35292435884448
D5_16 = 35.81684148639408
D6_1 = 19.985053242002433
D6_6 = -387.0373087493518
D6_7 = -189.17813819516758
D6_8 = 527.8081592054236
D6_9 = -11.57390253995963
D6_10 = 6.8812326946963
D6_11 = -1.0006050966910838
D6_12 = 0.7777137798053443
D6_13 = -2.778205752353508
D6_14 = -60.19669523126412
D6_15 = 84.32040550667716
D6_16 = 11.99229113618279
D7_1 = -25.69393346270375
D7_6 = -154.18974869023643
D7_7 = -231.5293791760455
D7_8 = 357.6391179106141
D7_9 = 93.40532418362432
D7_10 = -37.45832313645163
D7_11 = 104.0996495089623
D7_12 = 29.8402934266605
D7_13 = -43.53345659001114
D7_14 = 96.32455395918828
D7_15 = -39.17726167561544
D7_16 = -149.72683625798564


def step_template(v, y, h, mode, K, yt, y1, rtol, atol):
    """One DOP853 step; returns the error norm (see :mod:`phasemap._dopri5`)."""
    ny = y.shape[0]
    for i in range(ny):
        yt[i] = y[i] + h * (A2_1 * K[0, i])
    RHS(v, yt, mode, K, 1)
    for i in range(ny):
        yt[i] = y[i] + h * (A3_1 * K[0, i] + A3_2 * K[1, i])
    RHS(v, yt, mode, K, 2)
    for i in range(ny):
        yt[i] = y[i] + h * (A4_1 * K[0, i] + A4_3 * K[2, i])
    RHS(v, yt, mode, K, 3)
    for i in range(ny):
        yt[i] = y[i] + h * (A5_1 * K[0, i] + A5_3 * K[2, i] + A5_4 * K[3, i])
    RHS(v, yt, mode, K, 4)
    for i in range(ny):
        yt[i] = y[i] + h * (A6_1 * K[0, i] + A6_4 * K[3, i] + A6_5 * K[4, i])
    RHS(v, yt, mode, K, 5)
    for i in range(ny):
        yt[i] = y[i] + h * (A7_1 * K[0, i] + A7_4 * K[3, i] + A7_5 * K[4, i] + A7_6 * K[5, i])
    RHS(v, yt, mode, K, 6)
    for i in range(ny):
        yt[i] = y[i] + h * (A8_1 * K[0, i] + A8_4 * K[3, i] + A8_5 * K[4, i] + A8_6 * K[5, i]
                            + A8_7 * K[6, i])
    RHS(v, yt, mode, K, 7)
    for i in range(ny):
        yt[i] = y[i] + h * (A9_1 * K[0, i] + A9_4 * K[3, i] + A9_5 * K[4, i] + A9_6 * K[5, i]
                            + A9_7 * K[6, i] + A9_8 * K[7, i])
    RHS(v, yt, mode, K, 8)
    for i in range(ny):
        yt[i] = y[i] + h * (A10_1 * K[0, i] + A10_4 * K[3, i] + A10_5 * K[4, i]
                            + A10_6 * K[5, i] + A10_7 * K[6, i] + A10_8 * K[7, i]
                            + A10_9 * K[8, i])
    RHS(v, yt, mode, K, 9)
    for i in range(ny):
        yt[i] = y[i] + h * (A11_1 * K[0, i] + A11_4 * K[3, i] + A11_5 * K[4, i]
                            + A11_6 * K[5, i] + A11_7 * K[6, i] + A11_8 * K[7, i]
                            + A11_9 * K[8, i] + A11_10 * K[9, i])
    RHS(v, yt, mode, K, 10)
    for i in range(ny):
        yt[i] = y[i] + h * (A12_1 * K[0, i] + A12_4 * K[3, i] + A12_5 * K[4, i]
                            + A12_6 * K[5, i] + A12_7 * K[6, i] + A12_8 * K[7, i]
                            + A12_9 * K[8, i] + A12_10 * K[9, i] + A12_11 * K[10, i])
    RHS(v, yt, mode, K, 11)
    acc5 = 0.0
    acc3 = 0.0
    for i in range(ny):
        y1[i] = y[i] + h * (B1 * K[0, i] + B6 * K[5, i] + B7 * K[6, i] + B8 * K[7, i]
                            + B9 * K[8, i] + B10 * K[9, i] + B11 * K[10, i] + B12 * K[11, i])
        sk = atol + rtol * max(abs(y[i]), abs(y1[i]))
        e5 = (E5_1 * K[0, i] + E5_6 * K[5, i] + E5_7 * K[6, i] + E5_8 * K[7, i] + E5_9 * K[8, i]
              + E5_10 * K[9, i] + E5_11 * K[10, i] + E5_12 * K[11, i]) / sk
        e3 = (E3_1 * K[0, i] + E3_6 * K[5, i] + E3_7 * K[6, i] + E3_8 * K[7, i] + E3_9 * K[8, i]
              + E3_10 * K[9, i] + E3_11 * K[10, i] + E3_12 * K[11, i]) / sk
        acc5 += e5 * e5
        acc3 += e3 * e3
    if acc5 == 0.0 and acc3 == 0.0:
        e = 0.0
    else:
        e = abs(h) * acc5 / np.sqrt((acc5 + 0.01 * acc3) * ny)
    if e <= 1.0:
        RHS(v, y1, mode, K, 12)  # first same as last; v now holds y1
    return e


def dense_template(v, y, y1, h, mode, K, yt, r):
    """The order-7 continuous extension of the step y -> y1 into ``r`` (8 rows)."""
    ny = y.shape[0]
    for i in range(ny):
        yt[i] = y[i] + h * (A14_1 * K[0, i] + A14_7 * K[6, i] + A14_8 * K[7, i]
                            + A14_9 * K[8, i] + A14_10 * K[9, i] + A14_11 * K[10, i]
                            + A14_12 * K[11, i] + A14_13 * K[12, i])
    RHS(v, yt, mode, K, 13)
    for i in range(ny):
        yt[i] = y[i] + h * (A15_1 * K[0, i] + A15_6 * K[5, i] + A15_7 * K[6, i]
                            + A15_8 * K[7, i] + A15_11 * K[10, i] + A15_12 * K[11, i]
                            + A15_13 * K[12, i] + A15_14 * K[13, i])
    RHS(v, yt, mode, K, 14)
    for i in range(ny):
        yt[i] = y[i] + h * (A16_1 * K[0, i] + A16_6 * K[5, i] + A16_7 * K[6, i]
                            + A16_8 * K[7, i] + A16_9 * K[8, i] + A16_13 * K[12, i]
                            + A16_14 * K[13, i] + A16_15 * K[14, i])
    RHS(v, yt, mode, K, 15)
    for i in range(ny):
        dy = y1[i] - y[i]
        r[0, i] = y[i]
        r[1, i] = dy
        r[2, i] = h * K[0, i] - dy
        r[3, i] = 2.0 * dy - h * (K[12, i] + K[0, i])
        r[4, i] = h * (D4_1 * K[0, i] + D4_6 * K[5, i] + D4_7 * K[6, i] + D4_8 * K[7, i]
                      + D4_9 * K[8, i] + D4_10 * K[9, i] + D4_11 * K[10, i] + D4_12 * K[11, i]
                      + D4_13 * K[12, i] + D4_14 * K[13, i] + D4_15 * K[14, i]
                      + D4_16 * K[15, i])
        r[5, i] = h * (D5_1 * K[0, i] + D5_6 * K[5, i] + D5_7 * K[6, i] + D5_8 * K[7, i]
                      + D5_9 * K[8, i] + D5_10 * K[9, i] + D5_11 * K[10, i] + D5_12 * K[11, i]
                      + D5_13 * K[12, i] + D5_14 * K[13, i] + D5_15 * K[14, i]
                      + D5_16 * K[15, i])
        r[6, i] = h * (D6_1 * K[0, i] + D6_6 * K[5, i] + D6_7 * K[6, i] + D6_8 * K[7, i]
                      + D6_9 * K[8, i] + D6_10 * K[9, i] + D6_11 * K[10, i] + D6_12 * K[11, i]
                      + D6_13 * K[12, i] + D6_14 * K[13, i] + D6_15 * K[14, i]
                      + D6_16 * K[15, i])
        r[7, i] = h * (D7_1 * K[0, i] + D7_6 * K[5, i] + D7_7 * K[6, i] + D7_8 * K[7, i]
                      + D7_9 * K[8, i] + D7_10 * K[9, i] + D7_11 * K[10, i] + D7_12 * K[11, i]
                      + D7_13 * K[12, i] + D7_14 * K[13, i] + D7_15 * K[14, i]
                      + D7_16 * K[15, i])
