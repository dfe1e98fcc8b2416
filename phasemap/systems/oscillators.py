r"""Friction oscillators: a block on a spring, riding on a belt or forced on a floor.

A block of mass m on a spring k (its other end fixed at x = 0) rides on a rough floor
or belt; gravity g gives the normal force N = m g, so that with g = 1 (and m = 1) a
friction coefficient is the friction force itself.  The block's position is x, its
height y (fixed by the contact).  Declared, as every system: the equations follow from
the Lagrangian L = m (x'^2 + y'^2)/2 - k x^2/2 - m g y and the contact's law.

* :data:`BELT`: the belt moves at the speed v; Coulomb friction with a static
  coefficient f_s above the kinetic one f_k.  While the block sticks it moves with the
  belt (x' = v) until the spring's pull k x reaches f_s m g; it then slips with
  m x'' = -k x + f_k m g (the belt drags it) until its speed is the belt's again.  The
  stick-slip orbit (m = k = g = 1, delta = f_s - f_k) sticks for 2 delta / v, slips for
  pi + 2 arctan(v / delta), and reaches down to x_min = f_k - sqrt(delta^2 + v^2).
* :data:`STRIBECK_BELT`: the same with the slip coefficient falling with the relative
  speed, f_s / (1 + delta |v_rel|) (Leine, van Campen et al. 1998).
* :data:`DEN_HARTOG`: a floor at rest, the block forced by F0 cos(Omega t): Den Hartog's
  (1931) oscillator with Coulomb damping, x'' + x = cos(Omega t) - r sgn x' with
  m = k = F0 = g = 1 and r = f.
* :data:`DUFFING`: the same forced block on a hardening spring (potential
  k x^2/2 + beta x^4/4) with viscous damping c as well, m x'' + c x' + k x + beta x^3 =
  F0 cos(Omega t) - f m g sgn x'.  Its resonance curve bends to the right and folds (the
  defaults: a large and a small stable orbit coexist for Omega in (1.406, 1.573)); with
  k = 0 it is Ueda's oscillator, whose period-one orbit doubles its period.

These run in full coordinates: a moving surface, static friction above kinetic,
friction that depends on the speed and forcing in time do not fit a reduced model.
:func:`phasemap.simulate` moves them, :func:`phasemap.classify` and
:class:`phasemap.Scene` map them (:mod:`phasemap.maps.full`).

Leine R. I., van Campen D. H., de Kraker A., van den Steen L. (1998), Stick-slip
vibrations induced by alternate friction models, Nonlinear Dynamics 16, 41-54.
Den Hartog J. P. (1931), Forced vibrations with combined Coulomb and viscous friction,
Trans. ASME 53 (APM-53-9), 107-115.
"""

from __future__ import annotations

import sympy as sp

from phasemap.declare import (SLIP_SPEED, TIME, Body, Coordinate, Parameter, PointContact,
                              Rate, System)

m = Parameter("m", "kg", "mass of the block", default=1.0, lower=0.0, lower_open=True)
k = Parameter("k", "N m-1", "stiffness of the spring", default=1.0, lower=0.0, lower_open=True)
g = Parameter("g", "m s-2", "gravitational acceleration (N = m g)", default=1.0, lower=0.0,
              lower_open=True)
x = Coordinate("x", "m", "position of the block (spring unstretched at 0)", default=0.0,
               rate=Rate("xdot", "m s-1", "velocity of the block", symbol="\\dot x"))
y = Coordinate("y", "m", "height of the block above the floor")


def _block(name, title, citation, parameters, contact, **kw) -> System:
    return System(name, title, citation, coordinates=(x, y), parameters=(m, k, g, *parameters),
                  bodies=(Body(m, (x, y)),), potential=k * x**2 / 2 + m * g * y,
                  contacts=(contact,), **kw)


_v = Parameter("v", "m s-1", "speed of the belt", default=0.2)
_fs = Parameter("f_s", "1", "static friction coefficient", default=1.0, lower=0.0)
_fk = Parameter("f_k", "1", "kinetic friction coefficient", default=0.5, lower=0.0)

