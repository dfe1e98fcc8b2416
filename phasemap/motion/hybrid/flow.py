"""The compiled flow of a phase in full coordinates: its accelerations, its event functions,
and DOP853 stepping from event to event, in machine code for every declaration at once.

A phase (each contact open, smooth, stuck or slipping one way) moves by one small
linear system (:mod:`phasemap.motion.hybrid.phases`): ``M u' = h + sum G lam`` with the
held accelerations ``R u' = rhs``.  The functions here solve it and step it with
scipy's DOP853 method (its coefficients and its step-size control, in machine code).
They are compiled once for every declaration: a declaration's own functions (its
generated pieces, rewritten by :mod:`.flowtext`) are compiled on their own, in well under
a second (:mod:`.binding`), and the kernels take the addresses of their machine code and
call them there (:func:`_at`).  Where a step holds an
event, :func:`locate` finds it.  Every kernel is in this one file: numba's cache renews a
function whose file changed, not one that calls it from another file.  The projection of a
state onto its closed contacts in the mass metric (:func:`project`) is here too.  What
follows an event (which phase, an impact, a jam) stays in
:class:`phasemap.motion.hybrid.Motion`, in Python.

Layout ``lay`` (int64): ``[n, k, n_domain, has_surface, has_kinetic]``.  The workspace
``W`` (float64, :func:`workspace`) holds the pieces first, at the offsets of
:meth:`phasemap.declare.full.Mechanics.pieces`, then the surfaces' speeds and rates,
then the slip coefficients.
"""

from __future__ import annotations

import numpy as np
from numba import prange, types
from numba.extending import intrinsic

from phasemap.core import calls, interpret, tiers
from phasemap.core.jit import njit
from phasemap.motion.hybrid.phases import OPEN, SLIP_NEG, SLIP_POS, SMOOTH, STICK, TOL

#: The signature of a declaration's rewritten functions (:mod:`.flowtext`):
#: ``f(out, y, p, t)``.
FUNCTION = types.none(types.Array(types.float64, 1, "C"), types.Array(types.float64, 1, "C"),
                      types.Array(types.float64, 1, "C"), types.float64)


@intrinsic
def _at(typingctx, at, out, y, p, t):
    """``f(out, y, p, t)`` for the declaration's function ``f`` whose machine code is at
    the address ``at`` (:func:`phasemap.core.calls.address`): called in numba's own
    calling convention, so that the kernels, compiled once for every declaration, are not
    typed again at each call as first-class function arguments are (about 4 us each)."""
    return calls.typer(FUNCTION, at, (out, y, p, t))


# what the kernels' twins call instead (the function's machine code, or its own twin, at
# phasemap.core.tiers' address or handle)
interpret.register(_at, tiers.at_address())

#: What :func:`accel` and :func:`advance` return.
OK, REDUNDANT, SINGULAR = 0, 1, 2
#: What :func:`advance` stopped at, beyond :data:`REDUNDANT` and :data:`SINGULAR`.
FINISHED, EVENT, FAILED, MAX_STEPS, FULL = 3, 4, 5, 6, 7

def _dop853_tables():
    """scipy's DOP853 tables (scipy/integrate/_ivp/dop853_coefficients.py), executed from
    their file: importing them as a module imports all of scipy.integrate first (0.4 s of
    every ``import phasemap``), and the file needs only numpy."""
    import importlib.util
    import os

    import scipy

    path = os.path.join(os.path.dirname(scipy.__file__), "integrate", "_ivp",
                        "dop853_coefficients.py")
    try:
        spec = importlib.util.spec_from_file_location("phasemap_dop853_coefficients", path)
        tables = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(tables)
    except OSError:      # (laid out otherwise: as a module, then)
        from scipy.integrate._ivp import dop853_coefficients as tables
    return tables


# scipy's DOP853 (scipy/integrate/_ivp/rk.py, dop853_coefficients.py)
_dc = _dop853_tables()
_A = np.ascontiguousarray(_dc.A)
_C = np.ascontiguousarray(_dc.C)
_B = np.ascontiguousarray(_dc.B)
_E3 = np.ascontiguousarray(_dc.E3)
_E5 = np.ascontiguousarray(_dc.E5)
_D = np.ascontiguousarray(_dc.D)
_SAFETY, _MIN_FACTOR, _MAX_FACTOR, _EXPONENT = 0.9, 0.2, 10.0, -1.0 / 8.0


@njit(cache=True, error_model="numpy")
def sizes_of(n, k):
    """``(pieces, workspace)``: the flat pieces' length and the float workspace's."""
    nf = n * n + n + k + 3 * k * n + 3 * k + k
    m = 3 * k
    return nf, (nf + 3 * k + n * n + 2 * (m + 1) * n + (m + 1) + (m + 1) * n
                + 2 * (m * m + 1) + (n + m + 1) + n + 8)


def sizes(n: int, k: int) -> tuple[int, int]:
    """:func:`sizes_of` in Python (no compile)."""
    return sizes_of.py_func(n, k)


def workspace(n: int, k: int):
    """``(W, I)``: the float and integer scratch of :func:`accel` and :func:`watch`."""
    return np.zeros(sizes(n, k)[1]), np.zeros(9 * k + n + 8, dtype=np.int64)


# The hot functions index the workspace at offsets, without slices: a slice is an array
# whose reference count numba raises and lowers (two atomic operations each time), which
# cost more than the arithmetic of a small phase.
#
# Every kernel that allocates no array is compiled without numba's reference counting
# (``_nrt=False``): numba otherwise raises and lowers the count of each array an argument
# holds around the calls between these functions (an atomic operation each, a few
# nanoseconds, and tens of them per call), which made half of what a phase's solve cost
# (the ladder in flight: ``accel`` 248 ns -> 122 ns, eleven DOP853 stages 4.6 us -> 1.5
# us; the same bits).  They only read and write the arrays their caller holds and
# return numbers, never an array, so that no count is needed; numba refuses to compile
# an allocation in them or in a kernel they call (it compiles the callee without the
# counts too).  The kernels that allocate are these:
ALLOCATING = ("sizes_of", "survey_cells", "survey_range", "_rows", "dense_many", "steps_of",
              "transition")


@njit(cache=True, error_model="numpy", _nrt=False)
def _lu(W, o, I, op, m):
    """LU factors, in place, of the ``m x m`` matrix at ``W[o:]`` (row-major), partial
    pivoting, the pivots at ``I[op:]``; its determinant.  The sizes up to 4 run the same
    operations with the size a constant (:func:`_lu_of`), which LLVM unrolls: a phase's
    mass matrix and reaction matrix are this small, and their factors with a size known
    only at run time took most of a flight step's solve (the same bits)."""
    if m == 1:
        return _lu_of(W, o, I, op, 1)
    if m == 2:
        return _lu_of(W, o, I, op, 2)
    if m == 3:
        return _lu_of(W, o, I, op, 3)
    if m == 4:
        return _lu_of(W, o, I, op, 4)
    return _lu_of(W, o, I, op, m)


@njit(cache=True, error_model="numpy", inline="always")
def _lu_of(W, o, I, op, m):
    """:func:`_lu`'s factors (inlined into its branches, each with its own ``m``)."""
    det = 1.0
    for j in range(m):
        p = j
        big = abs(W[o + j * m + j])
        for i in range(j + 1, m):
            if abs(W[o + i * m + j]) > big:
                big = abs(W[o + i * m + j])
                p = i
        I[op + j] = p
        if p != j:
            for c in range(m):
                W[o + j * m + c], W[o + p * m + c] = W[o + p * m + c], W[o + j * m + c]
            det = -det
        d = W[o + j * m + j]
        det *= d
        if d == 0.0:
            continue
        for i in range(j + 1, m):
            f = W[o + i * m + j] / d
            W[o + i * m + j] = f
            for c in range(j + 1, m):
                W[o + i * m + c] -= f * W[o + j * m + c]
    return det


@njit(cache=True, error_model="numpy", _nrt=False)
def _lu_solve(W, o, I, op, m, x):
    """``W[x:x+m]`` <- its solution by :func:`_lu`'s factors at ``W[o:]``, ``I[op:]`` (the
    sizes up to 4 unrolled, as :func:`_lu`)."""
    if m == 1:
        _lu_solve_of(W, o, I, op, 1, x)
    elif m == 2:
        _lu_solve_of(W, o, I, op, 2, x)
    elif m == 3:
        _lu_solve_of(W, o, I, op, 3, x)
    elif m == 4:
        _lu_solve_of(W, o, I, op, 4, x)
    else:
        _lu_solve_of(W, o, I, op, m, x)


@njit(cache=True, error_model="numpy", inline="always")
def _lu_solve_of(W, o, I, op, m, x):
    """:func:`_lu_solve`'s substitutions (inlined into its branches)."""
    for j in range(m):
        p = I[op + j]
        if p != j:
            W[x + j], W[x + p] = W[x + p], W[x + j]
    for i in range(m):
        s = W[x + i]
        for c in range(i):
            s -= W[o + i * m + c] * W[x + c]
        W[x + i] = s
    for i in range(m - 1, -1, -1):
        s = W[x + i]
        for c in range(i + 1, m):
            s -= W[o + i * m + c] * W[x + c]
        W[x + i] = s / W[o + i * m + i]


@njit(cache=True, error_model="numpy", _nrt=False)
def accel(PC, SF, KN, y, t, p, lay, rolls, modes, rho, start, want_det, W, I, ud, N, F, a):
    """The accelerations ``ud``, reactions ``N``, ``F`` and contact accelerations ``a`` (k, 3;
    the tangential relative to the surface) of the phase ``modes`` at ``(t, y)``:
    ``(status, det)``, with ``det`` the normalised determinant of the phase's reaction
    matrix where ``want_det`` and a contact slips with friction (else 1).  ``rho``: the
    sign of N each contact's friction assumes; ``start``: the slips that start from
    relative rest (their static coefficient).  ``REDUNDANT`` where the reaction matrix is
    near singular (the caller picks an admissible member), ``SINGULAR`` where the
    solution is not finite.  The pieces are left at the start of ``W``."""
    st, det = _solve(PC, SF, KN, y, t, p, lay, rolls, modes, rho, start, want_det, W, I, ud,
                     N, F)
    if st == OK:
        _contact_accelerations(W, lay, ud, a)
    return st, det


