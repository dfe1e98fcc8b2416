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
:mod:`phasemap.motion.integrate.dopri5`.  Stage i of ``dop853.f`` (1-based) is row i - 1 of
the stage array ``K``; the systems are autonomous, so the nodes c_i are not
needed.
"""

from __future__ import annotations

import numpy as np

from phasemap.motion.integrate import dopri5 as _dopri5
from phasemap.motion.integrate.dopri5 import combine, run_stages

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

#: Modules compiled into these templates besides this one (see phasemap.core.compile).
SOURCES = (_dopri5,)

RHS = None  # the model's right-hand side, a compile-time global (phasemap.motion.integrate)

# Stage i of dop853.f (1-based) fills row i - 1 of K: (that row, the rows it
# combines, its coupling coefficients a_ij), nonzero only.
#: Stages 2..12 of a step.
STAGES = (
    (1, (0,), (0.05260015195876773,)),
    (2, (0, 1), (0.0197250569845379, 0.0591751709536137)),
    (3, (0, 2), (0.02958758547680685, 0.08876275643042054)),
    (4, (0, 2, 3), (0.2413651341592667, -0.8845494793282861, 0.924834003261792)),
    (5, (0, 3, 4), (0.037037037037037035, 0.17082860872947386, 0.12546768756682242)),
    (6, (0, 3, 4, 5), (0.037109375, 0.17025221101954405, 0.06021653898045596, -0.017578125)),
    (7, (0, 3, 4, 5, 6), (0.03709200011850479, 0.17038392571223998, 0.10726203044637328,
                          -0.015319437748624402, 0.008273789163814023)),
    (8, (0, 3, 4, 5, 6, 7), (0.6241109587160757, -3.3608926294469414, -0.868219346841726,
                             27.59209969944671, 20.154067550477894, -43.48988418106996)),
    (9, (0, 3, 4, 5, 6, 7, 8), (0.47766253643826434, -2.4881146199716677, -0.590290826836843,
                                21.230051448181193, 15.279233632882423, -33.28821096898486,
                                -0.020331201708508627)),
    (10, (0, 3, 4, 5, 6, 7, 8, 9), (-0.9371424300859873, 5.186372428844064, 1.0914373489967295,
                                    -8.149787010746927, -18.52006565999696, 22.739487099350505,
                                    2.4936055526796523, -3.0467644718982196)),
    (11, (0, 3, 4, 5, 6, 7, 8, 9, 10), (2.273310147516538, -10.53449546673725, -2.0008720582248625,
                                        -17.9589318631188, 27.94888452941996, -2.8589982771350235,
                                        -8.87285693353063, 12.360567175794303, 0.6433927460157636)),
)
#: Stages 14..16, of the dense output only.
DENSE_STAGES = (
    (13, (0, 6, 7, 8, 9, 10, 11, 12), (0.056167502283047954, 0.25350021021662483,
                                       -0.2462390374708025, -0.12419142326381637,
                                       0.15329179827876568, 0.00820105229563469,
                                       0.007567897660545699, -0.008298)),
    (14, (0, 5, 6, 7, 10, 11, 12, 13), (0.03183464816350214, 0.028300909672366776,
                                        0.053541988307438566, -0.05492374857139099,
                                        -0.00010834732869724932, 0.0003825710908356584,
                                        -0.00034046500868740456, 0.1413124436746325)),
    (15, (0, 5, 6, 7, 8, 12, 13, 14), (-0.42889630158379194, -4.697621415361164, 7.683421196062599,
                                       4.06898981839711, 0.3567271874552811,
                                       -0.0013990241651590145, 2.9475147891527724,
                                       -9.15095847217987)),
)

#: Rows of K in the solution and the error estimates: stages 1, 6..12.
B_ROWS = (0, 5, 6, 7, 8, 9, 10, 11)
#: Weights b_i of the order-8 solution.
B = (0.054293734116568765, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
     0.3111643669578199, -0.1521609496625161, 0.20136540080403034, 0.04471061572777259)
#: Error estimators: order-5 (E5) and order-3 (E3 = b - bhh) weights.
E5 = (0.01312004499419488, -1.2251564463762044, -0.4957589496572502, 1.6643771824549864,
      -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294)
E3 = (-0.18980075407240762, 4.450312892752409, 1.8915178993145003, -5.801203960010585,
      -0.4226823213237919, -0.1521609496625161, 0.20136540080403034, 0.02265179219836082)

#: Rows of K in the dense output's rows 4..7: stages 1, 6..16.
D_ROWS = (0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)
D4 = (-8.428938276109013, 0.5667149535193777, -3.0689499459498917, 2.38466765651207,
      2.117034582445028, -0.871391583777973, 2.2404374302607883, 0.6315787787694688,
      -0.08899033645133331, 18.148505520854727, -9.194632392478356, -4.436036387594894)
D5 = (10.427508642579134, 242.28349177525817, 165.20045171727028, -374.5467547226902,
      -22.113666853125306, 7.733432668472264, -30.674084731089398, -9.332130526430229,
      15.697238121770845, -31.139403219565178, -9.35292435884448, 35.81684148639408)
D6 = (19.985053242002433, -387.0373087493518, -189.17813819516758, 527.8081592054236,
      -11.57390253995963, 6.8812326946963, -1.0006050966910838, 0.7777137798053443,
      -2.778205752353508, -60.19669523126412, 84.32040550667716, 11.99229113618279)
D7 = (-25.69393346270375, -154.18974869023643, -231.5293791760455, 357.6391179106141,
      93.40532418362432, -37.45832313645163, 104.0996495089623, 29.8402934266605,
      -43.53345659001114, 96.32455395918828, -39.17726167561544, -149.72683625798564)


def step_template(v, y, h, branch, K, yt, y1, rtol, atol):
    """One DOP853 step; returns the error norm (see :mod:`phasemap.motion.integrate.dopri5`)."""
    ny = y.shape[0]
    run_stages(RHS, v, y, h, branch, K, yt, STAGES)
    acc5 = 0.0
    acc3 = 0.0
    for i in range(ny):
        y1[i] = y[i] + h * combine(K, i, B_ROWS, B)
        sk = atol + rtol * max(abs(y[i]), abs(y1[i]))
        e5 = combine(K, i, B_ROWS, E5) / sk
        e3 = combine(K, i, B_ROWS, E3) / sk
        acc5 += e5 * e5
        acc3 += e3 * e3
    if acc5 == 0.0 and acc3 == 0.0:
        e = 0.0
    else:
        e = abs(h) * acc5 / np.sqrt((acc5 + 0.01 * acc3) * ny)
    if e <= 1.0:
        RHS(v, y1, branch, K, FSAL)  # first same as last; v now holds y1
    return e


def dense_template(v, y, y1, h, branch, K, yt, r):
    """The order-7 continuous extension of the step y -> y1 into ``r`` (8 rows)."""
    ny = y.shape[0]
    run_stages(RHS, v, y, h, branch, K, yt, DENSE_STAGES)
    for i in range(ny):
        dy = y1[i] - y[i]
        r[0, i] = y[i]
        r[1, i] = dy
        r[2, i] = h * K[0, i] - dy
        r[3, i] = 2.0 * dy - h * (K[FSAL, i] + K[0, i])
        r[4, i] = h * combine(K, i, D_ROWS, D4)
        r[5, i] = h * combine(K, i, D_ROWS, D5)
        r[6, i] = h * combine(K, i, D_ROWS, D6)
        r[7, i] = h * combine(K, i, D_ROWS, D7)