#: A block on a spring riding on a belt, Coulomb friction with f_s >= f_k.
BELT = _block(
    "belt", "A block on a spring riding on a moving belt, static and kinetic friction",
    "the classical stick-slip oscillator (Leine et al. 1998, Nonlinear Dynamics 16, 41-54)",
    (_v, _fs, _fk),
    PointContact("belt", point=(x, y), normal=(0, 1), friction=_fk, static_friction=_fs,
                 surface_velocity=_v, long_name="the block on the belt"))

_delta = Parameter("delta", "s m-1", "decay of the slip coefficient with the speed",
                   default=3.0, lower=0.0)

#: A block on a spring riding on a belt, with the Stribeck-like law f_s / (1 + delta |v|).
STRIBECK_BELT = _block(
    "stribeck_belt", "A block on a spring riding on a moving belt, friction falling with "
    "the slip speed",
    "Leine R. I., van Campen D. H., de Kraker A., van den Steen L. (1998), Nonlinear "
    "Dynamics 16, 41-54",
    (_v, _fs, _delta),
    PointContact("belt", point=(x, y), normal=(0, 1),
                 friction=_fs / (1 + _delta * SLIP_SPEED), static_friction=_fs,
                 surface_velocity=_v, long_name="the block on the belt"))

_F0 = Parameter("F0", "N", "amplitude of the applied force", default=1.0)
_Omega = Parameter("Omega", "rad s-1", "angular frequency of the applied force", default=0.8,
                   lower=0.0, lower_open=True)
_f = Parameter("f", "1", "friction coefficient of the floor", default=0.2, lower=0.0)

#: Den Hartog's forced oscillator with Coulomb damping.
DEN_HARTOG = _block(
    "den_hartog", "Den Hartog's forced oscillator with Coulomb damping",
    "Den Hartog J. P. (1931), Trans. ASME 53 (APM-53-9), 107-115",
    (_F0, _Omega, _f),
    PointContact("floor", point=(x, y), normal=(0, 1), friction=_f,
                 long_name="the block on the floor"),
    forces={x: _F0 * sp.cos(_Omega * TIME)}, period=2 * sp.pi / _Omega)

_k0 = Parameter("k", "N m-1", "linear stiffness of the spring", default=1.0, lower=0.0)
_beta = Parameter("beta", "N m-3", "cubic stiffness of the spring (hardening)", default=1.0,
                  lower=0.0)
_c = Parameter("c", "kg s-1", "viscous damping", default=0.2, lower=0.0)
_F0d = Parameter("F0", "N", "amplitude of the applied force", default=0.5)
_Omegad = Parameter("Omega", "rad s-1", "angular frequency of the applied force",
                    default=1.3, lower=0.0, lower_open=True)
_fd = Parameter("f", "1", "friction coefficient of the floor", default=0.05, lower=0.0)

#: A forced oscillator with a hardening spring, viscous damping and Coulomb friction.
DUFFING = System(
    "duffing", "A forced hardening (Duffing) oscillator with viscous damping and Coulomb "
    "friction", "Duffing G. (1918), Erzwungene Schwingungen bei veraenderlicher "
    "Eigenfrequenz, Vieweg; with k = 0, Ueda Y. (1979), J. Stat. Phys. 20, 181-196",
    coordinates=(x, y), parameters=(m, _k0, g, _beta, _c, _F0d, _Omegad, _fd),
    bodies=(Body(m, (x, y)),), potential=_k0 * x**2 / 2 + _beta * x**4 / 4 + m * g * y,
    dissipation=_c * x.rate**2 / 2,
    contacts=(PointContact("floor", point=(x, y), normal=(0, 1), friction=_fd,
                           long_name="the block on the floor"),),
    forces={x: _F0d * sp.cos(_Omegad * TIME)}, period=2 * sp.pi / _Omegad)

#: The friction oscillators by name (they run in :func:`phasemap.simulate` by name).
OSCILLATORS = {s.name: s for s in (BELT, STRIBECK_BELT, DEN_HARTOG, DUFFING)}