@njit(cache=True, error_model="numpy", _nrt=False)
def _contact_accelerations(W, lay, ud, a):
    """``a`` (k, 3) <- each contact's accelerations ``J ud + b``, the tangential relative
    to its surface, from the pieces :func:`_solve` left in ``W``."""
    n, k = lay[0], lay[1]
    oJ = n * n + n + k             # J (k, 3, n), b (k, 3), then the static mu
    ob = oJ + 3 * k * n
    osd = ob + 3 * k + k           # the surfaces' speeds (k) and rates (k)
    for c in range(k):
        for r in range(3):
            v = W[ob + 3 * c + r]
            for i in range(n):
                v += W[oJ + (3 * c + r) * n + i] * ud[i]
            a[c, r] = v
        if lay[3]:
            a[c, 1] -= W[osd + k + c]


@njit(cache=True, error_model="numpy", _nrt=False)
def _solve(PC, SF, KN, y, t, p, lay, rolls, modes, rho, start, want_det, W, I, ud, N, F):
    """:func:`accel` but the contact accelerations ``a``: what a stage of a step needs
    (its accelerations ``ud``), without the ``3 k n`` products it does not read."""
    n, k = lay[0], lay[1]
    nf = n * n + n + k + 3 * k * n + 3 * k + k
    _at(PC, W[:nf], y, p, t)
    oh = n * n                     # M at 0, h, g, J (k, 3, n), b (k, 3), mu (static)
    oJ = oh + n + k
    ob = oJ + 3 * k * n
    om0 = ob + 3 * k
    osd = nf                       # the surfaces' speeds (k) and rates (k)
    omu = osd + 2 * k              # the slip coefficients
    mm = 3 * k                     # the most reactions a phase has
    oLU = omu + k
    oG = oLU + n * n               # the reactions' directions (m, n)
    oR = oG + (mm + 1) * n         # the held accelerations' rows (m, n)
    orhs = oR + (mm + 1) * n
    oX = orhs + mm + 1             # M^-1 h, then M^-1 of each direction ((m + 1), n)
    oA = oX + (mm + 1) * n
    oB = oA + mm * mm + 1
    ocol = oB + mm * mm + 1
    otmp = ocol + max(n, mm) + 1
    oc, oj, op = 0, mm + 1, 2 * mm + 2   # owners (contact, row) of each reaction; pivots
    if lay[3]:
        _at(SF, W[osd:osd + 2 * k], y, p, t)
    else:
        for c in range(2 * k):
            W[osd + c] = 0.0
    if lay[4]:
        for c in range(k):
            v = 0.0
            for i in range(n):
                v += W[oJ + (3 * c + 1) * n + i] * y[n + i]
            W[omu + c] = abs(v - W[osd + c])
        _at(KN, W[omu:omu + k], y, p, t)
        for c in range(k):
            if start[c]:
                W[omu + c] = W[om0 + c]
    else:
        for c in range(k):
            W[omu + c] = W[om0 + c]
    m = 0
    slips = False
    for c in range(k):
        md = modes[c]
        if md == OPEN:
            continue
        s = 1.0 if md == SLIP_POS else (-1.0 if md == SLIP_NEG else 0.0)
        mu = W[omu + c]
        if s != 0.0 and mu != 0.0:
            slips = True
        for r in (0, 2, 1):        # the normal, a rolling disc's tangent, a stuck channel
            if r == 1 and md != STICK:
                continue
            if r == 2 and not rolls[c]:
                continue
            for i in range(n):
                jr = W[oJ + (3 * c + r) * n + i]
                W[oR + m * n + i] = jr
                W[oG + m * n + i] = jr - s * rho[c] * mu * W[oJ + (3 * c + 1) * n + i] \
                    if r == 0 else jr
            if r == 1:
                W[orhs + m] = (W[osd + k + c] - W[ob + 3 * c + 1]) if lay[3] \
                    else -W[ob + 3 * c + 1]
            else:
                W[orhs + m] = -W[ob + 3 * c + r]
            I[oc + m] = c
            I[oj + m] = r
            m += 1
    for i in range(n * n):
        W[oLU + i] = W[i]
    _lu(W, oLU, I, op, n)
    for i in range(n):
        W[oX + i] = W[oh + i]
    _lu_solve(W, oLU, I, op, n, oX)
    for j in range(m):
        for i in range(n):
            W[oX + (j + 1) * n + i] = W[oG + j * n + i]
        _lu_solve(W, oLU, I, op, n, oX + (j + 1) * n)
    for c in range(k):
        N[c] = 0.0
        F[c] = 0.0
    det = 1.0
    if m == 0:
        for i in range(n):
            ud[i] = W[oX + i]
    else:
        hadamard = 1.0
        for r in range(m):
            s2 = 0.0
            for j in range(m):
                v = 0.0
                for i in range(n):
                    v += W[oR + r * n + i] * W[oX + (j + 1) * n + i]
                W[oA + r * m + j] = v
                s2 += v * v
            hadamard *= np.sqrt(s2)
            v = 0.0
            for i in range(n):
                v += W[oR + r * n + i] * W[oX + i]
            W[ocol + r] = W[orhs + r] - v
        if want_det and slips:
            # rows and columns at unit length in the inverse mass metric
            for r in range(m):
                for i in range(n):
                    W[otmp + i] = W[oR + r * n + i]
                _lu_solve(W, oLU, I, op, n, otmp)
                dr = 0.0
                for i in range(n):
                    dr += W[oR + r * n + i] * W[otmp + i]
                dr = np.sqrt(max(dr, 1e-300))
                for j in range(m):
                    dc = 0.0
                    for i in range(n):
                        dc += W[oG + j * n + i] * W[oX + (j + 1) * n + i]
                    W[oB + r * m + j] = W[oA + r * m + j] / dr / np.sqrt(max(dc, 1e-300))
            det = _lu(W, oB, I, op, m)
        for i in range(m * m):
            W[oB + i] = W[oA + i]
        dA = _lu(W, oB, I, op, m)
        if not abs(dA) > 1e-12 * hadamard:
            return REDUNDANT, det
        _lu_solve(W, oB, I, op, m, ocol)
        for j in range(m):
            if not np.isfinite(W[ocol + j]):
                return SINGULAR, det
        for i in range(n):
            v = W[oX + i]
            for j in range(m):
                v += W[oX + (j + 1) * n + i] * W[ocol + j]
            ud[i] = v
        for j in range(m):
            if I[oj + j] == 0:
                N[I[oc + j]] = W[ocol + j]
            elif I[oj + j] == 1:
                F[I[oc + j]] = W[ocol + j]
        for c in range(k):
            if modes[c] == SLIP_POS or modes[c] == SLIP_NEG:
                s = 1.0 if modes[c] == SLIP_POS else -1.0
                F[c] = -s * rho[c] * W[omu + c] * N[c]
    return OK, det


@njit(cache=True, error_model="numpy", _nrt=False)
def admits(modes, rho, one_sided, N, F, a, g, vn, vt, mu, sc, prefer):
    """Whether the phase ``modes`` is admissible at a state, from its solution (reactions
    ``N``, ``F``, contact accelerations ``a``, each contact's sign ``rho`` of N), the
    state's gaps ``g``, its contacts' normal and tangential velocities ``vn``, ``vt``
    (the tangential relative to the surface), the static coefficients ``mu`` and the
    scales ``sc`` (velocity, force, acceleration, length): a touching open contact does
    not accelerate into its obstacle, a closed one pushes (or pulls, as ``rho`` says),
    a stuck one within its cone, and a slip that starts from relative rest accelerates its
    way; at the friction limit of a stuck contact (``prefer[c]``, the mode its event points
    to, else -1) it may start from a zero acceleration, the tie with stick decided by the
    next derivative (:meth:`phasemap.motion.hybrid.Motion.enumerate`)."""
    vs, fs, acs, L = sc[0], sc[1], sc[2], sc[3]
    ok = True
    for c in range(modes.size):
        m = modes[c]
        if m == OPEN:
            if g[c] <= TOL * L and vn[c] <= TOL * vs:
                ok = ok and a[c, 0] >= -TOL * acs
            continue
        ok = ok and rho[c] * N[c] >= -TOL * fs
        if m == STICK:
            ok = ok and abs(F[c]) <= mu[c] * rho[c] * N[c] + TOL * fs
        elif (m == SLIP_POS or m == SLIP_NEG) and abs(vt[c]) <= TOL * vs:
            s = 1.0 if m == SLIP_POS else -1.0
            if prefer[c] == m:
                ok = ok and s * a[c, 1] >= -TOL * acs
            else:
                ok = ok and s * a[c, 1] > TOL * acs
    return ok


