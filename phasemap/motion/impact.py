"""Frictional impacts of one planar contact, integrated exactly in the normal impulse.

An impact is a velocity jump v+ = v- + W P at one contact, where ``P = (P_n, P_t)`` is
the impulse (normal, tangential) and ``W`` the 2x2 Delassus matrix: the inverse mass
matrix projected on the contact's normal and tangent (:func:`delassus`; for one rigid
body W_nn = 1/m + (r x n)^2/I, W_tt = 1/m + (r x t)^2/I, W_nt = (r x n)(r x t)/I, with r
the contact point from the centre of mass).  Coulomb friction acts throughout the
impact, so the jump is found by following the contact velocities ``v = (v_n, v_t)`` as
the normal impulse ``P`` grows (Darboux-Keller, Routh; Stronge, *Impact Mechanics*,
ch. 5; GUIDE section 8):

* **slip** with s = sgn v_t: dv_n/dP = W_nn - s mu W_nt, dv_t/dP = W_nt - s mu W_tt,
  dP_t/dP = -s mu;
* where v_t reaches 0 the contact **sticks** if |W_nt| <= mu W_tt (dP_t/dP = -W_nt/W_tt,
  dv_n/dP = det W / W_tt > 0), otherwise the slip **reverses** (s = sgn W_nt);
* **compression** ends at v_n = 0 (normal impulse P_c, normal work W_c = int v_n dP < 0);
* **restitution** ends by the law: Newton at v_n = -e v_n-; Poisson at P = (1 + e) P_c;
  Stronge (energetic) where the normal work of restitution is e^2 |W_c|.

W is constant during an impact, so every phase is linear in P and every end is found in
closed form (the Stronge end is the root of a quadratic): no step size, no tolerance.
An impact always ends: a slip with W_nn - s mu W_nt < 0 (a Painleve state, the normal
velocity still falling) decelerates, because det W > 0.

Sign conventions: ``n`` points out of the obstacle into the body, ``t`` is a unit
tangent, ``v_n < 0`` approaches, and the impulse acts on the body (``P_n >= 0``).  The
kinetic energy changes by ``dKE = P . v- + P^T W P / 2``.

The three laws agree for e = 0 and where the slip never stops.  Stronge's and
Poisson's never gain energy at one frictional contact; **Newton's can**, where the slip
stops or reverses (Stronge 1991): :attr:`Impact.gains_energy` says so, and
:func:`impact` warns.

An *impact without collision* (a tangential impact, Genot & Brogliato 1999) starts at
v_n = 0 in a Painleve state: the slip forces the contact into the obstacle, compression
goes on until the slip stops, and the impact then ends by the law.  :func:`impact` takes
it with ``v_n = 0`` where ``W_nn - s mu W_nt < 0``.

>>> import numpy as np
>>> r = impact(delassus_body(1.0, 1 / 3, (-np.cos(np.pi / 4), -np.sin(np.pi / 4))),
...            (-1.0, 0.5), mu=1.0, e=0.9, law="poisson")
>>> round(r.P_n, 12), round(r.P_t, 12), round(r.dKE, 5)
(0.83125, 0.29875, -0.07909)
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import warnings
from dataclasses import dataclass

import numpy as np
from numba import njit

#: The restitution laws, by name; Stronge's is the default.
LAWS = {"stronge": 0, "poisson": 1, "newton": 2}
#: The phases an impact passes through, as :attr:`Impact.phases` names them.
PHASES = ("slip_pos", "slip_neg", "stick")
_SLIP_POS, _SLIP_NEG, _STICK = 0, 1, 2
#: Most phase changes of one impact: a slip that stops (then sticks or reverses), and
#: the end of compression inside a phase.
_MAX_SEGMENTS = 6
_INF = math.inf


@njit(cache=True)
def _rates(phase, Wnn, Wnt, Wtt, mu):
    """(dv_n/dP, dv_t/dP, dP_t/dP) in ``phase``."""
    if phase == _STICK:
        return (Wnn * Wtt - Wnt * Wnt) / Wtt, 0.0, -Wnt / Wtt
    s = 1.0 if phase == _SLIP_POS else -1.0
    return Wnn - s * mu * Wnt, Wnt - s * mu * Wtt, -s * mu


@njit(cache=True)
def _phase_at_rest(Wnt, Wtt, mu):
    """The phase of a contact whose tangential velocity is zero."""
    if abs(Wnt) <= mu * Wtt:
        return _STICK
    return _SLIP_POS if Wnt > 0.0 else _SLIP_NEG


@njit(cache=True)
def _root_of_work(vn, a, work):
    """The least x >= 0 with vn x + a x^2 / 2 = work (work > 0, vn >= 0), or inf."""
    if a == 0.0:
        return work / vn if vn > 0.0 else _INF
    disc = vn * vn + 2.0 * a * work
    if disc < 0.0:
        return _INF
    root = math.sqrt(disc)
    # the smaller positive root, written to avoid cancellation
    x = 2.0 * work / (vn + root) if vn + root > 0.0 else (-vn + root) / a
    return x if x >= 0.0 else _INF


@njit(cache=True)
def impact_kernel(Wnn, Wnt, Wtt, vn0, vt0, mu, e, law, phases):
    """The impact of one contact (see the module docstring); ``law`` a code of
    :data:`LAWS`.  Fills ``phases`` with the phase codes passed through (-1 after the
    last) and returns ``(P_n, P_t, v_n+, v_t+, P_c, W_c, segments)``."""
    for i in range(phases.shape[0]):
        phases[i] = -1
    P, Pt, vn, vt = 0.0, 0.0, vn0, vt0
    if vt > 0.0:
        phase = _SLIP_POS
    elif vt < 0.0:
        phase = _SLIP_NEG
    else:
        phase = _phase_at_rest(Wnt, Wtt, mu)
    compressing = True
    Pc, Wc, Wr = _INF, 0.0, 0.0
    target_v = -e * vn0  # Newton's end
    nseg = 0
    while nseg < phases.shape[0]:
        phases[nseg] = phase
        nseg += 1
        a, b, c = _rates(phase, Wnn, Wnt, Wtt, mu)
        # candidate ends of this segment, as increments of P
        d_stop = _INF
        if phase != _STICK and b != 0.0 and vt * b < 0.0:
            d_stop = -vt / b
        d_end = _INF
        if compressing:
            if vn < 0.0 and a > 0.0:
                d_end = -vn / a
            elif vn >= 0.0 and a >= 0.0 and P > 0.0:
                d_end = 0.0  # came back to v_n = 0 (after a Painleve compression)
        else:
            if law == 2:  # Newton
                if vn >= target_v:
                    d_end = 0.0
                elif a > 0.0:
                    d_end = (target_v - vn) / a
            elif law == 1:  # Poisson
                d_end = max((1.0 + e) * Pc - P, 0.0)
            else:  # Stronge: the work of restitution reaches e^2 |W_c|
                d_end = _root_of_work(vn, a, max(e * e * (-Wc) - Wr, 0.0))
                if e * e * (-Wc) - Wr <= 0.0:
                    d_end = 0.0
        d = min(d_stop, d_end)
        if d == _INF:
            break  # cannot happen for det W > 0; reported by the caller
        work = vn * d + 0.5 * a * d * d
        P += d
        Pt += c * d
        vn += a * d
        vt = 0.0 if d == d_stop else vt + b * d
        if compressing:
            Wc += work
        else:
            Wr += work
        if d_end <= d_stop:
            if compressing:
                compressing = False
                Pc = P
                vn = 0.0 if vn < 0.0 else vn
                if e == 0.0 or (law == 1 and Pc == 0.0):
                    break
                if law == 2 and vn >= target_v:
                    break
                nseg -= 1  # the same phase goes on into restitution
                continue
            break
        phase = _phase_at_rest(Wnt, Wtt, mu)
    return P, Pt, vn, vt, Pc, Wc, nseg


@dataclass(frozen=True)
class Impact:
    """The result of :func:`impact`: impulses, velocities after, energy."""

    #: normal and tangential impulse on the body
    P_n: float
    P_t: float
    #: normal and tangential contact velocity before and after
    v_n_before: float
    v_t_before: float
    v_n: float
    v_t: float
    #: normal impulse at the end of compression, and the normal work of compression
    P_compression: float
    W_compression: float
    #: kinetic energy change, P . v- + P^T W P / 2
    dKE: float
    #: the phases in order: "slip_pos", "slip_neg", "stick"
    phases: tuple[str, ...]
    law: str
    restitution: float
    #: whether the law made energy (Newton's, where the slip stopped or reversed)
    gains_energy: bool

    @property
    def sticks(self) -> bool:
        """Whether the contact ends the impact stuck (v_t = 0)."""
        return self.v_t == 0.0 and self.phases[-1] == "stick"


def _check_W(W) -> np.ndarray:
    try:
        W = np.asarray(W, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"W must be a 2x2 matrix of numbers, got {W!r}") from None
    if W.shape != (2, 2) or not np.all(np.isfinite(W)):
        raise ValueError(f"W must be a finite 2x2 matrix, got shape {W.shape}")
    if abs(W[0, 1] - W[1, 0]) > 1e-12 * max(1.0, abs(W).max()):
        raise ValueError("W must be symmetric (the inverse mass matrix projected on n, t)")
    if not (W[0, 0] > 0.0 and W[1, 1] > 0.0 and W[0, 0] * W[1, 1] - W[0, 1] ** 2 > 0.0):
        raise ValueError("W must be positive definite (a body with mass and inertia)")
    return W


def _number(name: str, x, lo: float, hi: float = _INF) -> float:
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {x!r}") from None
    if not (lo <= x <= hi) or math.isnan(x):
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}], got {x!r}")
    return x


def impact(W, v_before, mu: float, e: float = 0.0, law: str = "stronge") -> Impact:
    """The frictional impact of one contact (module docstring).

    Parameters
    ----------
    W : array_like, 2x2
        the Delassus matrix in (n, t): symmetric positive definite.
    v_before : (float, float)
        the contact velocity (v_n, v_t) before; v_n < 0 approaches.  v_n = 0 is an impact
        without collision, allowed only where the slip forces the contact into the
        obstacle (W_nn - s mu W_nt < 0, s = sgn v_t).
    mu : float
        the friction coefficient, >= 0.
    e : float
        the coefficient of restitution, in [0, 1] (0: plastic).
    law : {"stronge", "poisson", "newton"}
        how restitution ends.  Newton's law can make energy where the slip stops or
        reverses (the result says so, and a warning too).

    Returns
    -------
    Impact

    Examples
    --------
    The Painleve rod (half-length 1, mass 1, f = 1.5) at theta = arctan 2, sliding at
    x_A' = -1: an impact without collision, P_n = 0.3, P_t = 0.4, then it sticks.

    >>> th = math.atan(2.0)
    >>> W = delassus_body(1.0, 1 / 3, (-math.cos(th), -math.sin(th)))
    >>> r = impact(W, (0.0, -1.0), mu=1.5)
    >>> round(r.P_n, 12), round(r.P_t, 12), r.sticks
    (0.3, 0.4, True)
    """
    W = _check_W(W)
    try:
        vn, vt = (float(x) for x in v_before)
    except (TypeError, ValueError):
        raise ValueError(f"v_before must be two numbers (v_n, v_t), got {v_before!r}") from None
    if not (math.isfinite(vn) and math.isfinite(vt)):
        raise ValueError(f"v_before must be finite, got {v_before!r}")
    mu = _number("mu", mu, 0.0)
    e = _number("e", e, 0.0, 1.0)
    if not isinstance(law, str) or law.lower() not in LAWS:
        raise ValueError(f"law must be one of {', '.join(LAWS)}, got {law!r}")
    law = law.lower()
    Wnn, Wnt, Wtt = W[0, 0], W[0, 1], W[1, 1]
    if vn > 0.0:
        raise ValueError(f"v_before: v_n = {vn!r} > 0 separates; there is no impact")
    if vn == 0.0:
        s = 0.0 if vt == 0.0 else math.copysign(1.0, vt)
        if s == 0.0 or Wnn - s * mu * Wnt >= 0.0:
            raise ValueError("v_before: v_n = 0 is an impact only without collision, where "
                             "the slip forces the contact in (W_nn - sgn(v_t) mu W_nt < 0)")
    phases = np.empty(_MAX_SEGMENTS, dtype=np.int64)
    Pn, Pt, vn1, vt1, Pc, Wc, nseg = impact_kernel(Wnn, Wnt, Wtt, vn, vt, mu, e, LAWS[law],
                                                   phases)
    P = np.array([Pn, Pt])
    dKE = float(P @ np.array([vn, vt]) + 0.5 * P @ W @ P)
    names = tuple(PHASES[p] for p in phases[:nseg])
    gains = law == "newton" and dKE > 1e-12 * max(1.0, 0.5 * (vn * vn + vt * vt) / Wnn)
    if gains:
        warnings.warn(f"Newton's law made energy in this impact (dKE = {dKE:.6g}): the slip "
                      "stopped or reversed; Stronge's law never does", RuntimeWarning,
                      stacklevel=2)
    return Impact(float(Pn), float(Pt), vn, vt, float(vn1), float(vt1), float(Pc), float(Wc),
                  dKE, names, law, e, bool(gains))


@dataclass(frozen=True)
class Simultaneous:
    """One solution of :func:`simultaneous`: per contact its mode (``"open"``,
    ``"stick"``, ``"slip_pos"``, ``"slip_neg"``), the impulses and the velocities after."""

    modes: tuple[str, ...]
    P: np.ndarray
    v: np.ndarray
    dKE: float
    #: the impulses are not determined (a singular W: more contact rows than the body's
    #: freedoms, a rod landing flat); ``P`` is the least-norm member of the family
    continuum: bool = False


def simultaneous(W, v_before, mu, *, e=0.0, tol: float = 1e-12, held=(),
                 delassus_made: bool = False) -> list[Simultaneous]:
    """Every impulse-level solution of k contacts closing at once, by Moreau's law
    (inelastic), or with restitution ``e`` by Moreau's generalised Newton law.

    ``W`` is the 2k x 2k Delassus matrix in (n1, t1, n2, t2, ...), ``v_before`` the 2k
    contact velocities before, ``mu`` the k friction coefficients, ``e`` the
    coefficients of restitution (one for all, or one per contact, in [0, 1]).  With
    w_c = -e_c min(v_n before, 0) (a contact that approaches rebounds; a closed one,
    v_n = 0 before, does not), each contact ends *open* (no impulse, v_n >= w), *stuck*
    (v_n = w, v_t = 0, |P_t| <= mu P_n), or *slipping* either way (v_n = w, P_t = -s mu
    P_n with s = sgn v_t after): 0 <= P_n is complementary to v_n after + e v_n before
    >= 0 (Glocker 2004; Pfeiffer and Glocker 1996).  The 4^k combinations are each a
    linear system, solved and kept where every inequality holds (within ``tol``
    relative).  The count is what the acceleration level counts too: for one body it is
    one (an inelastic impact always has a solution, Anitescu and Potra 1997); more than
    one is an indeterminate impact, none cannot happen for a positive definite W.  A
    singular W (more contact rows than freedoms, such as a rod landing flat on both
    ends) can leave the impulses undetermined: such a mode combination is reported once
    as a continuum, with its least-norm impulses.  Solutions equal to ``tol`` are
    reported once.  Without friction the generalised Newton law never gains energy
    for e <= 1; with friction it can, where a slip stops or reverses (as Newton's law
    at one contact): ``dKE`` says so.

    ``held``: contacts that have one more row, appended after the 2k in their order, whose
    velocity a closed contact brings to zero with whatever impulse it takes (a rolling
    disc's tangent: it rolls without slip; its friction channel is then its spin, with
    ``mu`` its rolling-friction length); an open one takes none.

    ``delassus_made``: ``W`` is :func:`delassus` of a positive definite mass matrix, so
    symmetric positive semi-definite by construction, and its check (an eigenvalue
    decomposition, a fifth of a landing's time) is skipped; the motion through contact
    changes passes it for every landing.

    >>> W = np.array([[2.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0],
    ...               [1.0, 0.0, 2.0, 0.0], [0.0, 1.0, 0.0, 1.0]]) + np.eye(4) * 0.5
    >>> [s.modes for s in simultaneous(W, [-1.0, 0.0, -1.0, 0.0], [0.5, 0.5])]
    [('stick', 'stick')]
    """
    W = np.asarray(W, dtype=float)
    v0 = np.asarray(v_before, dtype=float).ravel()
    mu = np.atleast_1d(np.asarray(mu, dtype=float))
    k = mu.size
    held = [int(c) for c in held]
    size = 2 * k + len(held)
    if W.shape != (size, size) or v0.size != size or not all(0 <= c < k for c in held):
        raise ValueError(f"simultaneous: W must be {size}x{size} and v_before {size} long "
                         f"for {k} friction coefficients and {len(held)} held rows, got "
                         f"{W.shape} and {v0.size}")
    if not (np.all(np.isfinite(W)) and np.all(np.isfinite(v0)) and np.all(mu >= 0)):
        raise ValueError("simultaneous: W and v_before must be finite and mu >= 0")
    try:
        e = np.broadcast_to(np.asarray(e, dtype=float), (k,))
    except (TypeError, ValueError):
        raise ValueError(f"simultaneous: e must be one number or {k}, got {e!r}") from None
    if not np.all((e >= 0.0) & (e <= 1.0)):
        raise ValueError(f"simultaneous: e must be in [0, 1], got {e.tolist()}")
    w = np.zeros(size)
    w[0:2 * k:2] = -e * np.minimum(v0[0:2 * k:2], 0.0)   # a closed contact's normal after
    if not delassus_made and (not np.allclose(W, W.T) or np.linalg.eigvalsh(W).min()
                              < -1e-12 * np.abs(W).max()):
        raise ValueError("simultaneous: W must be symmetric positive semi-definite")
    scale = max(float(np.abs(v0).max()), 1e-300)
    pscale = scale / float(np.abs(W).max())
    found: list[Simultaneous] = []
    names = ("open", "stick", "slip_pos", "slip_neg")
    # (the tests below on Python floats: the same doubles and the same comparisons as on
    # NumPy's scalars, at a fraction of their cost)
    wl, mul = w.tolist(), mu.tolist()
    for combo in itertools.product(range(4), repeat=k):
        A = np.zeros((size, size))
        b = np.zeros(size)
        for j, c in enumerate(held):
            r = 2 * k + j
            if combo[c] == 0:      # open: no impulse
                A[r, r] = 1.0
            else:                  # closed: its velocity zero after
                A[r], b[r] = W[r], -v0[r]
        for c, mode in enumerate(combo):
            n, t = 2 * c, 2 * c + 1
            if mode == 0:  # open: no impulse
                A[n, n] = A[t, t] = 1.0
            else:  # closed: v_n after = w (0 for an inelastic impact)
                A[n], b[n] = W[n], w[n] - v0[n]
                if mode == 1:  # stuck: v_t after = 0
                    A[t], b[t] = W[t], -v0[t]
                else:  # slipping: P_t = -s mu P_n
                    s = 1.0 if mode == 2 else -1.0
                    A[t, t], A[t, n] = 1.0, s * mu[c]
        if not any(combo):     # every contact open: A = I, b = 0, no impulse exactly
            P, rank = np.zeros(size), size
        else:
            P, _, rank, _ = np.linalg.lstsq(A, b, rcond=1e-12)
            if np.abs(A @ P - b).max() > 1e-9 * (np.abs(b).max() + pscale):
                continue  # inconsistent: no impulse puts the contacts in these modes
        continuum = rank < size
        for c, mode in enumerate(combo):
            if mode == 0:
                P[2 * c] = P[2 * c + 1] = 0.0  # exactly: least squares leaves rounding
        for j, c in enumerate(held):
            if combo[c] == 0:
                P[2 * k + j] = 0.0
        v = v0 + W @ P
        Pl, vl = P.tolist(), v.tolist()
        ok = True
        for c, mode in enumerate(combo):
            n, t = 2 * c, 2 * c + 1
            if mode == 0:
                ok = ok and vl[n] >= wl[n] - tol * scale
            else:
                ok = ok and Pl[n] >= -tol * pscale
                if mode == 1:
                    ok = ok and abs(Pl[t]) <= mul[c] * Pl[n] + tol * pscale
                else:
                    s = 1.0 if mode == 2 else -1.0
                    ok = ok and s * vl[t] > tol * scale
        if ok and not any(np.allclose(P, f.P, atol=tol * pscale * 10) for f in found):
            found.append(Simultaneous(tuple(names[j] for j in combo), P, v,
                                      float(P @ v0 + 0.5 * P @ W @ P), bool(continuum)))
    return found


def delassus(M, J) -> np.ndarray:
    """W = J M^-1 J^T: the Delassus matrix of the contact rows ``J`` (a 2 x n Jacobian,
    normal row first) of a system with mass matrix ``M`` (n x n, symmetric positive
    definite)."""
    M = np.asarray(M, dtype=float)
    J = np.atleast_2d(np.asarray(J, dtype=float))
    if M.ndim != 2 or M.shape[0] != M.shape[1] or J.shape[1] != M.shape[0]:
        raise ValueError(f"delassus: M must be n x n and J k x n, got {M.shape} and {J.shape}")
    return J @ np.linalg.solve(M, J.T)


def delassus_body(m: float, inertia: float, r, normal=(0.0, 1.0)) -> np.ndarray:
    """W of one planar rigid body (mass ``m``, moment of inertia ``inertia`` about its
    centre of mass) at a contact point ``r`` from its centre of mass, with unit normal
    ``normal`` and tangent t = (n_y, -n_x) rotated from it (for n = (0, 1), t = (1, 0))."""
    n = np.asarray(normal, dtype=float)
    n = n / np.hypot(*n)
    t = np.array([n[1], -n[0]])
    rx, ry = (float(x) for x in r)
    rn = rx * n[1] - ry * n[0]
    rt = rx * t[1] - ry * t[0]
    return np.array([[1 / m + rn * rn / inertia, rn * rt / inertia],
                     [rn * rt / inertia, 1 / m + rt * rt / inertia]])


def zeno_time(t_k: float, v_k: float, a_n: float, e: float) -> float:
    """When the impacts of a bouncing contact accumulate: ``t_k + 2 v_k / (|a_n| (1 - e))``
    for a rebound speed ``v_k`` at ``t_k`` under a constant normal acceleration ``a_n``
    towards the obstacle and Newton restitution ``e`` < 1 (the geometric series of the
    flight times 2 v_k e^j / |a_n|).

    >>> round(zeno_time(math.sqrt(2 / 9.81), 0.5 * math.sqrt(2 * 9.81), -9.81, 0.5), 6)
    1.354571
    """
    if not 0.0 <= e < 1.0:
        raise ValueError(f"e must be in [0, 1) for the impacts to accumulate, got {e!r}")
    if a_n == 0.0:
        raise ValueError("a_n must be nonzero: without an acceleration towards the obstacle "
                         "the impacts do not accumulate")
    return t_k + 2.0 * v_k / (abs(a_n) * (1.0 - e))


def tangential_impact(M, Jc, u, mu, slip=None, held=None):
    """The impact without collision at one contact (Genot and Brogliato 1999): at zero
    normal velocity, the slip ``Jc[1] @ u`` forced into the obstacle, the impulse
    integrated until the slip stops (:func:`phasemap.motion.impact.impact`, e = 0).
    ``M`` the mass matrix, ``Jc`` the contact's normal and tangential rows.  Returns the
    rates after it and the :class:`phasemap.motion.impact.Impact`; ValueError where the
    impact is refused (the slip does not force the contact in).  The reduced model's
    impacts without collision (:func:`phasemap.simulate`) and this engine's take it.

    ``held``: a row whose velocity stays zero through the impact, with whatever impulse it
    takes (a rolling disc's tangent, ``Jc`` then its normal and spin, ``mu`` its
    rolling-friction length): the impact runs on the Delassus matrix of ``Jc`` with that
    row held, the Schur complement ``W_cc - W_ch W_hh^-1 W_hc``.  The Impact's ``P_t`` is
    then the held row's impulse (the force along the surface); the spin's (the rolling
    friction's moment) is ``-s mu P_n`` while it spins."""
    slip = float(Jc[1] @ u) if slip is None else float(slip)
    if held is None:
        r = impact(delassus(M, Jc), (0.0, slip), mu=mu, e=0.0)
        return u + np.linalg.solve(M, Jc.T @ np.array([r.P_n, r.P_t])), r
    rows = np.vstack([Jc, held])
    W3 = delassus(M, rows)
    W = W3[:2, :2] - np.outer(W3[:2, 2], W3[2, :2]) / W3[2, 2]
    r = impact(0.5 * (W + W.T), (0.0, slip), mu=mu, e=0.0)
    P = np.array([r.P_n, r.P_t])
    P_h = -(W3[2, :2] @ P) / W3[2, 2]       # keeps the held row's velocity where it was
    return (u + np.linalg.solve(M, rows.T @ np.append(P, P_h)),
            dataclasses.replace(r, P_t=float(P_h)))
