r"""Phase curves omega(phi) of the one-degree-of-freedom systems: :func:`phase_curve`.

The ladder, the wheel and the hinge pendulum have one coordinate phi.  On a
*stage* the sign sigma of omega is fixed, so is the friction law, and with
u = omega^2 and phi'' = u'/2 (u' = du/dphi) the motion equation becomes a
first-order equation for u(phi).  :func:`phase_curve` follows u stage by stage
in phi, with no time stepping, and ends every stage at an exactly located event.

Stage equations and how they are solved
---------------------------------------
*Ladder* (equation (8) of :mod:`phasemap.models.ladder`): closed form
u = c0 e^{lam (phi - phi0)} + a sin phi + b cos phi with lam = 6 s f/(2 - f^2).
Near f = sqrt 2, |lam| grows without bound.  Every function of the stage has the
form p(phi) E + q(phi) with E = e^{lam (phi - phi0)}, p and q trigonometric, so
events are located on the *scaled* function (p E + q)/(1 + E): same sign and
zeros, evaluated as p/(1 + e^{-x}) + q e^{-x}/(1 + e^{-x}) for x > 0, so it never
overflows or forms inf - inf.  The reactions along the stage use
phi'' = (lam c0 E + a cos phi - b sin phi)/2, the derivative of the closed form,
so no O(lam) terms cancel.  Events are searched in tau = s (phi - phi0) >= 0 on
a grid that is uniform in phi (step 0.01 rad) and, where |lam| tau is large,
uniform in |lam| tau across the boundary layer of width 1/|lam|, then refined
with Brent's method to a relative 4 eps in tau.

*Hinge pendulum* (equation (34) of :mod:`phasemap.models.hinge_pendulum`):
l phi'' = -g sin phi - sigma k |Q_n|, with Q_n = l u + g cos phi and
k = delta/sqrt(l^2 - delta^2).  On a piece where q = sgn Q_n is fixed the
equation is linear with constant coefficients,

    u' + 2 sigma k q u = -(2 g / l)(sin phi + sigma k q cos phi),

solved by u = c0 e^{-2 sigma k q (phi - phi0)} + a sin phi + b cos phi with

    a = -6 sigma k q g / (l (1 + 4 k^2)),   b = 2 g (1 - 2 k^2) / (l (1 + 4 k^2))

(k = 0 gives energy conservation u - 2 g cos phi / l = const).  Along the
motion Q_n obeys sigma Q_n' = -3 g sigma sin phi - 2 k |Q_n|, so it crosses zero
transversally where sigma sin phi has the right sign; there u is continuous
and the next piece starts with q flipped.  Where q = +1 the exponential
decays along the motion; where q = -1 it grows, but only while
u < -g cos phi / l <= g / l, so u stays bounded.  Pieces are searched and refined
exactly like the ladder's stage, with Q_n = 0 as one more event.  The sign
scans run over windows of 8 pi rad, so a long phi range costs time, not memory.

*Wheel* (equation (13) of :mod:`phasemap.models.wheel`): the bracket
B = rho^2 + r^2 + l^2 - 2 r l cos phi + delta sigma l sin phi multiplies phi''.
The linear equation u' = P u + Q of the paper is integrated in the exactly
equivalent form for w = B u,

    w' = p(phi) w + q(phi),   p = -delta sigma l cos phi / B,
                              q = -2 g (l sin phi + delta sigma),

(from (B u)' = B' u + B u', B' = 2 r l sin phi + delta sigma l cos phi).  This is
the integrating-factor form of u' = P u + Q with E = exp(int P) =
(B0 / B) exp(int p), whose remaining exponent int p is small (it vanishes with
delta) and bounded.  On each panel [phi_k, phi_k + h]

    w(phi_k + h) = e^{I(phi_k + h)} [w_k + int_{phi_k}^{phi_k + h} q(s) e^{-I(s)} ds],
    I(x) = int_{phi_k}^{x} p,

with both integrals by :data:`GL_NODES`-point Gauss-Legendre rules (the inner
one mapped onto [phi_k, s_j] for each outer node s_j): **composite
Gauss-Legendre, 6 nodes, global order 12** in the panel width (the test suite
measures the order).  Panels are at most :data:`WHEEL_PANEL` rad long and at
most :data:`WHEEL_KAPPA` times the distance to the nearest complex zero of B,
so they shrink geometrically towards a real zero of B.  The same formula with h
set to x - phi_k gives u at any x of a panel with the same accuracy (dense
output), which the event search and the output points use.  Panel ends are
checked for u < 0 and N < 0; the crossing is then bracketed on the panel's
dense output and refined with Brent's method.

Events (the codes of :class:`phasemap.Event`)
---------------------------------------------
A stage ends at the first of:

* u = 0.  The rest state (phi, 0) is classified with the model's own ``point``
  function and :func:`phasemap._numerics.summarize`, exactly as
  :func:`phasemap.classify` decides: a unique solution on the stick branch is
  ``rest``; a unique solution on a slip (roll, turn) branch is ``reversal``
  and the next stage starts from rest in that branch's direction; no solution
  is ``no_solution`` (``singular`` if a coefficient of the senior derivative
  vanishes, ``contact_lost`` if a branch needs a one-sided contact to pull);
  two or more solutions are ``indeterminate`` (a continuum at a vanishing
  coefficient is ``singular``).  The tracer never picks a branch.
* a one-sided contact would pull: N_floor or N_wall < 0 for the ladder, N < 0
  (a bounce, the paper's condition (12)) for the wheel: ``contact_lost``, at
  the crossing N = 0.  The hinge is two-sided: it never ends a stage this way.
* the wheel's bracket B reaches zero (|B| <= 1e-12 times the scale of its
  terms, as in the model): ``singular``, at the last panel end before it.
  The ladder's 2 - f^2 and the pendulum's l^2 - delta^2 are constant: a
  vanishing one is reported as ``singular`` when the stage starts, and
  delta > l (no solution off Q_n = 0) as ``no_solution``.
* phi leaves ``phi_range``: ``horizon``, at the boundary; where that boundary
  is the model's own domain edge (the ladder lying flat at pi/2),
  ``left_domain``.
* the stage count runs out: the last stage's reason becomes ``max_events``.
* a safety net of the closed forms: u would exceed :data:`U_MAX` = 1e300
  rad2 s-2, beyond double precision: ``step_failure``, at u = U_MAX.  A
  growing exponential needs the ladder's f within 0.006 of sqrt 2
  (|lam| > 450); there it loses a contact or stops within a few 1/|lam|
  (a scan of 4000 random states grew e^{lam (phi - phi0)} to e^7 at most),
  and the pendulum's growing pieces keep u below g / l, so this is not seen.

Ties: at a stage start, the model's ``point`` decides (a grazing N = 0 is
kept); along a stage an event function counts as crossed when it is < 0
strictly at a sample, so u = 0 or N = 0 touched without a sign change is not an
event.

Dataset
-------
Dimension ``point``: ``phi``, ``omega`` (signed: the sign of the stage, 0 at
rest), ``omega_squared`` and ``point_stage`` (the index of the stage each
point belongs to; the stage coordinate is called ``stage``, so the per-point
index cannot be).  Each stage contributes ``points_per_stage`` points evenly
spaced in phi from its start to its exact end point (plus up to a quarter more
inside a fast exponential boundary layer; one point for a stage that ends where
it starts); consecutive stages share their reversal point.  Dimension
``stage``: ``stage_sign``, ``stage_start_phi``, ``stage_start_omega``,
``stage_end_reason`` (int8 CF flags of :class:`phasemap.Event`),
``stage_end_phi`` and ``stage_end_omega``.
Global attributes: ``phasemap_kind = "phase_curve"``, the model, the version,
``phasemap_initial_<state>``, ``phasemap_fixed_<param>``, ``phasemap_phi_range``,
``end_reason`` and ``end_message``.

For developers
--------------
A new one-degree-of-freedom model needs a stage function
``stage(phi0, u0, sigma, phi_stop, params, points)`` returning a
:class:`_StageResult` (u along the stage and the end event), registered in
:data:`_STAGES`.  Classification at rest and at the start, validation and the
Dataset are shared.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numba import njit
from scipy.optimize import brentq

from . import _numerics as nx
from . import events as ev
from ._version import __version__
from .model import Model
from .models import get_model
from .models import ladder as _ladder

__all__ = ["GL_NODES", "WHEEL_KAPPA", "WHEEL_PANEL", "phase_curve"]

#: Gauss-Legendre nodes per panel of the wheel's quadrature (global order 2 * GL_NODES).
GL_NODES = 6
_GL_X, _GL_W = np.polynomial.legendre.leggauss(GL_NODES)

#: Largest panel of the wheel's quadrature (rad).
WHEEL_PANEL = 0.25
#: Largest panel of the wheel's quadrature relative to the distance to the
#: nearest complex zero of the bracket.
WHEEL_KAPPA = 0.2

#: Largest omega^2 a stage may reach (rad2 s-2); beyond it, step_failure.
U_MAX = 1e300

#: Step of the uniform part of the event-search grid of the closed forms (rad).
_SCAN_STEP = 0.01
#: Relative precision of Brent's method (its smallest allowed value).
_RTOL = 4.0 * np.finfo(float).eps
#: Internal marker: the stage ended at omega = 0 (classified afterwards).
_ZERO = -1
#: Internal marker of the wheel's march: it stopped to let the caller grow its arrays.
_FULL = -2
#: Length of phi scanned at a time for the events of a closed-form stage (rad).
_WINDOW = 8.0 * math.pi
#: Default half width of the phi range of the unbounded models.
_DEFAULT_SPAN = 4.0 * math.pi


# ---------------------------------------------------------------- closed forms


@njit(cache=True, error_model="numpy")
def _split(x):
    """(E/(1 + E), 1/(1 + E)) for E = exp(x), without overflow."""
    if x > 0.0:
        e = math.exp(-x)
        return 1.0 / (1.0 + e), e / (1.0 + e)
    e = math.exp(x)
    return e / (1.0 + e), 1.0 / (1.0 + e)


@njit(cache=True, error_model="numpy")
def _exptrig(tau, phi0, c0, s, mu, a, b):
    """u = c0 e^{mu tau} + a sin phi + b cos phi at phi = phi0 + s tau."""
    phi = phi0 + s * tau
    return c0 * math.exp(mu * tau) + a * math.sin(phi) + b * math.cos(phi)


@njit(cache=True, error_model="numpy")
def _exptrig_many(taus, phi0, c0, s, mu, a, b, out):
    for i in range(taus.shape[0]):
        out[i] = _exptrig(taus[i], phi0, c0, s, mu, a, b)


@njit(cache=True, error_model="numpy")
def _ladder_event(tau, which, phi0, c0, s, lam, a, b, f, l, g):
    """Scaled event function of a ladder stage: 0 u, 1 N_floor, 2 N_wall.

    Each is h = p E + q with E = e^{lam (phi - phi0)}; the value returned is
    h/(1 + E) (same sign and zeros).  Reactions are per unit mass, times 1 + f^2.
    """
    d = s * tau
    phi = phi0 + d
    sp, cp = math.sin(phi), math.cos(phi)
    we, w1 = _split(lam * d)
    t = a * sp + b * cp
    if which == 0:
        return c0 * we + t * w1
    dt = a * cp - b * sp  # phi'' = (lam c0 E + dt) / 2
    if which == 1:
        ku = -l * cp + s * f * l * sp
        ka = -l * sp - s * f * l * cp
        n0 = g
    else:
        ku = -l * sp - s * f * l * cp
        ka = l * cp - s * f * l * sp
        n0 = s * f * g
    p = c0 * (ku + 0.5 * ka * lam)
    q = n0 + ku * t + 0.5 * ka * dt
    return p * we + q * w1


@njit(cache=True, error_model="numpy")
def _ladder_events(taus, phi0, c0, s, lam, a, b, f, l, g, out):
    for i in range(taus.shape[0]):
        for which in range(3):
            out[which, i] = _ladder_event(taus[i], which, phi0, c0, s, lam, a, b, f, l, g)


@njit(cache=True, error_model="numpy")
def _hinge_coefficients(sigma, q, delta, l, g):
    """(mu, a, b) of u = c0 e^{mu tau} + a sin phi + b cos phi on a piece of sgn Q_n = q.

    tau = sigma (phi - phi0) >= 0 along the motion, so mu = -2 k q.
    """
    k = delta / math.sqrt((l - delta) * (l + delta))
    den = l * (1.0 + 4.0 * k * k)
    return -2.0 * k * q, -6.0 * sigma * k * q * g / den, 2.0 * g * (1.0 - 2.0 * k * k) / den


@njit(cache=True, error_model="numpy")
def _hinge_event(tau, which, phi0, c0, sigma, mu, a, b, q, l, g):
    """Scaled event function of a hinge piece: 0 u, 1 q Q_n (Q_n = l u + g cos phi)."""
    phi = phi0 + sigma * tau
    sp, cp = math.sin(phi), math.cos(phi)
    we, w1 = _split(mu * tau)
    t = a * sp + b * cp
    if which == 0:
        return c0 * we + t * w1
    return q * (l * c0 * we + (l * t + g * cp) * w1)


@njit(cache=True, error_model="numpy")
def _hinge_events(taus, phi0, c0, sigma, mu, a, b, q, l, g, out):
    for i in range(taus.shape[0]):
        for which in range(2):
            out[which, i] = _hinge_event(taus[i], which, phi0, c0, sigma, mu, a, b, q, l, g)


# ---------------------------------------------------------------- wheel quadrature


@njit(cache=True, error_model="numpy")
def _bracket(phi, sigma, delta, r, l, rho):
    return rho * rho + r * r + l * l - 2.0 * r * l * math.cos(phi) + delta * sigma * l * math.sin(phi)


@njit(cache=True, error_model="numpy")
def _wheel_p(phi, sigma, delta, r, l, rho):
    return -delta * sigma * l * math.cos(phi) / _bracket(phi, sigma, delta, r, l, rho)


@njit(cache=True, error_model="numpy")
def _wheel_exponent(a, x, sigma, delta, r, l, rho):
    """I = int_a^x p by the Gauss-Legendre rule on [a, x]."""
    half = 0.5 * (x - a)
    mid = a + half
    acc = 0.0
    for j in range(GL_NODES):
        acc += _GL_W[j] * _wheel_p(mid + half * _GL_X[j], sigma, delta, r, l, rho)
    return half * acc


@njit(cache=True, error_model="numpy")
def _wheel_advance(a, w_a, x, sigma, delta, r, l, rho, g):
    """w = B omega^2 at x from its value w_a at a (one Gauss-Legendre panel [a, x])."""
    half = 0.5 * (x - a)
    mid = a + half
    acc = 0.0
    for j in range(GL_NODES):
        s = mid + half * _GL_X[j]
        q = -2.0 * g * (l * math.sin(s) + delta * sigma)
        acc += _GL_W[j] * q * math.exp(-_wheel_exponent(a, s, sigma, delta, r, l, rho))
    return math.exp(_wheel_exponent(a, x, sigma, delta, r, l, rho)) * (w_a + half * acc)


@njit(cache=True, error_model="numpy")
def _wheel_normal(phi, u, sigma, delta, r, l, rho, g):
    """N/m on a rolling stage at (phi, u = omega^2), from (13) and (12) as the model writes them."""
    sp, cp = math.sin(phi), math.cos(phi)
    bracket = _bracket(phi, sigma, delta, r, l, rho)
    phi_ddot = (-l * (r * sp + delta * sigma * cp) * u - g * l * sp - delta * sigma * g) / bracket
    return g + l * (sp * phi_ddot + cp * u)


@njit(cache=True, error_model="numpy")
def _wheel_event(x, which, a, w_a, sigma, delta, r, l, rho, g):
    """0: omega^2, 1: N/m at x, from the panel that starts at (a, w_a)."""
    w = _wheel_advance(a, w_a, x, sigma, delta, r, l, rho, g)
    u = w / _bracket(x, sigma, delta, r, l, rho)
    if which == 0:
        return u
    return _wheel_normal(x, u, sigma, delta, r, l, rho, g)


@njit(cache=True, error_model="numpy")
def _wheel_singularity_distance(phi, sigma, delta, r, l, rho):
    """Distance from phi to the nearest complex zero of the bracket (inf if it is constant)."""
    a0 = rho * rho + r * r + l * l
    a1 = -2.0 * r * l
    a2 = delta * sigma * l
    amp = math.hypot(a1, a2)
    if amp == 0.0:
        return np.inf
    psi = math.atan2(a2, a1)  # B = a0 + amp cos(phi - psi)
    two_pi = 2.0 * math.pi
    if amp > a0:  # real zeros at psi +- theta (mod 2 pi)
        theta = math.acos(-a0 / amp)
        best = np.inf
        for z in (psi + theta, psi - theta):
            d = (phi - z) % two_pi
            best = min(best, d, two_pi - d)
        return best
    eta = math.acosh(a0 / amp)  # zeros at psi + pi +- i eta
    d = (phi - psi - math.pi) % two_pi
    d = min(d, two_pi - d)
    return math.sqrt(d * d + eta * eta)


@njit(cache=True, error_model="numpy")
def _wheel_march(k0, phis, ws, sigma, phi_stop, delta, r, l, rho, g, panel, kappa):
    """March panels from (phis[k0], ws[k0]) towards phi_stop.

    Fills phis, ws from k0 + 1 on; returns (last index filled, status):
    ``HORIZON`` (reached phi_stop), ``SINGULAR`` (|bracket| vanishes at the
    last point), ``_ZERO`` (u < 0 or N < 0 at the last panel end: the event is
    inside the last panel) or ``_FULL`` (the arrays are full).
    """
    b_scale = rho * rho + r * r + l * l + 2.0 * r * l + delta * l
    k = k0
    while k + 1 < phis.shape[0]:
        phi = phis[k]
        remaining = sigma * (phi_stop - phi)
        if remaining <= 0.0:
            return k, ev.HORIZON
        if abs(_bracket(phi, sigma, delta, r, l, rho)) <= nx.TOL * b_scale:
            return k, ev.SINGULAR
        h = min(panel, kappa * _wheel_singularity_distance(phi, sigma, delta, r, l, rho))
        new = phi_stop if h >= remaining else phi + sigma * h
        w = _wheel_advance(phi, ws[k], new, sigma, delta, r, l, rho, g)
        phis[k + 1] = new
        ws[k + 1] = w
        k += 1
        u = w / _bracket(new, sigma, delta, r, l, rho)
        if u < 0.0 or _wheel_normal(new, u, sigma, delta, r, l, rho, g) < 0.0:
            return k, _ZERO
    return k, _FULL


@njit(cache=True, error_model="numpy")
def _wheel_dense(xs, index, phis, ws, sigma, delta, r, l, rho, g, out):
    """omega^2 at xs, each from the panel start phis[index[i]]."""
    for i in range(xs.shape[0]):
        k = index[i]
        w = _wheel_advance(phis[k], ws[k], xs[i], sigma, delta, r, l, rho, g)
        out[i] = w / _bracket(xs[i], sigma, delta, r, l, rho)


# ---------------------------------------------------------------- stages


@dataclass
class _StageResult:
    """u = omega^2 along one stage (phi in the order of motion) and how it ended."""

    phi: np.ndarray
    u: np.ndarray
    reason: int  # an Event code, or _ZERO (omega reached 0: classify to decide)
    end_phi: float
    end_u: float


def _search_grid(lo: float, hi: float, mu: float) -> np.ndarray:
    """Sorted sample points in [lo, hi] for the sign scan of a closed-form stage.

    Uniform at :data:`_SCAN_STEP`; from tau = 0 also across the boundary layer of
    width 1/|mu| (step 0.1 in |mu| tau) and geometric towards 0 (a start from
    rest, where u = 0 at tau = 0).
    """
    if hi <= lo:
        return np.array([lo])
    parts = [np.linspace(lo, hi, max(math.ceil((hi - lo) / _SCAN_STEP), 16) + 1)]
    if lo == 0.0:
        rate = abs(mu)
        if rate * hi > 1.0:
            parts.append(np.arange(0.1, min(rate * hi, 60.0), 0.1) / rate)
        parts.append(hi * np.logspace(-9.0, -1.0, 17))
    grid = np.unique(np.concatenate(parts))
    return grid[grid <= hi]


def _layer(tau_end: float, mu: float, points: int) -> np.ndarray:
    """Extra output points inside a boundary layer of width 1/|mu| (none if it is thin)."""
    rate = abs(mu)
    if rate * tau_end <= 10.0:
        return np.empty(0)
    return np.geomspace(1e-3, min(rate * tau_end, 40.0), max(points // 4, 2)) / rate


def _output_grid(tau_end: float, mu: float, points: int) -> np.ndarray:
    """Output points of a closed-form stage: evenly spaced, plus its boundary layer."""
    if tau_end <= 0.0:
        return np.zeros(1)
    grid = np.unique(np.concatenate([np.linspace(0.0, tau_end, points),
                                     _layer(tau_end, mu, points)]))
    return grid[grid <= tau_end]


def _first_root(taus: np.ndarray, values: np.ndarray, fun, skip_below: float = 0.0):
    """tau of the first crossing to < 0 after tau = 0, refined; None if there is none.

    Samples below ``skip_below`` are not looked at (a piece that starts on the
    zero of this very function).
    """
    negative = values < 0.0
    negative[0] = False
    if skip_below > 0.0:
        negative &= taus >= skip_below
    hits = np.flatnonzero(negative)
    if hits.size == 0:
        return None
    i = int(hits[0])
    if values[i - 1] <= 0.0:
        return float(taus[i - 1])
    return float(brentq(fun, taus[i - 1], taus[i], xtol=1e-300, rtol=_RTOL, maxiter=500))


def _earliest(taus, table, fun, skip=None):
    """(tau, which) of the earliest event among the rows of ``table``; (None, None) if none."""
    best, which = None, None
    for j in range(table.shape[0]):
        root = _first_root(taus, table[j], lambda t, j=j: fun(t, j),
                           0.0 if skip is None else skip[j])
        if root is not None and (best is None or root < best):
            best, which = root, j
    return best, which


def _scan(tau_max: float, mu: float, n_events: int, many, one, args: tuple, skip=None):
    """(tau, which) of the earliest event of a closed-form stage in [0, tau_max].

    ``many(taus, *args, table)`` evaluates the scaled event functions on a grid,
    ``one(tau, which, *args)`` one of them; the range is scanned :data:`_WINDOW`
    at a time.
    """
    lo = 0.0
    while True:
        hi = min(lo + _WINDOW, tau_max)
        taus = _search_grid(lo, hi, mu)
        table = np.empty((n_events, taus.size))
        many(taus, *args, table)
        root, which = _earliest(taus, table, lambda t, j: one(t, j, *args), skip)
        if root is not None or hi >= tau_max:
            return root, which
        lo = hi


def _overflow_cap(c0: float, mu: float) -> float:
    """tau at which |c0| e^{mu tau} reaches U_MAX (inf if it never does)."""
    if mu <= 0.0 or c0 == 0.0:
        return math.inf
    return max(math.log(U_MAX) - math.log(abs(c0)), 0.0) / mu


def _ladder_stage(phi0, u0, s, phi_stop, p, points) -> _StageResult:
    f, l, g = p["f"], p["l"], p["g"]
    lam, a, b = _ladder.first_integral_coefficients(s, f, l, g)
    mu = lam * s  # rate along tau = s (phi - phi0)
    c0 = u0 - a * math.sin(phi0) - b * math.cos(phi0)
    tau_max = max(s * (phi_stop - phi0), 0.0)
    reason = ev.HORIZON
    cap = _overflow_cap(c0, mu)
    if cap < tau_max:
        tau_max, reason = cap, ev.STEP_FAILURE
    root, which = _scan(tau_max, mu, 3, _ladder_events, _ladder_event,
                        (phi0, c0, s, lam, a, b, f, l, g))
    tau_end = tau_max
    if root is not None:
        tau_end, reason = root, (_ZERO if which == 0 else ev.CONTACT_LOST)
    grid = _output_grid(tau_end, mu, points)
    u = np.empty(grid.size)
    _exptrig_many(grid, phi0, c0, s, mu, a, b, u)
    end_u = 0.0 if reason == _ZERO else float(u[-1])
    u[-1] = end_u
    u[0] = u0
    return _StageResult(phi0 + s * grid, u, reason, phi0 + s * tau_end, end_u)


def _hinge_stage(phi0, u0, sigma, phi_stop, p, points) -> _StageResult:
    delta, l, g = p["delta"], p["l"], p["g"]
    if delta >= l:  # only reachable on Q_n = 0 with delta > l, which the motion leaves at once
        return _StageResult(np.array([phi0]), np.array([u0]), ev.NO_SOLUTION, phi0, u0)
    pieces = []  # (tau offset, tau length, phi start, c0, mu, a, b)
    tau0, phi_p, u_p = 0.0, phi0, u0
    qn = l * u0 + g * math.cos(phi0)
    if nx.is_zero(qn, l * abs(u0) + g):  # starts on Q_n = 0: take the side it moves into
        q = 1.0 if -sigma * math.sin(phi0) >= 0.0 else -1.0
    else:
        q = 1.0 if qn > 0.0 else -1.0
    switched = False
    reason, end_u = ev.HORIZON, None
    for _ in range(10_000):
        mu, a, b = _hinge_coefficients(sigma, q, delta, l, g)
        c0 = u_p - a * math.sin(phi_p) - b * math.cos(phi_p)
        tau_max = max(sigma * (phi_stop - phi_p), 0.0)
        cap = _overflow_cap(c0, mu)
        piece_reason = ev.HORIZON
        if cap < tau_max:
            tau_max, piece_reason = cap, ev.STEP_FAILURE
        skip = (0.0, 1e-9 * max(tau_max, 1.0) if switched else 0.0)
        root, which = _scan(tau_max, mu, 2, _hinge_events, _hinge_event,
                            (phi_p, c0, sigma, mu, a, b, q, l, g), skip)
        length = tau_max if root is None else root
        pieces.append((tau0, length, phi_p, c0, mu, a, b))
        if root is None:
            reason = piece_reason
            end_u = _exptrig(length, phi_p, c0, sigma, mu, a, b)
            break
        if which == 0:
            reason, end_u = _ZERO, 0.0
            break
        u_p = max(_exptrig(length, phi_p, c0, sigma, mu, a, b), 0.0)
        phi_p = phi_p + sigma * length
        tau0 += length
        q, switched = -q, True
    else:
        reason = ev.STEP_FAILURE
        end_u = u_p
    total = pieces[-1][0] + pieces[-1][1]
    offsets = np.array([piece[0] for piece in pieces])
    parts = [np.linspace(0.0, total, points) if total > 0.0 else np.zeros(1), offsets]
    for off, length, _, _, mu, _, _ in pieces:
        parts.append(off + _layer(length, mu, points))
    tau = np.unique(np.concatenate(parts))
    tau = tau[tau <= total]
    which = np.clip(np.searchsorted(offsets, tau, side="right") - 1, 0, len(pieces) - 1)
    u = np.empty(tau.size)
    for j, (off, _, ph, c0, mu, a, b) in enumerate(pieces):
        sel = which == j
        part = np.empty(int(sel.sum()))
        _exptrig_many(tau[sel] - off, ph, c0, sigma, mu, a, b, part)
        u[sel] = part
    tau_end = total
    u[0], u[-1] = u0, end_u
    return _StageResult(phi0 + sigma * tau, u, reason, phi0 + sigma * tau_end, float(end_u))


def _wheel_stage(phi0, u0, sigma, phi_stop, p, points) -> _StageResult:
    args = (p["delta"], p["r"], p["l"], p["rho"], p["g"])
    phis = np.empty(1024)
    ws = np.empty(1024)
    phis[0] = phi0
    ws[0] = _bracket(phi0, sigma, *args[:4]) * u0
    k, status = 0, _FULL
    while status == _FULL:
        k, status = _wheel_march(k, phis, ws, sigma, phi_stop, *args, WHEEL_PANEL, WHEEL_KAPPA)
        if status == _FULL:
            phis = np.concatenate([phis, np.empty(phis.size)])
            ws = np.concatenate([ws, np.empty(ws.size)])
    phis, ws = phis[:k + 1].copy(), ws[:k + 1].copy()
    reason = status
    end_phi = float(phis[k])
    if status == _ZERO:  # the event is inside the last panel [phis[k-1], phis[k]]
        a, w_a = phis[k - 1], ws[k - 1]
        width = sigma * (phis[k] - a)
        sub = np.unique(np.concatenate([np.linspace(0.0, width, 33),
                                        width * np.logspace(-9.0, -1.0, 17)]))
        table = np.array([[_wheel_event(a + sigma * t, j, a, w_a, sigma, *args) for t in sub]
                          for j in range(2)])
        root, which = _earliest(
            sub, table, lambda t, j: _wheel_event(a + sigma * t, j, a, w_a, sigma, *args))
        if root is None:  # crossed at the panel end only (the sample there is negative)
            root, which = width, int(table[0, -1] >= 0.0)
        end_phi = float(a + sigma * root)
        reason = _ZERO if which == 0 else ev.CONTACT_LOST
        phis[k] = end_phi
        ws[k] = _wheel_advance(a, w_a, end_phi, sigma, *args)
    # output: evenly spaced in tau, each from the panel that contains it
    tau_panel = sigma * (phis - phi0)
    tau_end = float(tau_panel[-1])
    grid = np.linspace(0.0, tau_end, points) if tau_end > 0.0 else np.zeros(1)
    index = np.clip(np.searchsorted(tau_panel, grid, side="right") - 1, 0, max(k - 1, 0))
    u = np.empty(grid.size)
    _wheel_dense(phi0 + sigma * grid, index.astype(np.int64), phis, ws, sigma, *args, u)
    end_u = 0.0 if reason == _ZERO else float(ws[-1] / _bracket(end_phi, sigma, *args[:4]))
    u[0], u[-1] = u0, end_u
    phi = phi0 + sigma * grid
    phi[-1] = end_phi
    return _StageResult(phi, u, reason, end_phi, end_u)


#: The stage solver of each one-degree-of-freedom model.
_STAGES = {"ladder": _ladder_stage, "wheel": _wheel_stage, "hinge_pendulum": _hinge_stage}
#: How each model integrates its stages (for the Dataset's provenance).
_METHODS = {
    "ladder": "closed form u = c0 exp(lambda (phi - phi0)) + a sin phi + b cos phi; "
              "events by a sign scan and Brent's method on overflow-free scaled functions",
    "wheel": f"composite Gauss-Legendre quadrature ({GL_NODES} nodes, order {2 * GL_NODES}) of "
             "the integrating-factor form for w = bracket * omega^2; events by Brent's method "
             "on the dense output",
    "hinge_pendulum": "closed form on each piece of constant sgn(l omega^2 + g cos phi); events "
                      "by a sign scan and Brent's method on overflow-free scaled functions",
}


# ---------------------------------------------------------------- classification


def _classify(m: Model, values: dict, phi: float, omega: float) -> np.ndarray:
    v = m.input_vector({**values, "phi": phi, "omega": omega})
    out = np.full((len(m.branches), m.n_fields), np.nan)
    m.point(v, out)
    return out


def _at_rest(m: Model, values: dict, phi: float):
    """Classify the rest state (phi, 0): ('go', sigma) or ('stop', Event code)."""
    out = _classify(m, values, phi, 0.0)
    n, stagnation, lost, singular = nx.summarize(out, m.stick_branch)
    if n == nx.N_UNIQUE:
        if stagnation:
            return "stop", ev.REST
        row = int(np.flatnonzero(out[:, nx.STATUS] == nx.ADMISSIBLE)[0])
        return "go", m.directions[row]
    if singular and n in (nx.N_NONE, nx.N_CONTINUUM):
        return "stop", ev.SINGULAR
    if n == nx.N_NONE:
        return "stop", ev.CONTACT_LOST if lost else ev.NO_SOLUTION
    return "stop", ev.INDETERMINATE


def _moving(m: Model, values: dict, phi: float, omega: float):
    """Check the running branch at (phi, omega != 0): ('go', sigma) or ('stop', Event code).

    Returns ('rest', 0) when omega counts as zero for the model (its ``point``
    treats the state as a rest state).
    """
    out = _classify(m, values, phi, omega)
    if out[m.stick_branch, nx.STATUS] != nx.ABSENT:
        return "rest", 0.0
    row = int(np.flatnonzero(out[:, nx.STATUS] != nx.ABSENT)[0])
    status = int(out[row, nx.STATUS])
    if out[row, nx.SINGULAR] != 0.0:
        return "stop", ev.SINGULAR
    if status == nx.ADMISSIBLE:
        return "go", m.directions[row]
    if status == nx.CONTACT_LOST:
        return "stop", ev.CONTACT_LOST
    return "stop", ev.NO_SOLUTION


# ---------------------------------------------------------------- public API


def phase_curve(model: str | Model, *, phi: float, omega: float,
                phi_range: tuple[float, float] | None = None, max_stages: int = 50,
                points_per_stage: int = 200, **params: float) -> xr.Dataset:
    """The phase curve omega(phi) from (phi, omega), stage by stage, to its fate.

    Parameters
    ----------
    model:
        ``"ladder"``, ``"wheel"`` or ``"hinge_pendulum"`` (or their
        :class:`phasemap.Model`); the two-degree-of-freedom elliptic pendulum
        has no phase curve of this kind (use :func:`phasemap.simulate`).
    phi, omega:
        the initial state (rad, rad s-1).  An omega the model counts as zero
        (``|omega| <= 1e-12 sqrt(g / l)``) is a rest state.
    phi_range:
        ``(low, high)`` containing ``phi``: the curve ends with ``horizon``
        where it leaves this range.  Default: the domain of ``phi`` where it is
        bounded (the ladder's [0, pi/2]), else ``(phi - 4 pi, phi + 4 pi)``.
    max_stages:
        the largest number of stages; a curve still reversing after that many
        ends with ``max_events``.
    points_per_stage:
        points evenly spaced in phi on each stage, its ends included (stages
        with an exponential boundary layer get up to a quarter more inside it).
    **params:
        the model's parameters by name; missing ones take the defaults.

    Returns
    -------
    xarray.Dataset
        dimension ``point``: ``phi``, ``omega`` (signed), ``omega_squared``,
        ``point_stage``; dimension ``stage`` (coordinate ``stage``):
        ``stage_sign``, ``stage_start_phi``, ``stage_start_omega``,
        ``stage_end_reason`` (flags of :class:`phasemap.Event`),
        ``stage_end_phi``, ``stage_end_omega``.  ``attrs["end_reason"]`` names the
        last stage's reason.  See the module docstring for the methods and the
        events.

    Raises
    ------
    ValueError
        for another model, an unknown or out-of-domain variable, a
        non-scalar value, a ``phi_range`` that does not contain ``phi`` or
        leaves the model's domain, or bad ``max_stages``/``points_per_stage``.

    Examples
    --------
    >>> from phasemap.phase import phase_curve
    >>> ds = phase_curve("hinge_pendulum", phi=0.2, omega=0.0, delta=0.02)
    >>> ds.attrs["end_reason"], int(ds.sizes["stage"])
    ('rest', 5)
    >>> abs(float(ds.stage_end_phi[-1])) <= 0.02      # rest needs l |sin phi| <= delta
    True
    """
    m = get_model(model)
    if m.name not in _STAGES:
        raise ValueError(
            f"{m.name}: phase_curve follows one-degree-of-freedom models only "
            f"({', '.join(_STAGES)}); use phasemap.simulate for {m.name}")
    values = {"phi": phi, "omega": omega, **params}
    for k, val in values.items():
        if np.ndim(val) != 0:
            raise ValueError(f"{m.name}: {k} must be a scalar for phase_curve()")
    full = {k: float(v) for k, v in m.complete(values).items()}
    lo, hi = _checked_range(m, full["phi"], phi_range)
    max_stages = _positive_int(m, "max_stages", max_stages, 1)
    points = _positive_int(m, "points_per_stage", points_per_stage, 2)
    p = {v.name: full[v.name] for v in m.params}
    stage_fn = _STAGES[m.name]

    phi0, omega0 = full["phi"], full["omega"]
    stages: list[tuple[float, _StageResult]] = []
    action, value = ("rest", 0.0) if omega0 == 0.0 else _moving(m, full, phi0, omega0)
    if action == "rest":
        omega0 = 0.0
        action, value = _at_rest(m, full, phi0)
    if action == "stop":
        sign = 0.0 if omega0 == 0.0 else math.copysign(1.0, omega0)
        stages.append((sign, _StageResult(np.array([phi0]), np.array([omega0 ** 2]), value,
                                          phi0, omega0 ** 2)))
    else:
        sigma, u0 = value, omega0 * omega0
        while True:
            stop = hi if sigma > 0 else lo
            res = stage_fn(phi0, u0, sigma, stop, p, points)
            next_sigma = None
            if res.reason == _ZERO:
                action, value = _at_rest(m, full, res.end_phi)
                if action == "go":
                    res.reason, next_sigma = ev.REVERSAL, value
                else:
                    res.reason = value
            stages.append((sigma, res))
            if next_sigma is None:
                break
            if len(stages) >= max_stages:
                res.reason = ev.MAX_EVENTS
                break
            phi0, u0, sigma = res.end_phi, 0.0, next_sigma
    last = stages[-1][1]
    var = m.variables["phi"]
    if last.reason == ev.HORIZON and last.end_phi in (var.lower, var.upper):
        last.reason = ev.LEFT_DOMAIN  # the model's own edge (the ladder lies flat)
    return _dataset(m, full, (lo, hi), max_stages, points, stages)


def _checked_range(m: Model, phi: float, phi_range) -> tuple[float, float]:
    var = m.variables["phi"]
    if phi_range is None:
        lo = var.lower if math.isfinite(var.lower) else phi - _DEFAULT_SPAN
        hi = var.upper if math.isfinite(var.upper) else phi + _DEFAULT_SPAN
        return float(lo), float(hi)
    try:
        lo, hi = (float(x) for x in phi_range)
    except (TypeError, ValueError):
        raise ValueError(f"{m.name}: phi_range must be two numbers (low, high), "
                         f"got {phi_range!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"{m.name}: phi_range must be finite with low < high, "
                         f"got {phi_range!r}")
    if not lo <= phi <= hi:
        raise ValueError(f"{m.name}: phi_range {phi_range!r} must contain phi = {phi:g}")
    var.check(m.name, lo)
    var.check(m.name, hi)
    return lo, hi


def _positive_int(m: Model, name: str, value, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise ValueError(f"{m.name}: {name} must be an integer >= {least}, got {value!r}")
    return int(value)


def _signed_root(sign: float, u: float) -> float:
    return sign * math.sqrt(u) if u > 0.0 else 0.0


def _dataset(m: Model, full: dict, phi_range, max_stages: int, points: int,
             stages: list[tuple[float, _StageResult]]) -> xr.Dataset:
    var_phi, var_omega = m.variables["phi"], m.variables["omega"]
    phis, omegas, us, index = [], [], [], []
    for i, (sign, res) in enumerate(stages):
        u = np.maximum(res.u, 0.0)
        phis.append(res.phi)
        us.append(u)
        omegas.append(np.where(u > 0.0, sign * np.sqrt(u), 0.0))
        index.append(np.full(res.phi.size, i, dtype=np.int32))
    signs = np.array([s for s, _ in stages], dtype=np.int8)
    reasons = np.array([r.reason for _, r in stages], dtype=np.int8)
    start_phi = np.array([r.phi[0] for _, r in stages])
    start_omega = np.array([_signed_root(s, r.u[0]) for s, r in stages])
    end_phi = np.array([r.end_phi for _, r in stages])
    end_omega = np.array([_signed_root(s, r.end_u) for s, r in stages])
    flags = {"flag_values": np.array(ev.EVENT_VALUES, dtype=np.int8),
             "flag_meanings": ev.EVENT_MEANINGS}

    def angle(name, values, dim):
        return xr.Variable(dim, values, {"long_name": name, "units": var_phi.units})

    def rate(name, values, dim):
        return xr.Variable(dim, values, {"long_name": name, "units": var_omega.units})

    data = {
        "phi": angle(var_phi.long_name, np.concatenate(phis), "point"),
        "omega": rate(var_omega.long_name, np.concatenate(omegas), "point"),
        "omega_squared": xr.Variable("point", np.concatenate(us), {
            "long_name": f"square of the {var_omega.long_name}", "units": "rad2 s-2"}),
        "point_stage": xr.Variable("point", np.concatenate(index), {
            "long_name": "index of the stage the point belongs to", "units": "1"}),
        "stage_sign": xr.Variable("stage", signs, {
            "long_name": "sign of omega on the stage (0: no motion)", "units": "1"}),
        "stage_start_phi": angle(f"{var_phi.long_name} at the start of the stage",
                                 start_phi, "stage"),
        "stage_start_omega": rate(f"{var_omega.long_name} at the start of the stage",
                                  start_omega, "stage"),
        "stage_end_reason": xr.Variable("stage", reasons, {
            "long_name": "event that ends the stage", **flags}),
        "stage_end_phi": angle(f"{var_phi.long_name} at the end of the stage", end_phi,
                               "stage"),
        "stage_end_omega": rate(f"{var_omega.long_name} at the end of the stage", end_omega,
                                "stage"),
    }
    coords = {"stage": xr.Variable("stage", np.arange(len(stages), dtype=np.int32),
                                   {"long_name": "stage index (omega keeps its sign on a stage)",
                                    "units": "1"})}
    from .simulate import end_message

    last = ev.Event(int(reasons[-1]))
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    attrs = {
        "Conventions": "CF-1.8",
        "title": f"phasemap phase curve: {m.title}",
        "source": f"phasemap {__version__}",
        "history": f"{now} created by phasemap.phase_curve {__version__}",
        "references": m.citation,
        "phasemap_kind": "phase_curve",
        "phasemap_model": m.name,
        "phasemap_version": __version__,
        "date_created": now,
        "method": _METHODS[m.name],
        "end_reason": last.name.lower(),
        "end_message": end_message(m, last, (float(end_phi[-1]),)),
        "n_reversals": np.int32(np.count_nonzero(reasons == ev.REVERSAL)),
        "phasemap_phi_range": np.array(phi_range, dtype=float),
        "phasemap_max_stages": np.int32(max_stages),
        "phasemap_points_per_stage": np.int32(points),
    }
    for v in m.state:
        attrs[f"phasemap_initial_{v.name}"] = float(full[v.name])
    for v in m.params:
        attrs[f"phasemap_fixed_{v.name}"] = float(full[v.name])
    return xr.Dataset(data, coords, attrs)