@njit(cache=True, error_model="numpy", _nrt=False)
def phases(PC, SF, KN, p, lay, one_sided, rolls, y, t, cand, ncand, flip, prefer, plain, sc,
           W, I, ud, N, F, a, modes, rho, start, vn, vt, gk, muk, out_modes, out_rho, out_ud,
           out_N, out_F, out_a):
    """Every admissible phase at ``(t, y)`` among the candidate modes (``cand[c, :ncand[c]]``
    per contact), in :meth:`phasemap.motion.hybrid.Motion.enumerate`'s order (the last
    contact's mode varying fastest), each with the first sign of N of its two-sided
    closed contacts that admits it (+1 first, flipped for those in ``flip``): its
    ``modes``, ``rho``, accelerations and reactions into the ``out_`` rows.  Returns how
    many, or -1 where a phase's contacts are redundant (the caller picks a member of
    their family of reactions: :meth:`phasemap.motion.hybrid.Motion.admissible`), or
    ``-2 - m`` where the ``out_`` rows are fewer than the ``m`` candidate phases (the
    caller grows them to ``m`` and calls again: they are sized by the state's
    candidates, not by the most a system's contacts could have, ``4 ** k``).
    ``vn``, ``vt``: the state's contact velocities (normal, tangential relative to the
    surface: :func:`survey` fills them); ``modes``, ``rho``, ``start``, ``gk``, ``muk``:
    scratch (k,); ``plain``: every slip with one coefficient, at surfaces at rest (no slip
    starts on a static one)."""
    n, k = lay[0], lay[1]
    og = n * n + n
    oJ = og + k
    om0 = oJ + 3 * k * n + 3 * k
    total = 1
    for c in range(k):
        total *= ncand[c]
    if total > out_modes.shape[0]:
        return -2 - total
    count = 0
    for pick in range(total):
        r = pick
        for c in range(k - 1, -1, -1):
            modes[c] = cand[c, r % ncand[c]]
            r //= ncand[c]
        two = 0
        for c in range(k):
            md = modes[c]
            start[c] = (not plain) and (md == SLIP_POS or md == SLIP_NEG) \
                and abs(vt[c]) <= TOL * sc[0]
            if md != OPEN and not one_sided[c]:
                two += 1
        for signs in range(2 ** two):
            bit = two - 1
            for c in range(k):
                rho[c] = 1.0
                if modes[c] != OPEN and not one_sided[c]:
                    s = (signs >> bit) & 1
                    rho[c] = (1.0 - 2.0 * s) * (-1.0 if flip[c] else 1.0)
                    bit -= 1
            st, _ = accel(PC, SF, KN, y, t, p, lay, rolls, modes, rho, start, False, W, I,
                          ud, N, F, a)
            if st == REDUNDANT:
                return -1
            if st != OK:
                continue
            for c in range(k):          # (the pieces accel left: the state's)
                gk[c] = W[og + c]
                muk[c] = W[om0 + c]
            if admits(modes, rho, one_sided, N, F, a, gk, vn, vt, muk, sc, prefer):
                for c in range(k):
                    out_modes[count, c] = modes[c]
                    out_rho[count, c] = rho[c]
                    out_N[count, c] = N[c]
                    out_F[count, c] = F[c]
                    for j in range(3):
                        out_a[count, c, j] = a[c, j]
                for i in range(n):
                    out_ud[count, i] = ud[i]
                count += 1
                break
    return count


@njit(cache=True, error_model="numpy", _nrt=False)
def scales(W, lay, y, S, I, sc):
    """The scales of a state into ``sc``: its contacts' velocities, its forces, its
    accelerations and its lengths, from the pieces at the start of ``W`` and the state
    ``y``.  The free flow's ``M^-1 h`` by :func:`_lu` (``S``: scratch, ``n * n + n``; ``I``:
    the pivots).  What every tolerance of a decision is relative to
    (:meth:`phasemap.motion.hybrid.Motion.scales`)."""
    n, k = lay[0], lay[1]
    oh = n * n
    oJ = oh + n + k
    ob = oJ + 3 * k * n
    for i in range(n * n):
        S[i] = W[i]
    _lu(S, 0, I, 0, n)
    for i in range(n):
        S[n * n + i] = W[oh + i]
    _lu_solve(S, 0, I, 0, n, n * n)
    acc = 0.0
    bmax = 0.0
    vel = 0.0
    for r in range(3 * k):
        v = 0.0
        w = 0.0
        for i in range(n):
            v += W[oJ + r * n + i] * S[n * n + i]
            w += W[oJ + r * n + i] * y[n + i]
        acc = max(acc, abs(v))
        vel = max(vel, abs(w))
        bmax = max(bmax, abs(W[ob + r]))
    acc = acc + bmax if k > 0 else 1.0
    hmax = 0.0
    umax = 0.0
    qmax = 0.0
    for i in range(n):
        hmax = max(hmax, abs(W[oh + i]))
        umax = max(umax, abs(S[n * n + i]))
        qmax = max(qmax, abs(y[i]))
    mmax = 0.0
    for i in range(n * n):
        mmax = max(mmax, abs(W[i]))
    length = 1.0 + qmax
    sc[0] = max(vel, np.sqrt(acc * length), 1e-300)
    sc[1] = max(hmax + mmax * umax, 1e-300)
    sc[2] = max(acc, 1e-300)
    sc[3] = length


@njit(cache=True, error_model="numpy", _nrt=False)
def scales_at(PC, p, lay, y, t, W, S, I, sc):
    """:func:`scales` of the state ``(t, y)``, its pieces evaluated into ``W`` first."""
    n, k = lay[0], lay[1]
    _at(PC, W[:n * n + n + k + 3 * k * n + 3 * k + k], y, p, t)
    scales(W, lay, y, S, I, sc)


@njit(cache=True, error_model="numpy", _nrt=False)
def survey(PC, SF, KN, p, lay, one_sided, rolls, y, t, flip, prefer, plain, W, I, S, sc,
           cand, ncand, ud, N, F, a, modes, rho, start, vn, vt, gk, muk, out_modes, out_rho,
           out_ud, out_N, out_F, out_a, out_group):
    """What a state is: its scales (:func:`scales`, into ``sc``), each contact's candidate
    modes (``cand[c, :ncand[c]]``: a one-sided contact apart or opening, open only; a
    frictionless one smooth; one that slips relative to its surface, that slip; one at
    relative rest, stuck or slipping either way; a touching one-sided contact may also
    open), every admissible phase among them (:func:`phases`, whose count it returns: -1
    for redundant contacts, ``-2 - m`` for too few ``out_`` rows) and their motions (:func:`groups`, into ``out_group``).  The
    one survey of a state that a motion's decisions
    (:meth:`phasemap.motion.hybrid.Motion.survey`) and the maps in full coordinates
    (:func:`survey_cells`) make."""
    n, k = lay[0], lay[1]
    nf = n * n + n + k + 3 * k * n + 3 * k + k
    og = n * n + n
    oJ = og + k
    om0 = oJ + 3 * k * n + 3 * k
    _at(PC, W[:nf], y, p, t)
    if lay[3]:
        _at(SF, W[nf:nf + 2 * k], y, p, t)
    scales(W, lay, y, S, I, sc)
    vs, L = sc[0], sc[3]
    for c in range(k):
        v0 = 0.0
        v1 = 0.0
        for i in range(n):
            v0 += W[oJ + 3 * c * n + i] * y[n + i]
            v1 += W[oJ + (3 * c + 1) * n + i] * y[n + i]
        vn[c] = v0
        vt[c] = v1 - W[nf + c] if lay[3] else v1
        v1 = vt[c]
        if one_sided[c] and (W[og + c] > TOL * L or v0 > TOL * vs):
            cand[c, 0] = OPEN
            ncand[c] = 1
            continue
        j = 0
        if one_sided[c]:
            cand[c, 0] = OPEN
            j = 1
        if W[om0 + c] == 0.0:
            cand[c, j] = SMOOTH
            j += 1
        elif abs(v1) > TOL * vs:
            cand[c, j] = SLIP_POS if v1 > 0.0 else SLIP_NEG
            j += 1
        else:
            cand[c, j] = STICK
            cand[c, j + 1] = SLIP_POS
            cand[c, j + 2] = SLIP_NEG
            j += 3
        ncand[c] = j
    count = phases(PC, SF, KN, p, lay, one_sided, rolls, y, t, cand, ncand, flip, prefer,
                   plain, sc, W, I, ud, N, F, a, modes, rho, start, vn, vt, gk, muk, out_modes,
                   out_rho, out_ud, out_N, out_F, out_a)
    if count >= 0:
        groups(out_ud, count, n, sc[2], out_group)
    return count


#: Where a slipping phase's reaction matrix counts as singular: its determinant, scaled to
#: [-1, 1] (:func:`accel`'s ``det``), at most this (:func:`survey_cells`).
SINGULAR_TOL = 1e-9
#: The bits of :func:`survey_cells`' flags.
STAGNATION, CONTACT_LOST, SINGULAR_PHASE = 1, 2, 4


@njit(cache=True, error_model="numpy", parallel=True)
def survey_cells(PC, SF, KN, P, lay, one_sided, rolls, Y, T, plain, moving, want_singular,
                 rows, out_n, out_flags, out_row):
    """The maps of a system in full coordinates (:mod:`phasemap.maps.full`): at each cell's
    state ``Y[i]``, parameters ``P[i]`` and time ``T[i]``, :func:`survey`'s motions.
    ``out_n[i]``: how many (3 or more as 4), -1 where the contacts are redundant (the
    caller surveys that cell in Python); ``out_flags[i]``: :data:`STAGNATION` (a contact at
    rest relative to its surface, and a motion that keeps every such contact stuck),
    :data:`CONTACT_LOST` (a motion opens a touching contact), :data:`SINGULAR_PHASE` (with
    ``want_singular``: a candidate phase that slips has a singular reaction matrix);
    ``out_row[i]``: the unique motion's accelerations of the coordinates ``moving``, then
    each contact's N and F, of its first phase in the survey's order (NaN unless the
    motion is unique).  ``rows``: the candidate phases a chunk's scratch holds at first
    (grown where a state has more).  Cells in parallel, in chunks
    (:func:`survey_range`, each with its own scratch)."""
    cells = Y.shape[0]
    chunks = min(cells, 256)
    for ch in prange(chunks):
        survey_range(PC, SF, KN, P, lay, one_sided, rolls, Y, T, plain, moving,
                     want_singular, rows, ch * cells // chunks, (ch + 1) * cells // chunks,
                     out_n, out_flags, out_row)


