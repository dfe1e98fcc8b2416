"""Brute-force mode-enumeration oracles in full coordinates (pure numpy).

Independent of phasemap's physics (imports nothing from phasemap, no sympy).
Each planar rigid body is described in FULL coordinates q = (xc, yc, theta)
(centre of mass, counter-clockwise body angle) with its mass matrix
M = diag(m, m, J) and gravity.  Every contact force is an unknown.  For every
combination of contact modes, the square linear system

    M q'' = Q + sum_c ( N_c dvn_c/dq' + F_c dvt_c/dq' + K_c drho_c/dq' ),
    one pair (or triple) of mode rows per contact,

is solved with an SVD (rank-deficient systems are handled: indeterminate
reactions with unique accelerations, or a continuum of accelerations), and
the mode's own inequalities are checked.  ``vn`` is the normal gap velocity
(reaction direction, opening positive), ``vt`` the slip velocity of the body's
material point at the contact (friction force conjugate to it), ``rho`` a
rolling rate (rolling contacts only; the rolling couple K is conjugate to it).
The time derivatives d/dt vn = (dvn/dq') q'' + (D_q vn) q' are formed with a
complex-step derivative along q' (exact to rounding; the velocity functions
are written with numpy functions that accept complex angles).

Modes of a one-sided point contact with friction f:
    ``sep``    N = F = 0, gap acceleration > tol (strict: a tie is kept grazing);
    ``slip+`` / ``slip-``  gap'' = 0, F = -s f N, N >= -tol; only the direction
               sgn(vt) when vt != 0; at vt = 0 a start needs s vt' > tol;
    ``stick``  (vt = 0 only) gap'' = 0, vt' = 0, N >= -tol, |F| <= f N + tol.
Modes of a one-sided rolling contact (no slip, unlimited F, rolling couple
magnitude delta N opposing the rolling rate rho):
    ``sep``    N = F = K = 0, gap'' > tol;
    ``roll+`` / ``roll-``  gap'' = 0, vt' = 0, K = -s delta N, N >= -tol; at
               rho = 0 a start needs s rho' > tol;
    ``rest``   (rho = 0 only) gap'' = 0, vt' = 0, rho' = 0, |K| <= delta N + tol.

Ties follow GUIDE section 1: stick (rest) ties to admissible, a slip start
needs a strictly positive acceleration, a kept contact with N = 0 (to
tolerance) is kept (grazing), separation needs a strictly opening gap.  Every
zero test is relative: tol = RTOL * scale, with the scale of forces
m (g + L w^2) (1 + f) and of accelerations g + L w^2 of each system (L its
size, w a velocity scale of the state).  ``margin`` reports the smallest
relative distance of any decisive quantity from its threshold, so that tests
can stay away from ties.

Public API (all return an :class:`Answer`):
    painleve_rod(theta, omega, xdot, f, l, g, m, k=None)   (k: radius of gyration)
    ladder(phi, omega, f, l, g, m)
    wheel(phi, omega, delta, r, l, rho, g, m)
    rod_on_step(theta, omega, f, l, h, g, m, f_edge=None, a=None, k=None, push=0.0)
    corner_block(psi, omega, sdot, f, a, b, alpha, g, m)
    leaning_ladder(phi, omega, f1, f2, beta, l, g, m)
    ledge_rod(xdot, f, l, h, g, m)
    incline_point(xdot, f, alpha, g, m)
    drawer(xdot, f, a, c, psi, d, p, g, m)
    peg_rod(theta, omega, f, l, p, g, m)
and the closed forms painleve_rod_threshold(), painleve_rod_B(theta, f, s),
drawer_wedge(a, c, psi).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

RTOL = 1e-9       # relative tolerance of every zero test
VTOL = 1e-12      # a slip velocity below VTOL * velocity scale is zero
_H = 1e-30        # complex step

NONE, UNIQUE, TWO, CONTINUUM, THREE_OR_MORE = 0, 1, 2, 3, 4


@dataclass
class Contact:
    """One contact: velocity functions (q, qd) -> scalar, linear in qd."""

    name: str
    vn: object
    vt: object
    f: float | None = None          # Coulomb coefficient (None: rolling, no slip)
    rho: object = None              # rolling rate (rolling contacts)
    delta: float = 0.0              # rolling friction length

    @property
    def rolling(self) -> bool:
        return self.rho is not None


@dataclass
class Mode:
    """One admissible mode combination and its numbers."""

    modes: tuple[str, ...]          # one mode name per contact
    keeps: tuple[bool, ...]         # which contacts it keeps
    qdd: np.ndarray                 # (xc'', yc'', theta'') of the body (a point of a continuum)
    N: np.ndarray                   # normal reactions (0 where separated)
    F: np.ndarray                   # tangential reactions
    K: np.ndarray                   # rolling couples (0 for point contacts)
    continuum: bool = False         # a one-parameter family of accelerations
    indeterminate: bool = False     # unique accelerations, reactions not unique
    gap_dd: np.ndarray = field(default_factory=lambda: np.zeros(0))   # gap accelerations
    extra: dict = field(default_factory=dict)   # system-specific reduced numbers


@dataclass
class Answer:
    n_solutions: int
    stagnation: bool
    modes: list                     # admissible Mode objects
    contacts: tuple[str, ...]
    margin: float                   # smallest relative slack of a decisive test

    @property
    def keeps(self) -> tuple[bool, ...]:
        """Per contact: kept by every admissible solution (False if there is none)."""
        if not self.modes:
            return tuple(False for _ in self.contacts)
        return tuple(all(md.keeps[i] for md in self.modes) for i in range(len(self.contacts)))

    def by_modes(self) -> dict:
        return {md.modes: md for md in self.modes}

    @property
    def all_kept(self) -> list:
        """Admissible modes that keep every contact."""
        return [md for md in self.modes if all(md.keeps)]

    @property
    def separating(self) -> list:
        """Admissible modes that leave at least one contact."""
        return [md for md in self.modes if not all(md.keeps)]


def _jac(fun, q, n=3):
    """Row d fun / d qd (fun linear in qd)."""
    return np.array([float(np.real(fun(q, np.eye(n)[k]))) for k in range(n)])


def _drift(fun, q, qd):
    """(D_q fun(q, qd)) qd by a complex step along qd."""
    return float(np.imag(fun(q + 1j * _H * qd, qd)) / _H)


def _contact_modes(c: Contact, vt: float, rho: float, vscale: float):
    if c.rolling:
        if abs(rho) > VTOL * vscale:
            kept = ["roll+" if rho > 0 else "roll-"]
        else:
            kept = ["rest", "roll+", "roll-"]
    else:
        if abs(vt) > VTOL * vscale:
            kept = ["slip+" if vt > 0 else "slip-"]
        else:
            kept = ["stick", "slip+", "slip-"]
    return kept + ["sep"]


def _equilibrate(A):
    r = np.max(np.abs(A), axis=1)
    r[r == 0] = 1.0
    A1 = A / r[:, None]
    c = np.max(np.abs(A1), axis=0)
    c[c == 0] = 1.0
    return r, c


def enumerate_modes(q, qd, M, Q, contacts, force_scale, acc_scale, length, vscale):
    """Every admissible mode combination at one state (the generic oracle)."""
    nq = len(q)
    nc = len(contacts)
    # unknown layout: qdd (nq), then per contact N, F, K
    nz = nq + 3 * nc
    Gn = [_jac(c.vn, q, nq) for c in contacts]
    Gt = [_jac(c.vt, q, nq) for c in contacts]
    gn0 = [_drift(c.vn, q, qd) for c in contacts]
    gt0 = [_drift(c.vt, q, qd) for c in contacts]
    Gr = [(_jac(c.rho, q, nq) if c.rolling else np.zeros(nq)) for c in contacts]
    gr0 = [(_drift(c.rho, q, qd) if c.rolling else 0.0) for c in contacts]
    vts = [float(np.real(c.vt(q, qd))) for c in contacts]
    rhos = [(float(np.real(c.rho(q, qd))) if c.rolling else 0.0) for c in contacts]
    tolF = RTOL * force_scale
    tolA = RTOL * acc_scale
    tolK = RTOL * force_scale * length
    tolR = RTOL * acc_scale / length

    options = [_contact_modes(c, vts[i], rhos[i], vscale) for i, c in enumerate(contacts)]
    admissible = []
    margin = math.inf
    for combo in itertools.product(*options):
        A = np.zeros((nz, nz))
        b = np.zeros(nz)
        A[:nq, :nq] = M
        b[:nq] = Q
        for i in range(nc):
            A[:nq, nq + 3 * i] = -Gn[i]
            A[:nq, nq + 3 * i + 1] = -Gt[i]
            A[:nq, nq + 3 * i + 2] = -Gr[i]
        ineq = []   # (row c, rhs d, tol, strict): c.z >= d (+ tol if strict, else - tol)
        row = nq
        for i, (c, mode) in enumerate(zip(contacts, combo)):
            jN, jF, jK = nq + 3 * i, nq + 3 * i + 1, nq + 3 * i + 2
            if mode == "sep":
                A[row, jN] = 1.0
                A[row + 1, jF] = 1.0
                A[row + 2, jK] = 1.0
                cg = np.zeros(nz)
                cg[:nq] = Gn[i]
                ineq.append((cg, -gn0[i], tolA, True))
                row += 3
                continue
            # kept: gap acceleration zero, N >= 0
            A[row, :nq] = Gn[i]
            b[row] = -gn0[i]
            cN = np.zeros(nz)
            cN[jN] = 1.0
            ineq.append((cN, 0.0, tolF, False))
            if c.rolling:
                A[row + 1, :nq] = Gt[i]          # no slip
                b[row + 1] = -gt0[i]
                law = (row + 2, jK, Gr[i], gr0[i], c.delta, rhos[i], tolK, tolR)
            else:
                A[row + 2, jK] = 1.0             # no couple at a point contact
                law = (row + 1, jF, Gt[i], gt0[i], c.f, vts[i], tolF, tolA)
            _friction_law(A, b, ineq, jN, mode, vscale, *law)
            row += 3
        sol = _solve_family(A, b)
        if sol is None:
            continue
        z0, v = sol
        lo, hi = -math.inf, math.inf
        open_lo = open_hi = False      # a strict inequality leaves its end out
        ok = True
        for cvec, d, tol, strict in ineq:
            a0 = float(cvec @ z0) - d
            a1 = 0.0 if v is None else float(cvec @ v)
            thr = tol if strict else -tol
            if v is None or abs(a1) <= 1e-12 * (abs(a0) + 1.0):
                rel = abs(a0) / (tol / RTOL) if tol > 0 else (math.inf if a0 else 0.0)
                if rel > 1e-11:     # structural zeros (e.g. a start the kinematics forbids) are exact ties
                    margin = min(margin, rel)
                if a0 <= thr if strict else a0 < thr:
                    ok = False
            elif a1 > 0:
                t = (thr - a0) / a1
                lo, open_lo = (t, strict) if t > lo else (lo, open_lo or (t == lo and strict))
            else:
                t = (thr - a0) / a1
                hi, open_hi = (t, strict) if t < hi else (hi, open_hi or (t == hi and strict))
        if not ok or lo > hi or (lo == hi and (open_lo or open_hi)):
            continue
        cont = False
        indet = False
        z = z0
        if v is not None:
            moves = np.max(np.abs(v[:nq])) > 1e-9 * np.max(np.abs(v))
            t = 0.0 if lo <= 0.0 <= hi else (lo if math.isfinite(lo) else hi)
            if math.isfinite(lo) and math.isfinite(hi):
                t = 0.5 * (lo + hi)
            z = z0 + t * v
            if moves:
                cont = hi - lo > 1e-9 * (1.0 + abs(lo) + abs(hi))
            indet = not moves
        gap = np.array([float(Gn[i] @ z[:nq] + gn0[i]) for i in range(nc)])
        admissible.append(Mode(
            modes=combo,
            keeps=tuple(mo != "sep" for mo in combo),
            qdd=z[:nq].copy(),
            N=z[nq::3].copy(), F=z[nq + 1::3].copy(), K=z[nq + 2::3].copy(),
            continuum=cont, indeterminate=indet, gap_dd=gap,
        ))
    if any(md.continuum for md in admissible):
        n = CONTINUUM
    else:
        n = min(len(admissible), 3)
        n = THREE_OR_MORE if n == 3 else n
    rest_combo = tuple("rest" if c.rolling else "stick" for c in contacts)
    stagnation = any(md.modes == rest_combo for md in admissible)
    return Answer(n, stagnation, admissible, tuple(c.name for c in contacts), margin)


def _friction_law(A, b, ineq, jN, mode, vscale, r, jX, G, g0, coeff, v, tol_cone, tol_start):
    """Row ``r`` of a kept contact's friction law on the unknown ``jX`` (F, or a rolling
    couple K) whose channel has the velocity Jacobian ``G``, drift ``g0`` and velocity ``v``:
    at rest (``stick``, ``rest``) the channel's acceleration is zero and ``coeff N -+ X >= 0``;
    moving in direction s (``slip+``, ``roll-``...) ``X = -s coeff N``, and from rest the
    channel must start in direction s."""
    nq = len(G)
    if mode in ("stick", "rest"):
        A[r, :nq] = G
        b[r] = -g0
        for sgn in (1.0, -1.0):      # coeff N - sgn X >= 0
            cc = np.zeros(A.shape[1])
            cc[jN] = coeff
            cc[jX] = -sgn
            ineq.append((cc, 0.0, tol_cone, False))
        return
    s = 1.0 if mode.endswith("+") else -1.0
    A[r, jX] = 1.0
    A[r, jN] = s * coeff
    if abs(v) <= VTOL * vscale:
        ct = np.zeros(A.shape[1])
        ct[:nq] = s * G
        ineq.append((ct, -s * g0, tol_start, True))


def _solve_family(A, b):
    """Solutions of A z = b: None (inconsistent), (z0, None) or (z0, v) (1-D family)."""
    r, c = _equilibrate(A)
    As = A / r[:, None] / c[None, :]
    bs = b / r
    U, S, Vt = np.linalg.svd(As)
    rank = int(np.sum(S > 1e-10 * S[0]))
    y = (U[:, :rank].T @ bs) / S[:rank]
    zs = Vt[:rank].T @ y
    res = As @ zs - bs
    if np.max(np.abs(res)) > 1e-9 * (np.max(np.abs(bs)) + np.max(np.abs(zs)) + 1e-300):
        return None
    z0 = zs / c
    if rank == A.shape[0]:
        return z0, None
    if rank < A.shape[0] - 1:
        raise NotImplementedError("null space of dimension >= 2")
    v = Vt[rank] / c
    return z0, v / np.max(np.abs(v))


# ---------------------------------------------------------------------------
# Systems
# ---------------------------------------------------------------------------

def _rot(th):
    return np.cos(th), np.sin(th)


def painleve_rod(theta, omega, xdot, f, l, g, m, k=None):
    """The classic Painleve rod: uniform rod (length 2l, J = m l^2/3), end A on a rough floor.

    ``k``: the radius of gyration about the centre (J = m k^2; default l / sqrt 3).

    theta in (0, pi) is the counter-clockwise angle from the +x axis to the rod
    direction A -> C, so C = A + l (cos theta, sin theta); xdot is A's velocity
    along the floor.  Contacts: ``floor`` (one-sided, friction f).  Full
    coordinates (xc, yc, theta); A - C = -l (cos theta, sin theta).
    """
    def vA(q, qd):
        c, s = _rot(q[2])
        return qd[0] + l * s * qd[2], qd[1] - l * c * qd[2]

    floor = Contact("floor", vn=lambda q, qd: vA(q, qd)[1], vt=lambda q, qd: vA(q, qd)[0], f=f)
    c, s = math.cos(theta), math.sin(theta)
    q = np.array([0.0, l * s, theta])
    qd = np.array([xdot - l * s * omega, l * c * omega, omega])
    M = np.diag([m, m, m * l * l / 3.0 if k is None else m * k * k])
    Q = np.array([0.0, -m * g, 0.0])
    w2 = omega * omega + xdot * xdot / (l * l)
    ans = enumerate_modes(q, qd, M, Q, [floor], m * (g + l * w2) * (1.0 + f), g + l * w2, l,
                          math.sqrt(g / l) * l + abs(xdot) + l * abs(omega))
    for md in ans.modes:
        md.extra = {"theta_ddot": md.qdd[2], "N": md.N[0], "F": md.F[0],
                    "xA_ddot": float(md.qdd[0] + l * s * md.qdd[2] + l * c * omega ** 2)}
    return ans


def painleve_rod_B(theta, f, s):
    """Coefficient B of the kept-slip normal force: B N = m (g - l sin(theta) omega^2).

    B = 1 + 3 cos^2 theta + 3 s f sin theta cos theta, s = sgn(xdot).
    """
    return 1.0 + 3.0 * np.cos(theta) ** 2 + 3.0 * s * f * np.sin(theta) * np.cos(theta)


def painleve_rod_threshold():
    """(f_min, theta*) : smallest f with B = 0 somewhere, and where (for s = -1)."""
    return 4.0 / 3.0, math.atan(2.0)


def ladder(phi, omega, f, l, g, m):
    """The seed ladder in full coordinates, with separation from the wall and the floor.

    C = (l sin phi, l cos phi), phi from the vertical (counter-clockwise body
    angle), bottom end P1 = C + l (sin phi, -cos phi) on the floor y = 0, top
    end P2 = C - l (sin phi, -cos phi) on the wall x = 0.  Contacts ``floor``
    (normal +y, slip along x) and ``wall`` (normal +x, slip along y).
    """
    def v1(q, qd):
        c, s = _rot(q[2])
        return qd[0] + l * c * qd[2], qd[1] + l * s * qd[2]

    def v2(q, qd):
        c, s = _rot(q[2])
        return qd[0] - l * c * qd[2], qd[1] - l * s * qd[2]

    floor = Contact("floor", vn=lambda q, qd: v1(q, qd)[1], vt=lambda q, qd: v1(q, qd)[0], f=f)
    wall = Contact("wall", vn=lambda q, qd: v2(q, qd)[0], vt=lambda q, qd: v2(q, qd)[1], f=f)
    c, s = math.cos(phi), math.sin(phi)
    q = np.array([l * s, l * c, phi])
    qd = np.array([l * c * omega, -l * s * omega, omega])
    M = np.diag([m, m, m * l * l / 3.0])
    Q = np.array([0.0, -m * g, 0.0])
    w2 = omega * omega
    ans = enumerate_modes(q, qd, M, Q, [floor, wall], m * (g + l * w2) * (1.0 + f), g + l * w2,
                          l, math.sqrt(g * l) + l * abs(omega))
    for md in ans.modes:
        md.extra = {"phi_ddot": md.qdd[2], "N_floor": md.N[0], "N_wall": md.N[1]}
    return ans


def wheel(phi, omega, delta, r, l, rho, g, m):
    """The seed wheel in full coordinates, with hopping.

    Disc of radius r; phi is the clockwise rotation angle (body angle
    theta = -phi), geometric centre A = (r phi, r) while rolling, centre of mass
    C = A - l (sin phi, cos phi), J = m rho^2.  Contact ``floor``: one-sided,
    rolling without slip (unlimited friction), rolling couple delta N opposing
    the rolling rate phi'.  Contact point P = A - (0, r).
    """
    def vn(q, qd):
        c, s = _rot(q[2])
        return qd[1] - l * s * qd[2]                       # d/dt y_A, y_A = yc + l cos theta

    def vt(q, qd):
        c, s = _rot(q[2])
        return qd[0] + qd[2] * (r - l * c)                 # material point at P, along x

    floor = Contact("floor", vn=vn, vt=vt, rho=lambda q, qd: -qd[2], delta=delta)
    c, s = math.cos(phi), math.sin(phi)
    q = np.array([r * phi - l * s, r - l * c, -phi])
    qd = np.array([(r - l * c) * omega, l * s * omega, -omega])
    M = np.diag([m, m, m * rho * rho])
    Q = np.array([0.0, -m * g, 0.0])
    w2 = omega * omega
    ans = enumerate_modes(q, qd, M, Q, [floor], m * (g + r * w2) * (1.0 + delta / r),
                          g + r * w2, r, math.sqrt(g * r) + r * abs(omega))
    for md in ans.modes:
        md.extra = {"phi_ddot": -md.qdd[2], "N": md.N[0], "F": md.F[0]}
    return ans


def rod_on_step(theta, omega, f, l, h, g, m, f_edge=None, a=None, k=None, push=0.0):
    """Uniform rod (length 2l, J = m l^2/3): end A on a rough floor, resting on a rough step edge.

    The edge is the fixed point K = (0, h); theta in (0, pi/2) is the rod's
    angle to the floor and the rod passes over K: A = (-h cot theta, 0),
    C = A + l e, e = (cos theta, sin theta); requires h / sin theta <= 2 l (K on
    the rod).  Contacts ``floor`` (at A, normal +y, slip along x, friction f)
    and ``edge`` (at K, normal nu = (-sin theta, cos theta), slip along e,
    friction f_edge, default f).  Both kept: one degree of freedom theta, with
    slip velocities xA' = h omega / sin^2 theta and e.v_K = h cos theta omega /
    sin^2 theta (both of the sign of omega).  ``a``: the centre of mass at C = A + a e
    instead (default l), ``k`` its radius of gyration (default l / sqrt 3), ``push``
    a constant force along +x at C.
    """
    fe = f if f_edge is None else f_edge
    ac = l if a is None else a
    J = m * l * l / 3.0 if k is None else m * k * k

    def vA(q, qd):
        c, s = _rot(q[2])
        return qd[0] + ac * s * qd[2], qd[1] - ac * c * qd[2]

    def edge_v(q, qd):
        c, s = _rot(q[2])
        nu = (-s, c)
        e = (c, s)
        dx, dy = q[0], q[1] - h                            # C - K
        vn = nu[0] * qd[0] + nu[1] * qd[1] - qd[2] * (e[0] * dx + e[1] * dy)
        vt = e[0] * qd[0] + e[1] * qd[1] + qd[2] * (nu[0] * dx + nu[1] * dy)
        return vn, vt

    floor = Contact("floor", vn=lambda q, qd: vA(q, qd)[1], vt=lambda q, qd: vA(q, qd)[0], f=f)
    edge = Contact("edge", vn=lambda q, qd: edge_v(q, qd)[0], vt=lambda q, qd: edge_v(q, qd)[1],
                   f=fe)
    c, s = math.cos(theta), math.sin(theta)
    xA = -h * c / s
    xAd = h * omega / (s * s)
    q = np.array([xA + ac * c, ac * s, theta])
    qd = np.array([xAd - ac * s * omega, ac * c * omega, omega])
    M = np.diag([m, m, J])
    Q = np.array([push, -m * g, 0.0])
    w2 = omega * omega * (1.0 + (h / (l * s * s)) ** 2)
    fm = max(f, fe)
    ans = enumerate_modes(q, qd, M, Q, [floor, edge], (m * (g + l * w2) + abs(push)) * (1.0 + fm),
                          g + l * w2, l, math.sqrt(g * l) + l * math.sqrt(w2))
    for md in ans.modes:
        md.extra = {"theta_ddot": md.qdd[2], "N_floor": md.N[0], "N_edge": md.N[1]}
    return ans


def _body_point(r):
    """Velocity functions of the body point at ``r(q)`` from the centre (q = (xc, yc, theta)):
    (vx, vy) = (xc' - theta' r_y, yc' + theta' r_x)."""
    def v(q, qd):
        rx, ry = r(q)
        return qd[0] - qd[2] * ry, qd[1] + qd[2] * rx
    return v


def _on_surface(name, v, normal, f):
    """A one-sided point contact with the velocity function ``v`` on a flat surface with
    the unit ``normal`` (slip positive along the normal turned clockwise)."""
    nx_, ny_ = normal
    return Contact(name, vn=lambda q, qd: nx_ * v(q, qd)[0] + ny_ * v(q, qd)[1],
                   vt=lambda q, qd: ny_ * v(q, qd)[0] - nx_ * v(q, qd)[1], f=f)


def corner_block(psi, omega, sdot, f, a, b, alpha, g, m):
    """A block (2a wide, 2b high, J = m (a^2 + b^2)/3) balanced on its corner P on a rough
    incline of angle alpha (normal n = (-sin alpha, cos alpha)).

    The block's bottom makes the angle psi with the incline (body angle alpha + psi);
    the centre is C = P + R(alpha + psi) (a, b).  P moves along the incline with sdot.
    """
    th = alpha + psi
    n = (-math.sin(alpha), math.cos(alpha))
    t = (math.cos(alpha), math.sin(alpha))

    def r(q):                                   # P - C
        c, s = _rot(q[2])
        return -(a * c - b * s), -(a * s + b * c)

    corner = _on_surface("corner", _body_point(r), n, f)
    c, s = math.cos(th), math.sin(th)
    d = (a * c - b * s, a * s + b * c)          # C - P
    q = np.array([d[0], d[1], th])
    qd = np.array([sdot * t[0] - omega * d[1], sdot * t[1] + omega * d[0], omega])
    M = np.diag([m, m, m * (a * a + b * b) / 3.0])
    Q = np.array([0.0, -m * g, 0.0])
    L = math.hypot(a, b)
    w2 = omega * omega + sdot * sdot / (L * L)
    return enumerate_modes(q, qd, M, Q, [corner], m * (g + L * w2) * (1.0 + f), g + L * w2, L,
                           math.sqrt(g * L) + abs(sdot) + L * abs(omega))


def leaning_ladder(phi, omega, f1, f2, beta, l, g, m):
    """A ladder (2l, J = m l^2/3) with its foot on a rough floor (f1) and its top against a
    rough wall (f2) that leans back from the vertical by beta: the wall is the line
    through the origin with the normal n = (cos beta, sin beta).

    phi is the ladder's angle from the vertical (its body angle): foot
    P1 = C + l (sin phi, -cos phi) on y = 0, top P2 = C - l (sin phi, -cos phi) on the
    wall, so C = (l sin phi - 2 l cos phi tan beta, l cos phi).
    """
    n = (math.cos(beta), math.sin(beta))
    foot = _on_surface("floor", _body_point(lambda q: (l * np.sin(q[2]), -l * np.cos(q[2]))),
                       (0.0, 1.0), f1)
    top = _on_surface("wall", _body_point(lambda q: (-l * np.sin(q[2]), l * np.cos(q[2]))),
                      n, f2)
    c, s, tb = math.cos(phi), math.sin(phi), math.tan(beta)
    q = np.array([l * s - 2 * l * c * tb, l * c, phi])
    qd = np.array([(l * c + 2 * l * s * tb) * omega, -l * s * omega, omega])
    M = np.diag([m, m, m * l * l / 3.0])
    Q = np.array([0.0, -m * g, 0.0])
    w2 = omega * omega
    return enumerate_modes(q, qd, M, Q, [foot, top], m * (g + l * w2) * (1.0 + max(f1, f2)),
                           g + l * w2, l, math.sqrt(g * l) + l * abs(omega))


def ledge_rod(xdot, f, l, h, g, m):
    """A uniform rod (2l, J = m l^2/3) with its end A on a rough floor and its end B on a
    rough ledge at the height h < 2l (both one-sided, friction f): its angle to the floor
    is fixed, sin(theta) = h / (2 l), and it slides with xdot."""
    th = math.asin(h / (2 * l))
    foot = _on_surface("A", _body_point(lambda q: (-l * np.cos(q[2]), -l * np.sin(q[2]))),
                       (0.0, 1.0), f)
    end = _on_surface("B", _body_point(lambda q: (l * np.cos(q[2]), l * np.sin(q[2]))),
                      (0.0, 1.0), f)
    q = np.array([l * math.cos(th), l * math.sin(th), th])
    qd = np.array([xdot, 0.0, 0.0])
    M = np.diag([m, m, m * l * l / 3.0])
    Q = np.array([0.0, -m * g, 0.0])
    return enumerate_modes(q, qd, M, Q, [foot, end], m * g * (1.0 + f) + m * xdot * xdot / l,
                           g + xdot * xdot / l, l, math.sqrt(g * l) + abs(xdot))


def incline_point(xdot, f, alpha, g, m):
    """A point mass on a rough incline of angle alpha (normal (-sin alpha, cos alpha)),
    moving along it with the velocity xdot of its x coordinate."""
    n = (-math.sin(alpha), math.cos(alpha))
    point = _on_surface("P", lambda q, qd: (qd[0], qd[1]), n, f)
    q = np.zeros(2)
    qd = np.array([xdot, xdot * math.tan(alpha)])
    M = np.diag([m, m])
    Q = np.array([0.0, -m * g])
    return enumerate_modes(q, qd, M, Q, [point], m * g * (1.0 + f), g, 1.0,
                           math.sqrt(g) + abs(xdot))


def drawer(xdot, f, a, c, psi, d, p, g, m):
    """A drawer (half length a, half width c, J = m (a^2 + c^2)/3) tilted by psi in a slot
    whose guides are the lines y = -+w, w = a sin psi + c cos psi: its corner R(psi) (a, c)
    against the upper guide (normal -y), the opposite corner against the lower one
    (normal +y), both one-sided with friction f; gravity -y, and the push (-p, 0) at the
    handle R(psi) (a, -d).  It slides along the slot with xdot."""
    def corner(sign):
        return _body_point(lambda q: (sign * (a * np.cos(q[2]) - c * np.sin(q[2])),
                                      sign * (a * np.sin(q[2]) + c * np.cos(q[2]))))

    upper = _on_surface("upper", corner(1.0), (0.0, -1.0), f)
    lower = _on_surface("lower", corner(-1.0), (0.0, 1.0), f)
    cs, sn = math.cos(psi), math.sin(psi)
    q = np.array([0.0, 0.0, psi])
    qd = np.array([xdot, 0.0, 0.0])
    M = np.diag([m, m, m * (a * a + c * c) / 3.0])
    Q = np.array([-p, -m * g, p * (a * sn - d * cs)])
    L = math.hypot(a, c)
    load = m * g + p
    return enumerate_modes(q, qd, M, Q, [upper, lower], (load + m * xdot * xdot / L) * (1.0 + f),
                           load / m + xdot * xdot / L, L, math.sqrt(g * L) + abs(xdot))


def drawer_wedge(a, c, psi):
    """The drawer's self-locking friction: its two reactions can squeeze it with no load
    where the line through the two corners lies in both friction cones,
    f >= (a cos psi - c sin psi) / (a sin psi + c cos psi)."""
    return ((a * math.cos(psi) - c * math.sin(psi))
            / (a * math.sin(psi) + c * math.cos(psi)))


def peg_rod(theta, omega, f, l, p, g, m):
    """A uniform rod (2l, J = m l^2/3) with its end A against a rough wall x = 0 (normal
    +x), lying on a rough peg, the fixed corner K = (p, 0): theta is the rod's angle above
    the horizontal, A = (0, -p tan theta), C = A + l (cos theta, sin theta); both contacts
    one-sided with friction f (the peg's slip is the rod's material velocity along it)."""
    wall = _on_surface("wall", _body_point(lambda q: (-l * np.cos(q[2]), -l * np.sin(q[2]))),
                       (1.0, 0.0), f)

    def peg_v(q, qd):
        cs, sn = _rot(q[2])
        nu, e = (-sn, cs), (cs, sn)
        dx, dy = q[0] - p, q[1]                            # C - K
        vn = nu[0] * qd[0] + nu[1] * qd[1] - qd[2] * (e[0] * dx + e[1] * dy)
        vt = e[0] * qd[0] + e[1] * qd[1] + qd[2] * (nu[0] * dx + nu[1] * dy)
        return vn, vt

    peg = Contact("peg", vn=lambda q, qd: peg_v(q, qd)[0], vt=lambda q, qd: peg_v(q, qd)[1], f=f)
    cs, sn = math.cos(theta), math.sin(theta)
    yad = -p * omega / (cs * cs)
    q = np.array([l * cs, -p * sn / cs + l * sn, theta])
    qd = np.array([-l * sn * omega, yad + l * cs * omega, omega])
    M = np.diag([m, m, m * l * l / 3.0])
    Q = np.array([0.0, -m * g, 0.0])
    w2 = omega * omega * (1.0 + (p / (l * cs * cs)) ** 2)
    return enumerate_modes(q, qd, M, Q, [wall, peg], m * (g + l * w2) * (1.0 + f), g + l * w2,
                           l, math.sqrt(g * l) + l * math.sqrt(w2))


def barrow(phi, omega, f, delta, r, g, m, lw, k, mu, L, tau):
    """The wheelbarrow on its handles (tests/unseen.py), in the generalised coordinates
    q = (xa, ya, phi, theta) of its two bodies: the wheel's centre A, its clockwise angle
    phi, the handles' angle theta to the floor.  The wheel (mass m, centre of mass
    C_w = A - lw r (sin phi, cos phi), J_w = m k^2 r^2, body angle -phi) rolls with rolling
    friction delta on the floor y = 0 (contact ``wheel``: normal velocity ya', slip
    xa' - r phi', rolling rate -phi'); the handles, a uniform rod of mass mu m and length
    L r hinged at A (C_r = A - (L r / 2) e, e = (cos theta, sin theta), J_r = mu m (L r)^2 / 12)
    touch the floor at B = A - L r e with friction f (contact ``handles``).  The
    equations M q'' + h = Q + sum G^T lambda, with M = sum m_b J_b^T J_b + J_b a_b a_b^T, h
    the velocity terms sum m_b J_b^T (J_b' q'), Q the gravity forces and the torque tau on
    phi.  Both contacts kept: ya = r, sin theta = 1 / L, xa' = r omega."""
    mr = mu * m
    Lr = L * r
    sth = 1.0 / L
    th = math.asin(sth)
    q = np.array([r * phi, r, phi, th])
    qd = np.array([r * omega, 0.0, omega, 0.0])
    sp_, cp = math.sin(phi), math.cos(phi)
    st, ct = math.sin(th), math.cos(th)
    Jw = np.array([[1.0, 0.0, -lw * r * cp, 0.0], [0.0, 1.0, lw * r * sp_, 0.0]])
    Jr = np.array([[1.0, 0.0, 0.0, Lr / 2 * st], [0.0, 1.0, 0.0, -Lr / 2 * ct]])
    aw, ar = np.array([0.0, 0.0, -1.0, 0.0]), np.array([0.0, 0.0, 0.0, 1.0])
    M = (m * Jw.T @ Jw + m * (k * r) ** 2 * np.outer(aw, aw)
         + mr * Jr.T @ Jr + mr * Lr * Lr / 12.0 * np.outer(ar, ar))
    w2, t2 = omega * omega, 0.0
    dw = np.array([lw * r * sp_ * w2, lw * r * cp * w2])        # J_w' q'
    dr = np.array([Lr / 2 * ct * t2, Lr / 2 * st * t2])         # J_r' q'
    h = m * Jw.T @ dw + mr * Jr.T @ dr
    Q = np.array([0.0, -(m + mr) * g, -m * g * lw * r * sp_ + tau, mr * g * Lr / 2 * ct]) - h

    def handles_v(q, qd):
        c, s = _rot(q[3])
        return qd[0] + Lr * s * qd[3], qd[1] - Lr * c * qd[3]

    wheel = Contact("wheel", vn=lambda q, qd: qd[1], vt=lambda q, qd: qd[0] - r * qd[2],
                    rho=lambda q, qd: -qd[2], delta=delta)
    handles = Contact("handles", vn=lambda q, qd: handles_v(q, qd)[1],
                      vt=lambda q, qd: handles_v(q, qd)[0], f=f)
    force = (m + mr) * (g + r * w2) * (1.0 + f + delta / r) + abs(tau) / r
    ans = enumerate_modes(q, qd, M, Q, [wheel, handles], force, g + r * w2, r,
                          math.sqrt(g * r) + r * abs(omega))
    for md in ans.modes:
        md.extra = {"phi_ddot": md.qdd[2], "N_wheel": md.N[0], "N_handles": md.N[1]}
    return ans