@njit(cache=True, error_model="numpy")
def survey_range(PC, SF, KN, P, lay, one_sided, rolls, Y, T, plain, moving, want_singular,
                 rows, lo, hi, out_n, out_flags, out_row):
    """:func:`survey_cells` of the cells ``lo`` to ``hi``, one after another (what the
    interpreter tier runs while the parallel kernel compiles): the scratch, grown where a
    state has more candidate phases than ``rows``, around :func:`_survey_run`."""
    n, k = lay[0], lay[1]
    if hi <= lo:
        return
    W = np.zeros(sizes_of(n, k)[1])
    I = np.zeros(9 * k + n + 8, dtype=np.int64)
    S = np.zeros(n * n + n)
    sc = np.zeros(4)
    cand = np.zeros((k, 4), dtype=np.int64)
    ncand = np.zeros(k, dtype=np.int64)
    ud = np.zeros(n)
    N = np.zeros(k)
    F = np.zeros(k)
    a = np.zeros((k, 3))
    modes = np.zeros(k, dtype=np.int64)
    rho = np.ones(k)
    start = np.zeros(k, dtype=np.bool_)
    vn = np.zeros(k)
    vt = np.zeros(k)
    gk = np.zeros(k)
    muk = np.zeros(k)
    flip = np.zeros(k, dtype=np.bool_)
    prefer = np.full(k, -1, dtype=np.int64)
    om, orho, oud, oN, oF, oa, og = _rows(rows, n, k)
    i = lo
    while i < hi:
        i, need = _survey_run(PC, SF, KN, P, lay, one_sided, rolls, Y, T, plain, moving,
                              want_singular, i, hi, out_n, out_flags, out_row, W, I, S, sc,
                              cand, ncand, ud, N, F, a, modes, rho, start, vn, vt, gk, muk,
                              flip, prefer, om, orho, oud, oN, oF, oa, og)
        if need > om.shape[0]:       # more candidate phases than rows: grown
            om, orho, oud, oN, oF, oa, og = _rows(need, n, k)


@njit(cache=True, error_model="numpy", _nrt=False)
def _survey_run(PC, SF, KN, P, lay, one_sided, rolls, Y, T, plain, moving, want_singular,
                lo, hi, out_n, out_flags, out_row, W, I, S, sc, cand, ncand, ud, N, F, a,
                modes, rho, start, vn, vt, gk, muk, flip, prefer, om, orho, oud, oN, oF, oa,
                og):
    """The cells ``lo`` to ``hi`` of :func:`survey_range` on its scratch, without numba's
    reference counts: ``(hi, 0)``, or ``(i, rows)`` at the first cell ``i`` whose state
    has more candidate phases than the rows ``om`` hold (its survey then starts again,
    on ``rows`` of them)."""
    k = lay[1]
    for i in range(lo, hi):
        y = Y[i]
        p = P[i]
        t = T[i]
        for j in range(out_row.shape[1]):
            out_row[i, j] = np.nan
        count = survey(PC, SF, KN, p, lay, one_sided, rolls, y, t, flip, prefer, plain,
                       W, I, S, sc, cand, ncand, ud, N, F, a, modes, rho, start, vn,
                       vt, gk, muk, om, orho, oud, oN, oF, oa, og)
        if count <= -2:
            return i, -2 - count
        out_flags[i] = 0
        if count < 0:
            out_n[i] = -1
            continue
        ng = 0
        for j in range(count):
            ng = max(ng, og[j] + 1)
        out_n[i] = ng if ng < 3 else 4
        flags = 0
        rest = False
        for c in range(k):
            rest = rest or _at_rest(cand, ncand, c)
        for j in range(count):
            keeps = True
            for c in range(k):
                if om[j, c] != STICK and _at_rest(cand, ncand, c):
                    keeps = False
                if om[j, c] == OPEN and ncand[c] > 1:
                    flags |= CONTACT_LOST
            if rest and keeps:
                flags |= STAGNATION
        if want_singular and _singular(PC, SF, KN, p, lay, rolls, y, t, cand, ncand, W,
                                       I, ud, N, F, a, modes, rho, start):
            flags |= SINGULAR_PHASE
        out_flags[i] = flags
        if ng == 1:
            for j in range(moving.size):
                out_row[i, j] = oud[0, moving[j]]
            for c in range(k):
                out_row[i, moving.size + 2 * c] = oN[0, c]
                out_row[i, moving.size + 2 * c + 1] = oF[0, c]
    return hi, 0


@njit(cache=True, error_model="numpy")
def _rows(most, n, k):
    """A survey's output rows for ``most`` candidate phases: their modes, signs of N,
    accelerations, N, F, contact accelerations and groups."""
    return (np.zeros((most, k), dtype=np.int64), np.zeros((most, k)), np.zeros((most, n)),
            np.zeros((most, k)), np.zeros((most, k)), np.zeros((most, k, 3)),
            np.zeros(most, dtype=np.int64))


@njit(cache=True, error_model="numpy", _nrt=False)
def _at_rest(cand, ncand, c):
    """Whether contact ``c`` may stick (it is at rest relative to its surface)."""
    for j in range(ncand[c]):
        if cand[c, j] == STICK:
            return True
    return False


@njit(cache=True, error_model="numpy", _nrt=False)
def _singular(PC, SF, KN, p, lay, rolls, y, t, cand, ncand, W, I, ud, N, F, a, modes, rho,
              start):
    """Whether a candidate phase that slips has a singular reaction matrix (its
    :func:`accel` ``det`` within :data:`SINGULAR_TOL` of 0, each N assumed positive)."""
    k = lay[1]
    total = 1
    for c in range(k):
        total *= ncand[c]
        rho[c] = 1.0
        start[c] = False
    for pick in range(total):
        r = pick
        slips = False
        for c in range(k - 1, -1, -1):
            modes[c] = cand[c, r % ncand[c]]
            r //= ncand[c]
            slips = slips or modes[c] == SLIP_POS or modes[c] == SLIP_NEG
        if not slips:
            continue
        _, det = accel(PC, SF, KN, y, t, p, lay, rolls, modes, rho, start, True, W, I, ud, N,
                       F, a)
        if abs(det) <= SINGULAR_TOL:
            return True
    return False


#: Phases whose accelerations agree to this (relative, and of the acceleration scale) move
#: the body alike: one motion (:func:`groups`).
SAME_MOTION = 1e-7


@njit(cache=True, error_model="numpy", _nrt=False)
def groups(out_ud, count, n, acs, out_group):
    """Each of the ``count`` phases' group into ``out_group``: the phases whose
    accelerations agree with a group's first to :data:`SAME_MOTION` (numpy's ``allclose``
    test, relative and of the acceleration scale ``acs``) are one motion (slip with
    N = 0 and open with g'' = 0); the groups in the order of their first phase.  How many
    groups."""
    ng = 0
    for i in range(count):
        out_group[i] = -1
        for j in range(i):
            if out_group[j] == -1 or j != _first(out_group, out_group[j]):
                continue
            same = True
            for r in range(n):
                if not abs(out_ud[j, r] - out_ud[i, r]) <= SAME_MOTION * acs + \
                        SAME_MOTION * abs(out_ud[i, r]):
                    same = False
            if same:
                out_group[i] = out_group[j]
                break
        if out_group[i] == -1:
            out_group[i] = ng
            ng += 1
    return ng


@njit(cache=True, error_model="numpy", _nrt=False)
def _first(out_group, g):
    """The first phase of group ``g``."""
    i = 0
    while out_group[i] != g:
        i += 1
    return i


@njit(cache=True, error_model="numpy", _nrt=False)
def watch(PC, SF, KN, DM, y, t, p, lay, one_sided, rolls, modes, rho, none, jam, bounds,
          W, I, ud, N, F, a, out):
    """The event functions of the phase at ``(t, y)`` into ``out``, each >= 0 while it goes
    on (:meth:`phasemap.motion.hybrid.Motion.watch`; ``none``: k falses); the status of
    :func:`accel`."""
    n, k, nd = lay[0], lay[1], lay[2]
    for i in range(out.size):
        out[i] = 1.0
    st, det = accel(PC, SF, KN, y, t, p, lay, rolls, modes, rho, none, jam != 0.0, W, I,
                    ud, N, F, a)
    if st != OK:
        return st
    if jam != 0.0:
        out[out.size - 1] = jam * det
    og = n * n + n                 # (the pieces accel left: g, J, ..., mu; the surfaces)
    oJ = og + k
    nf = n * n + n + k + 3 * k * n + 3 * k + k
    for c in range(k):
        md = modes[c]
        if md == OPEN:
            if one_sided[c]:
                out[2 * c] = W[og + c]
            continue
        if one_sided[c]:
            out[2 * c] = N[c]
        elif md != SMOOTH:
            out[2 * c] = rho[c] * N[c]
        if md == STICK:
            out[2 * c + 1] = W[nf - k + c] * rho[c] * N[c] - abs(F[c])
        elif md == SLIP_POS or md == SLIP_NEG:
            v = 0.0
            for i in range(n):
                v += W[oJ + (3 * c + 1) * n + i] * y[n + i]
            out[2 * c + 1] = (1.0 if md == SLIP_POS else -1.0) * (v - W[nf + c])
    i0 = 2 * k
    for i in range(n):
        out[i0 + i] = y[i] - bounds[i, 0]
        out[i0 + n + i] = bounds[i, 1] - y[i]
    if nd:
        _at(DM, out[i0 + 2 * n:i0 + 2 * n + nd], y, p, t)
    return OK


@njit(cache=True, error_model="numpy", _nrt=False)
def watch_many(PC, SF, KN, DM, ys, ts, p, lay, one_sided, rolls, modes, rho, none, jam,
               bounds, W, I, ud, N, F, a, out, status):
    """:func:`watch` at each state ``(ts[i], ys[i])`` into ``out[i]``, its status into
    ``status[i]``: a phase's conditions along a sampled segment in one call."""
    for i in range(ts.size):
        status[i] = watch(PC, SF, KN, DM, ys[i], ts[i], p, lay, one_sided, rolls, modes, rho,
                          none, jam, bounds, W, I, ud, N, F, a, out[i])


@njit(cache=True, error_model="numpy", _nrt=False)
def _rhs(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, a, t, y, out):
    """``out`` <- ``y'`` of the phase, and its contact accelerations ``a``; the status of
    :func:`accel`."""
    st = _ydot(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, t, y, out)
    if st == OK:
        _contact_accelerations(W, lay, ud, a)
    return st


@njit(cache=True, error_model="numpy", _nrt=False)
def _ydot(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, t, y, out):
    """:func:`_rhs` without the contact accelerations (:func:`_solve`): a stage's."""
    n = lay[0]
    st, det = _solve(PC, SF, KN, y, t, p, lay, rolls, modes, rho, none, False, W, I, ud, N,
                     F)
    for i in range(n):
        out[i] = y[n + i]
        out[n + i] = ud[i]
    return st


@njit(cache=True, error_model="numpy", _nrt=False)
def _dip_rates(W, a, lay, modes, y, out):
    """Per contact, the rate of the function its mode watches for a dip between steps
    (:func:`_watched`), from what :func:`accel` left in ``W`` and ``a``: an open
    contact's normal velocity ``J_n u`` (its gap's rate), a slipping one's tangential
    acceleration relative to its surface, signed by its slip (its slip velocity's rate);
    0 for the others."""
    n, k = lay[0], lay[1]
    o = n * n + n + k
    for c in range(k):
        out[c] = 0.0
        if modes[c] == OPEN:
            for i in range(n):
                out[c] += W[o + (3 * c) * n + i] * y[n + i]
        elif modes[c] == SLIP_POS or modes[c] == SLIP_NEG:
            out[c] = (1.0 if modes[c] == SLIP_POS else -1.0) * a[c, 1]


@njit(cache=True, inline="always")
def _watched(modes, one_sided, c):
    """The event function of contact ``c`` whose dip below zero and back inside a step
    is checked: an open one-sided gap's, a slip velocity's; -1 for the others."""
    if modes[c] == OPEN:
        return 2 * c if one_sided[c] else -1
    return 2 * c + 1 if modes[c] == SLIP_POS or modes[c] == SLIP_NEG else -1


@njit(cache=True, error_model="numpy", _nrt=False)
def _norm(x, scale):
    s = 0.0
    for i in range(x.size):
        v = x[i] / scale[i]
        s += v * v
    return np.sqrt(s / x.size)


@njit(cache=True, error_model="numpy", _nrt=False)
def dense_at(Fd, t_old, h, y_old, t, out):
    """scipy's DOP853 dense output of a step at ``t`` into ``out``."""
    if h == 0.0:            # (an empty step: scipy's constant dense output)
        for j in range(out.size):
            out[j] = y_old[j]
        return
    x = (t - t_old) / h
    out[:] = 0.0
    for i in range(Fd.shape[0]):
        f = Fd[Fd.shape[0] - 1 - i]
        for j in range(out.size):
            out[j] += f[j]
            out[j] *= x if i % 2 == 0 else 1.0 - x
    for j in range(out.size):
        out[j] += y_old[j]


@njit(cache=True, error_model="numpy", _nrt=False)
def _trial_step(y, f, rtol, atol, interval, yt, y1):
    """scipy's ``select_initial_step`` up to its trial step: ``(h0, d1)``, with ``yt`` the
    scale ``atol + rtol |y|`` and ``y1 = y + h0 f``, where the rate is to be taken next."""
    for i in range(y.size):
        yt[i] = atol + abs(y[i]) * rtol
    d0 = _norm(y, yt)
    d1 = _norm(f, yt)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(y.size):
        y1[i] = y[i] + h0 * f[i]
    return h0, d1


@njit(cache=True, error_model="numpy", _nrt=False)
def _first_step(f, f1, yt, h0, d1, interval, max_step):
    """The rest of ``select_initial_step`` (order 7) from the rate ``f1`` at the trial."""
    d2 = 0.0
    for i in range(f.size):
        v = (f1[i] - f[i]) / yt[i]
        d2 += v * v
    d2 = np.sqrt(d2 / f.size) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, interval, max_step)


@njit(cache=True, error_model="numpy", _nrt=False)
def _error(K, y, y_new, h, rtol, atol):
    """scipy's DOP853 error norm of the step ``y -> y_new`` over ``h`` with the stages
    ``K``: ``|h| ||err5||^2 / sqrt(||err5||^2 + 0.01 ||err3||^2)``, RMS norms over
    ``atol + rtol max(|y|, |y_new|)``."""
    e5 = 0.0
    e3 = 0.0
    for i in range(y.size):
        sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
        v5 = 0.0
        v3 = 0.0
        for j in range(13):
            v5 += K[j, i] * _E5[j]
            v3 += K[j, i] * _E3[j]
        v5 /= sc
        v3 /= sc
        e5 += v5 * v5
        e3 += v3 * v3
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * y.size)


@njit(cache=True, error_model="numpy", _nrt=False)
def _step_factor(err, rejected):
    """scipy's step-size factor after a step of error norm ``err``: accepted (``err < 1``),
    never above 1 after a rejection in the same step; rejected, the shrink."""
    if err < 1.0:
        factor = _MAX_FACTOR if err == 0.0 else min(_MAX_FACTOR, _SAFETY * err ** _EXPONENT)
        return min(1.0, factor) if rejected else factor
    return max(_MIN_FACTOR, _SAFETY * err ** _EXPONENT)


@njit(cache=True, error_model="numpy", _nrt=False)
def _at_times(Fd, t_old, h, y_old, t, te, i_eval, out_t, out_y, saved):
    """Save the step's dense output at the times ``te`` from ``i_eval`` on that it reaches
    (``<= t``; those before ``t_old`` are passed over); ``(i_eval, saved)`` after."""
    while i_eval < te.size and te[i_eval] <= t:
        if te[i_eval] >= t_old:
            dense_at(Fd, t_old, h, y_old, te[i_eval], out_y[saved])
            out_t[saved] = te[i_eval]
            saved += 1
        i_eval += 1
    return i_eval, saved


@njit(cache=True, error_model="numpy", _nrt=False)
def _stages(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, K, t, y, h, first,
            last, yt):
    """The stages ``first`` to ``last - 1`` of scipy's DOP853 from ``(t, y)`` over ``h``
    into the rows of ``K``; the worst status of :func:`accel`."""
    st = OK
    for s in range(first, last):
        for i in range(y.size):
            v = 0.0
            for j in range(s):
                v += K[j, i] * _A[s, j]
            yt[i] = y[i] + v * h
        st = max(st, _ydot(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F,
                           t + _C[s] * h, yt, K[s]))
    return st


@njit(cache=True, error_model="numpy", _nrt=False)
def _dense(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, K, t_old,
           y_old, y, f, h, yt, Fd):
    """The dense output's coefficients ``Fd`` (7, 2n) of the step ``y_old -> y`` (scipy's
    DOP853 ``_dense_output_impl``); the status of the extra stages."""
    ny = y.size
    st = _stages(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, K, t_old,
                 y_old, h, 13, 16, yt)
    for i in range(ny):
        dy = y[i] - y_old[i]
        Fd[0, i] = dy
        Fd[1, i] = h * K[0, i] - dy
        Fd[2, i] = 2.0 * dy - h * (f[i] + K[0, i])
        for r in range(4):
            v = 0.0
            for j in range(16):
                v += _D[r, j] * K[j, i]
            Fd[3 + r, i] = h * v
    return st


@njit(cache=True, error_model="numpy", _nrt=False)
def advance(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, jam, bounds, none,
            state, y, f, y_old, w0, w1, gr0, gr1, K, Fd, te, t_stop, rtol, atol, max_step,
            steps_left, out_t, out_y, W, I, ud, N, F, a, yt, quiet):
    """Steps the phase ``modes`` with scipy's DOP853 from ``state = [t, h_abs, t_old,
    h_prev, i_eval]`` and ``y`` (``f`` its rate; ``h_abs`` <= 0: chosen as scipy does; ``w0``
    the event functions there) until an event function changes sign in a step or a gap's
    rate turns from negative to positive (``EVENT``: the step's dense output in ``Fd``,
    ``w1`` and ``gr1`` at its end), ``t_stop`` (``FINISHED``), a step below scipy's
    smallest (``FAILED``), ``steps_left`` (``MAX_STEPS``) or ``out_t`` full (``FULL``).
    Saves each step's end into ``out_t``, ``out_y``, or the state at the times ``te`` from
    ``state[4]`` on where ``te`` is not empty.  ``quiet``: to ``t_stop`` without watching
    the events or saving (a segment of a periodic orbit).  Returns ``(status, saved,
    steps)``."""
    n = lay[0]
    k = lay[1]
    ny = 2 * n
    t = state[0]
    h_abs = state[1]
    i_eval = int(state[4])
    saved = 0
    steps = 0
    args_ok = OK
    if h_abs <= 0.0:       # scipy's select_initial_step (order 7)
        interval = abs(t_stop - t)
        if interval == 0.0:
            h_abs = 0.0
        else:
            h0, d1 = _trial_step(y, f, rtol, atol, interval, yt, y_old)
            args_ok = _ydot(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F,
                            t + h0, y_old, K[15])
            h_abs = _first_step(f, K[15], yt, h0, d1, interval, max_step)
    if args_ok != OK:
        state[1] = h_abs
        return args_ok, saved, steps
    if t >= t_stop:         # (scipy takes no step where the span is empty)
        return FINISHED, saved, steps
    while True:
        if steps >= steps_left:
            state[0], state[1], state[4] = t, h_abs, i_eval
            return MAX_STEPS, saved, steps
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > max_step:
            ha = max_step
        elif h_abs < min_step:
            ha = min_step
        else:
            ha = h_abs
        rejected = False
        while True:
            if ha < min_step:     # (a failed step counts, as the scipy loop counted it)
                state[0], state[1], state[4] = t, h_abs, i_eval
                return FAILED, saved, steps + 1
            t_new = t + ha
            if t_new - t_stop > 0.0:
                t_new = t_stop
            h = t_new - t
            ha = abs(h)
            for i in range(ny):
                K[0, i] = f[i]
            st = _stages(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, K,
                         t, y, h, 1, 12, yt)
            for i in range(ny):
                v = 0.0
                for j in range(12):
                    v += K[j, i] * _B[j]
                y_old[i] = y[i] + h * v          # (y_new, kept here for now)
            st = max(st, _ydot(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F,
                               t + h, y_old, K[12]))
            if st != OK:
                state[0], state[1], state[4] = t, h_abs, i_eval
                return st, saved, steps
            err = _error(K, y, y_old, h, rtol, atol)
            ha *= _step_factor(err, rejected)
            if err < 1.0:
                break
            rejected = True
        h_abs = ha
        steps += 1
        t_old = t
        for i in range(ny):
            v = y_old[i]
            y_old[i] = y[i]
            y[i] = v
            f[i] = K[12, i]
        t = t_new
        if quiet:       # (a segment of known length: no events; only the times te saved)
            state[0], state[1], state[2], state[3] = t, h_abs, t_old, h
            if te.size > 0 and i_eval < te.size and te[i_eval] <= t:
                st = _dense(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F,
                            K, t_old, y_old, y, f, h, yt, Fd)
                if st != OK:
                    state[4] = i_eval
                    return st, saved, steps
                i_eval, saved = _at_times(Fd, t_old, h, y_old, t, te, i_eval, out_t, out_y,
                                          saved)
                state[4] = i_eval
            if t >= t_stop:
                return FINISHED, saved, steps
            continue
        st = watch(PC, SF, KN, DM, y, t, p, lay, one_sided, rolls, modes, rho, none, jam,
                   bounds, W, I, ud, N, F, a, w1)
        _dip_rates(W, a, lay, modes, y, gr1)
        state[0], state[1], state[2], state[3] = t, h_abs, t_old, h
        if st != OK:
            state[4] = i_eval
            return st, saved, steps
        hit = False
        for i in range(w0.size):
            if w0[i] >= 0.0 and w1[i] < 0.0:
                hit = True
        for c in range(k):
            j = _watched(modes, one_sided, c)
            if j >= 0 and w1[j] >= 0.0 and w0[j] > 0.0 and gr0[c] < 0.0 < gr1[c]:
                hit = True
        dense = hit or (te.size > 0 and i_eval < te.size and te[i_eval] <= t)
        if dense:
            st = _dense(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, K,
                        t_old, y_old, y, f, h, yt, Fd)
            if st != OK:
                state[4] = i_eval
                return st, saved, steps
        if hit:
            state[4] = i_eval
            return EVENT, saved, steps
        if te.size:
            i_eval, saved = _at_times(Fd, t_old, h, y_old, t, te, i_eval, out_t, out_y, saved)
        else:
            out_t[saved] = t
            for i in range(ny):
                out_y[saved, i] = y[i]
            saved += 1
        for i in range(w0.size):
            w0[i] = w1[i]
        for c in range(k):
            gr0[c] = gr1[c]
        state[4] = i_eval
        if t >= t_stop:
            return FINISHED, saved, steps
        if saved + 1 >= out_t.size:
            return FULL, saved, steps


@njit(cache=True, error_model="numpy")
def steps_of(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, bounds, none, t0, y, f,
             t_stop, rtol, atol, W, I, ud, N, F, a, T, TE, Y0, FD):
    """A segment of known length as :func:`advance` steps it quietly (the same steps, so
    the same end in ``y``), with every step's dense output kept: step ``i`` runs from
    ``T[i]`` to ``TE[i]`` from ``Y0[i]``, its coefficients ``FD[i]`` (:func:`_dense`), so
    that its states anywhere are what :func:`advance` gives at given times
    (:func:`dense_many`).  ``(status, steps)``: ``FINISHED``, ``FULL`` where the arrays
    hold too few steps, or :func:`advance`'s failure."""
    ny = y.size
    state = np.array([t0, 0.0, t0, 0.0, 0.0])
    K = np.zeros((16, ny))
    Fd = np.zeros((7, ny))
    y_old = np.empty(ny)
    yt = np.empty(ny)
    none_t = np.empty(0)
    out_t = np.empty(1)
    out_y = np.empty((1, ny))
    nw = 2 * lay[1] + 2 * lay[0] + lay[2] + 1
    w0, w1 = np.zeros(nw), np.zeros(nw)
    g0, g1 = np.zeros(lay[1]), np.zeros(lay[1])
    count = 0
    while True:
        if count >= T.size:
            return FULL, count
        st, _, taken = advance(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, 0.0,
                               bounds, none, state, y, f, y_old, w0, w1, g0, g1, K, Fd,
                               none_t, t_stop, rtol, atol, np.inf, 1, out_t, out_y, W, I,
                               ud, N, F, a, yt, True)
        if st != FINISHED and st != MAX_STEPS:
            return st, count
        if taken == 1:      # the step just taken: its dense output, as advance makes it
            s2 = _dense(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, K,
                        state[2], y_old, y, f, state[3], yt, FD[count])
            if s2 != OK:
                return s2, count
            T[count], TE[count] = state[2], state[0]
            for i in range(ny):
                Y0[count, i] = y_old[i]
            count += 1
        if st == FINISHED:
            return FINISHED, count


@njit(cache=True, error_model="numpy")
def dense_many(T, TE, Y0, FD, count, y_end, times, out):
    """``out[i]`` <- the state at ``times[i]`` on the steps of :func:`steps_of`, each time
    on the first step that ends at it or after (where :func:`advance` saves it); NaN at a
    time outside the steps (a segment of no steps: its state at every time)."""
    for i in range(times.size):
        s = times[i]
        if count == 0:
            out[i, :] = y_end
        elif not T[0] <= s <= TE[count - 1]:
            out[i, :] = np.nan
        else:
            lo, hi = 0, count - 1   # the first step whose end is not before s (a search
            while lo < hi:          # by halves: the interpreted twin has no searchsorted)
                mid = (lo + hi) // 2
                if TE[mid] < s:
                    lo = mid + 1
                else:
                    hi = mid
            dense_at(FD[lo], T[lo], TE[lo] - T[lo], Y0[lo], s, out[i])


@njit(cache=True, error_model="numpy", _nrt=False)
def _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam, bounds,
                 W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, kind, idx, t):
    """At ``t`` in the step (its dense output): the event function ``idx`` (``kind`` 0; its
    value at the step's start for ``t <= t_old``) or the rate of contact ``idx``'s watched
    function (1; :func:`_dip_rates`)."""
    n = lay[0]
    if kind == 0 and t <= t_old:
        return w0[idx]
    dense_at(Fd, t_old, h, y_old, t, yt)
    if kind == 0 or modes[idx] != OPEN:
        st = watch(PC, SF, KN, DM, yt, t, p, lay, one_sided, rolls, modes, rho, none, jam,
                   bounds, W, I, ud, N, F, a, wt)
        if kind == 0:
            return wt[idx]
        return (1.0 if modes[idx] == SLIP_POS else -1.0) * a[idx, 1] if st == OK else np.nan
    nf = n * n + n + lay[1] + 3 * lay[1] * n + 4 * lay[1]
    _at(PC, W[:nf], yt, p, t)
    o = n * n + n + lay[1] + 3 * idx * n
    v = 0.0
    for i in range(n):
        v += W[o + i] * yt[n + i]
    return v


@njit(cache=True, error_model="numpy", _nrt=False)
def _brent(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam, bounds, W, I, ud,
           N, F, a, Fd, t_old, h, y_old, w0, wt, yt, kind, idx, xa, xb, xtol, rtol):
    """scipy's ``brentq`` (its C code, 100 iterations) on :func:`_event_value`."""
    xpre, xcur = xa, xb
    xblk, fblk, spre, scur = 0.0, 0.0, 0.0, 0.0
    fpre = _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                        bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, kind, idx,
                        xpre)
    fcur = _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                        bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, kind, idx,
                        xcur)
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if np.signbit(fpre) == np.signbit(fcur) or np.isnan(fpre) or np.isnan(fcur):
        return np.nan       # (where scipy's brentq raises)
    for _ in range(100):
        if fpre != 0.0 and fcur != 0.0 and np.signbit(fpre) != np.signbit(fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre, scur = scur, stry
            else:
                spre, scur = sbis, sbis
        else:
            spre, scur = sbis, sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        fcur = _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                            bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, kind,
                            idx, xcur)
    return xcur


@njit(cache=True, error_model="numpy", _nrt=False)
def _onto_root(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam, bounds, W, I,
               ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, i, r, t1):
    """The root ``r`` moved, by ulps, to where the function is no longer positive
    (:meth:`phasemap.motion.hybrid.Motion._onto_root`)."""
    for k in range(64):
        v = _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                         bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 0, i, r)
        if v <= 0.0 or r >= t1:
            return min(r, t1)
        r = np.nextafter(r, np.inf) if k < 8 else r + (t1 - r) * 1e-12 * 2.0 ** (k - 8)
    return r


@njit(cache=True, error_model="numpy", _nrt=False)
def locate(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam, bounds, W, I, ud,
           N, F, a, Fd, t_old, t1, h, y_old, w0, w1, wt, yt):
    """``(t, index)`` of the earliest event function to reach zero in the step ``t_old`` to
    ``t1`` (its dense output ``Fd`` from ``y_old``), or ``(nan, -1)``: the machine-code form
    of :meth:`phasemap.motion.hybrid.Motion._first_event` (a gap whose rate turns from
    negative to positive inside the step is checked at its minimum too, and so is a slip
    velocity whose rate does: :func:`_watched`)."""
    k = lay[1]
    eps = np.finfo(np.float64).eps
    xtol = 4.0 * eps * max(abs(t_old), abs(t1), 1e-300)
    best_t, best_i = np.inf, -1
    for i in range(w0.size):
        if not (w0[i] >= 0.0 and w1[i] < 0.0):
            continue
        lo = t_old
        if w0[i] == 0.0:      # starts at zero (a gap just opened): the root after its rise
            for kk in range(1, 60):
                tm = t_old + (t1 - t_old) * 0.5 ** kk
                if tm <= t_old:
                    break
                if _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none,
                                jam, bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt,
                                yt, 0, i, tm) > 0.0:
                    lo = tm
                    break
        r = _brent(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam, bounds, W,
                   I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 0, i, lo, t1, xtol,
                   4.0 * eps)
        if np.isnan(r):   # (the dense output's end is an ulp off the step's end: the end)
            r = t1
        r = _onto_root(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                       bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, i, r, t1)
        if r < best_t:
            best_t, best_i = r, i
    for c in range(k):
        j = _watched(modes, one_sided, c)
        if j < 0 or w1[j] < 0.0 or w0[j] <= 0.0:
            continue     # (a function that starts at zero has just left it: not a dip)
        r0 = _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                          bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 1, c,
                          t_old)
        r1 = _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                          bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 1, c, t1)
        if not r0 < 0.0 < r1:
            continue
        tm = _brent(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam, bounds,
                    W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 1, c, t_old, t1, xtol,
                    4.0 * eps)
        if _event_value(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                        bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 0, j,
                        tm) < 0.0:
            r = _brent(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                       bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, 0, j,
                       t_old, tm, xtol, 4.0 * eps)
            if np.isnan(r):
                continue
            r = _onto_root(PC, SF, KN, DM, p, lay, one_sided, rolls, modes, rho, none, jam,
                           bounds, W, I, ud, N, F, a, Fd, t_old, h, y_old, w0, wt, yt, j,
                           r, tm)
            if r < best_t:
                best_t, best_i = r, j
    if best_i < 0:
        return np.nan, -1
    return best_t, best_i


@njit(cache=True, error_model="numpy", _nrt=False)
def jacobian(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, a, X, step, A, xp,
             xm, up):
    """``A = dF/dX`` of the phase's field ``F(X) = (u, u', 1)`` at ``X = (q, u, t)``: the
    accelerations' central differences, each step ``step (1 + |X_j|)``, exact in floating
    point (:func:`phasemap.motion.periodic.floquet.jacobian`, in one call); the status of
    :func:`accel` (``A`` is valid only where ``OK``)."""
    n = lay[0]
    m = 2 * n + 1
    for r in range(m):
        for j in range(m):
            A[r, j] = 0.0
    for i in range(n):
        A[i, n + i] = 1.0
    for j in range(m):
        h = step * (1.0 + abs(X[j]))
        for i in range(m):
            xp[i] = X[i]
            xm[i] = X[i]
        xp[j] += h
        xm[j] -= h
        st, det = accel(PC, SF, KN, xp[:2 * n], xp[2 * n], p, lay, rolls, modes, rho, none,
                        False, W, I, ud, N, F, a)
        if st != OK:
            return st
        for i in range(n):
            up[i] = ud[i]
        st, det = accel(PC, SF, KN, xm[:2 * n], xm[2 * n], p, lay, rolls, modes, rho, none,
                        False, W, I, ud, N, F, a)
        if st != OK:
            return st
        d = xp[j] - xm[j]
        for i in range(n):
            A[n + i, j] = (up[i] - ud[i]) / d
    return OK


@njit(cache=True, error_model="numpy", _nrt=False)
def _variational_rate(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, a, s, Y,
                      step, A, xp, xm, up, X, out, nc, directional):
    """``out`` <- the rate of the variational system at ``(s, Y)``, ``Y = (X, P)`` with
    ``P`` the m x ``nc`` matrix of directions row by row and ``X``'s time taken as ``s``:
    ``(F(X), A(X) P)``, ``F`` the phase's field and ``A`` its :func:`jacobian`, or, with
    ``directional``, each column ``A d`` by central differences of the accelerations along
    ``d`` itself (two solves a column, not two a coordinate); the status of
    :func:`accel`."""
    n = lay[0]
    m = 2 * n + 1
    for i in range(m):
        X[i] = Y[i]
    X[m - 1] = s
    st, det = accel(PC, SF, KN, X[:2 * n], s, p, lay, rolls, modes, rho, none, False, W, I,
                    ud, N, F, a)
    if st != OK:
        return st
    for i in range(n):
        out[i] = X[n + i]
        out[n + i] = ud[i]
    out[2 * n] = 1.0
    if directional:
        for c in range(nc):
            for i in range(n):          # the positions' rates: the velocities' directions
                out[m + i * nc + c] = Y[m + (n + i) * nc + c]
            out[m + 2 * n * nc + c] = 0.0
            # the longest step along d that moves no coordinate further than
            # :func:`jacobian`'s own step for it, step (1 + |X_i|)
            delta = np.inf
            big, at = 0.0, -1
            for i in range(m):
                d = abs(Y[m + i * nc + c])
                if d > 0.0:
                    delta = min(delta, step * (1.0 + abs(X[i])) / d)
                if d > big:
                    big, at = d, i
            if at < 0:
                for i in range(n):
                    out[m + (n + i) * nc + c] = 0.0
                continue
            for i in range(m):
                xp[i] = X[i] + delta * Y[m + i * nc + c]
                xm[i] = X[i] - delta * Y[m + i * nc + c]
            # the step as taken in floating point, read off d's largest component (exact
            # where d is a coordinate's direction, as :func:`jacobian`'s steps are)
            width = (xp[at] - xm[at]) / Y[m + at * nc + c]
            st, det = accel(PC, SF, KN, xp[:2 * n], xp[2 * n], p, lay, rolls, modes, rho,
                            none, False, W, I, ud, N, F, a)
            if st != OK:
                return st
            for i in range(n):
                up[i] = ud[i]
            st, det = accel(PC, SF, KN, xm[:2 * n], xm[2 * n], p, lay, rolls, modes, rho,
                            none, False, W, I, ud, N, F, a)
            if st != OK:
                return st
            for i in range(n):
                out[m + (n + i) * nc + c] = (up[i] - ud[i]) / width
        return OK
    st = jacobian(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, a, X, step, A,
                  xp, xm, up)
    if st != OK:
        return st
    for r in range(m):
        for c in range(nc):
            v = 0.0
            for j in range(m):
                v += A[r, j] * Y[m + j * nc + c]
            out[m + r * nc + c] = v
    return OK


@njit(cache=True, error_model="numpy")
def transition(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, a, X0, tau, rtol,
               atol, step, max_steps, Phi, P0, directional):
    """``Phi`` <- the transition matrix of the phase over ``tau`` from ``X0 = (q, u, t)``
    applied to the directions ``P0`` (m x c; the identity: the matrix itself):
    the variational equations ``X' = F(X)``, ``P' = A(X) P`` from ``P = P0``
    (:func:`_variational_rate`; ``directional``: ``A P`` by differences along the
    columns), stepped by scipy's DOP853 with its step-size control over the whole system
    (``rtol``, scalar ``atol``), as ``solve_ivp`` stepped them
    (:func:`phasemap.motion.periodic.segments.transition`).  The status of :func:`accel`,
    or ``FAILED`` (a step below scipy's smallest), or ``MAX_STEPS``."""
    n = lay[0]
    m = 2 * n + 1
    nc = P0.shape[1]
    ny = m + m * nc
    Y = np.zeros(ny)
    Yn = np.empty(ny)
    f = np.empty(ny)
    yt = np.empty(ny)
    K = np.empty((13, ny))
    A = np.empty((m, m))
    xp, xm, up, X = np.empty(m), np.empty(m), np.empty(n), np.empty(m)
    for i in range(m):
        Y[i] = X0[i]
        for c in range(nc):
            Y[m + i * nc + c] = P0[i, c]
    t = X0[m - 1]
    t_stop = t + tau
    st = _variational_rate(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F, a, t,
                           Y, step, A, xp, xm, up, X, f, nc, directional)
    if st != OK:
        return st
    interval = abs(t_stop - t)
    h_abs = 0.0
    if interval > 0.0:      # scipy's select_initial_step (order 7)
        h0, d1 = _trial_step(Y, f, rtol, atol, interval, yt, Yn)
        st = _variational_rate(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N, F,
                               a, t + h0, Yn, step, A, xp, xm, up, X, K[12], nc,
                               directional)
        if st != OK:
            return st
        h_abs = _first_step(f, K[12], yt, h0, d1, interval, np.inf)
    steps = 0
    while t < t_stop:
        if steps >= max_steps:
            return MAX_STEPS
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        ha = max(h_abs, min_step)
        rejected = False
        while True:
            if ha < min_step:
                return FAILED
            t_new = min(t + ha, t_stop)
            h = t_new - t
            ha = abs(h)
            for i in range(ny):
                K[0, i] = f[i]
            for s in range(1, 12):
                for i in range(ny):
                    v = 0.0
                    for j in range(s):
                        v += K[j, i] * _A[s, j]
                    yt[i] = Y[i] + v * h
                st = _variational_rate(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud,
                                       N, F, a, t + _C[s] * h, yt, step, A, xp, xm, up, X,
                                       K[s], nc, directional)
                if st != OK:
                    return st
            for i in range(ny):
                v = 0.0
                for j in range(12):
                    v += K[j, i] * _B[j]
                Yn[i] = Y[i] + h * v
            st = _variational_rate(PC, SF, KN, p, lay, rolls, modes, rho, none, W, I, ud, N,
                                   F, a, t + h, Yn, step, A, xp, xm, up, X, K[12], nc,
                                   directional)
            if st != OK:
                return st
            err = _error(K, Y, Yn, h, rtol, atol)
            ha *= _step_factor(err, rejected)
            if err < 1.0:
                break
            rejected = True
        h_abs = ha
        steps += 1
        for i in range(ny):
            Y[i] = Yn[i]
            f[i] = K[12, i]
        t = t_new
    for r in range(m):
        for c in range(nc):
            Phi[r, c] = Y[m + r * nc + c]
    return OK


@njit(cache=True, error_model="numpy", _nrt=False)
def reactions(PC, SF, KN, p, lay, rolls, rho, none, W, I, ud, N, F, a, ts, ys, modes, Ns, Fs,
              status):
    """Per saved state ``i``: the status of :func:`accel` of the phase ``modes[i]`` at
    ``(ts[i], ys[i])`` into ``status[i]`` and, where ``OK``, its reactions into ``Ns[i]``,
    ``Fs[i]`` (the reactions a Dataset of a motion records, in one call)."""
    k = lay[1]
    for i in range(ts.size):
        st, det = accel(PC, SF, KN, ys[i], ts[i], p, lay, rolls, modes[i], rho, none, False,
                        W, I, ud, N, F, a)
        status[i] = st
        if st == OK:
            for c in range(k):
                Ns[i, c] = N[c]
                Fs[i, c] = F[c]



def project_sizes(n, k):
    """``(float scratch, int scratch)`` lengths of :func:`project`: M's LU factors, then
    at most ``m`` constraint rows, their ``M^-1 R^T``, the reduced matrix, two vectors of
    ``m`` and three of ``n``; M's pivots and the constraints' order."""
    m = max(k + n, 3 * k)
    return n * n + 2 * m * n + m * m + 2 * m + 3 * n, n + m


@njit(cache=True, error_model="numpy", _nrt=False)
def _constrained(Z, Iz, n, m, mm, uo, out, full_rank):
    """``Z[out:out + n] <- u - M^-1 R^T lam`` (``u`` at ``Z[uo:]``) with
    ``(R M^-1 R^T) lam = R u - target``: the smallest change of ``u`` in the mass metric
    that puts ``R u`` on the target.  The layout is :func:`project_sizes`' for ``mm``
    rows at most: M's LU factors at ``Z[0:]`` (pivots at ``Iz[0:]``), the ``m`` rows ``R``
    at ``Z[n * n:]``, the targets after the reduced matrix.  The reduced matrix is factored
    by Cholesky with diagonal pivoting; a constraint whose pivot falls below 1e-13 of the
    largest diagonal (redundant, on a consistent target) is left out, as a least-squares
    solve leaves it, unless ``full_rank`` is asked for.  False where the reduced matrix or
    the result is not finite (a singular mass matrix, non-finite pieces) or, with
    ``full_rank``, a constraint is redundant."""
    oR = n * n
    oX = oR + mm * n                # M^-1 R^T, a row per constraint
    oS = oX + mm * n
    orr = oS + mm * mm              # R u - target, then the solution in pivot order
    otg = orr + mm
    op = n                          # the constraints' pivoted order, in Iz
    for j in range(m):
        v = 0.0
        for i in range(n):
            v += Z[oR + j * n + i] * Z[uo + i]
        Z[otg + j] = v - Z[otg + j]
        for i in range(n):
            Z[oX + j * n + i] = Z[oR + j * n + i]
        _lu_solve(Z, 0, Iz, 0, n, oX + j * n)
    big = 0.0
    for r in range(m):
        for j in range(m):
            v = 0.0
            for i in range(n):
                v += Z[oR + r * n + i] * Z[oX + j * n + i]
            if not np.isfinite(v):
                return False
            Z[oS + r * mm + j] = v
        big = max(big, Z[oS + r * mm + r])
        Iz[op + r] = r
    rank = 0
    for j in range(m):              # S = L L^T in place (L[b, a] at S[b, a])
        p, dp = j, Z[oS + Iz[op + j] * mm + Iz[op + j]]
        for i in range(j + 1, m):
            d = Z[oS + Iz[op + i] * mm + Iz[op + i]]
            if d > dp:
                p, dp = i, d
        if not dp > 1e-13 * big:
            if full_rank:
                return False
            break
        Iz[op + j], Iz[op + p] = Iz[op + p], Iz[op + j]
        a = Iz[op + j]
        lj = np.sqrt(dp)
        Z[oS + a * mm + a] = lj
        for i in range(j + 1, m):
            Z[oS + Iz[op + i] * mm + a] /= lj
        for i in range(j + 1, m):   # the Schur complement, both halves
            b = Iz[op + i]
            for l in range(j + 1, m):
                c = Iz[op + l]
                Z[oS + b * mm + c] -= Z[oS + b * mm + a] * Z[oS + c * mm + a]
        rank += 1
    for j in range(rank):           # L y = R u - target, then L^T lam = y
        a = Iz[op + j]
        v = Z[otg + a]
        for l in range(j):
            v -= Z[oS + a * mm + Iz[op + l]] * Z[orr + l]
        Z[orr + j] = v / Z[oS + a * mm + a]
    for j in range(rank - 1, -1, -1):
        a = Iz[op + j]
        v = Z[orr + j]
        for l in range(j + 1, rank):
            v -= Z[oS + Iz[op + l] * mm + a] * Z[orr + l]
        Z[orr + j] = v / Z[oS + a * mm + a]
    ok = True
    for i in range(n):
        v = Z[uo + i]
        for j in range(rank):
            v -= Z[oX + Iz[op + j] * n + i] * Z[orr + j]
        Z[out + i] = v
        ok = ok and np.isfinite(v)
    return ok


@njit(cache=True, error_model="numpy", _nrt=False)
def project_many(PC, SF, p, lay, rolls, ys, ts, closed, moving, held, fixed, W, Z, Iz, out,
                 status):
    """:func:`project` of each state ``(ts[i], ys[i])`` into ``out[i]``, its status into
    ``status[i]``: the projections a difference quotient takes, in one call."""
    for i in range(ts.size):
        status[i] = project(PC, SF, p, lay, rolls, ys[i], ts[i], closed, moving, held, fixed,
                            W, Z, Iz, out[i])


@njit(cache=True, error_model="numpy", _nrt=False)
def project(PC, SF, p, lay, rolls, y, t, closed, moving, held, fixed, W, Z, Iz, out):
    """The state ``y`` put on the contacts ``closed`` (a boolean per contact) in the mass
    metric, into ``out``: the positions on their gaps' zero (Newton, at most 20 steps;
    ``fixed``, a boolean per coordinate: held where it is), then the velocities on
    ``J_n u = 0`` for the contacts ``moving`` (and a rolling disc's ``J_r u = 0``) and
    ``J_t u`` on the surface's velocity for those ``held``, each the smallest change in
    kinetic-energy norm (:meth:`phasemap.motion.hybrid.Motion.project`).  With no contact
    closed the positions are left as they are; with none moving or held, the velocities.  The
    pieces are evaluated into ``W``; ``Z``, ``Iz``: :func:`project_sizes`' scratch.
    Returns ``OK``, or ``SINGULAR`` where a solve has no finite result (a singular mass
    matrix, non-finite pieces or state) or the gaps cannot close (a Newton step's rows
    dependent: a fixed coordinate that moves a closed gap alone), as NumPy's ``solve``
    refused the step before.  The velocities are a least-squares projection: redundant
    rows are left out."""
    n, k = lay[0], lay[1]
    nf = n * n + n + k + 3 * k * n + 3 * k + k
    og, oJ = n * n + n, n * n + n + k
    mm = max(k + n, 3 * k)
    oR = n * n
    otg = oR + 2 * mm * n + mm * mm + mm
    ou = otg + mm                   # a velocity (n), the result (n), q before (n)
    oo = ou + n
    oq = oo + n
    for i in range(2 * n):
        out[i] = y[i]
        if not np.isfinite(y[i]):
            return SINGULAR
    any_closed = False
    for c in range(k):
        any_closed = any_closed or closed[c]
    for i in range(n):
        Z[oq + i] = y[i]
    for _ in range(20 if any_closed else 0):
        _at(PC, W[:nf], out, p, t)
        worst, qmax = 0.0, 0.0
        for c in range(k):
            if closed[c] and not abs(W[og + c]) <= worst:     # (a NaN gap stays NaN)
                worst = abs(W[og + c])
        for i in range(n):
            if not abs(out[i]) <= qmax:
                qmax = abs(out[i])
        if worst <= 4e-16 * (1.0 + qmax):
            break
        # the Newton step X (G X)^-1 g: the constrained change of a zero velocity that
        # puts G on -g, subtracted from q
        m = 0
        for c in range(k):
            if closed[c]:
                for i in range(n):
                    Z[oR + m * n + i] = W[oJ + 3 * c * n + i]
                Z[otg + m] = -W[og + c]
                m += 1
        for j in range(n):
            if fixed[j]:
                for i in range(n):
                    Z[oR + m * n + i] = 1.0 if i == j else 0.0
                Z[otg + m] = 0.0
                m += 1
        for i in range(n * n):
            Z[i] = W[i]
        _lu(Z, 0, Iz, 0, n)
        for i in range(n):
            Z[ou + i] = 0.0
        if not _constrained(Z, Iz, n, m, mm, ou, oo, True):
            return SINGULAR
        for i in range(n):
            out[i] = Z[oq + i] if fixed[i] else out[i] + Z[oo + i]
    any_moving = False
    for c in range(k):
        any_moving = any_moving or moving[c] or held[c]
    if not any_moving:
        return OK
    _at(PC, W[:nf], out, p, t)
    if lay[3]:
        _at(SF, W[nf:nf + 2 * k], out, p, t)
    m = 0
    for r in (0, 2, 1):             # the normals, rolling discs' tangents, held slips
        for c in range(k):
            if (held[c] if r == 1 else moving[c]) and (r != 2 or rolls[c]):
                for i in range(n):
                    Z[oR + m * n + i] = W[oJ + (3 * c + r) * n + i]
                Z[otg + m] = W[nf + c] if r == 1 and lay[3] else 0.0
                m += 1
    for i in range(n * n):
        Z[i] = W[i]
    _lu(Z, 0, Iz, 0, n)
    for i in range(n):
        Z[ou + i] = out[n + i]
    if not _constrained(Z, Iz, n, m, mm, ou, oo, False):
        return SINGULAR
    for i in range(n):
        out[n + i] = Z[oo + i]
    return OK
