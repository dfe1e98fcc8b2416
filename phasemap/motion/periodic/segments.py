"""One segment of a periodic orbit: a phase of fixed contact modes over a known time, from
a known start, as the orbits integrate it: its end, its states at given times and its
transition matrix (the variational equations), on the compiled flow
(:mod:`phasemap.motion.hybrid.flow`), and on ``solve_ivp`` where the kernel cannot (a
phase whose contacts are redundant, or without a finite solution) and for its errors."""

from __future__ import annotations

import numpy as np

from phasemap.motion.hybrid import MODE_NAMES
from phasemap.motion.periodic import floquet as fq


def flow(motion, z, t, tau, seg, rtol, dense=False):
    """The segment on ``solve_ivp`` (DOP853, ``rtol``, ``atol = rtol (1 + max |z|)``), its
    dense output with ``dense``; a one-line ValueError where its phase has no
    accelerations or the integration fails."""
    from scipy.integrate import solve_ivp

    n = motion.n

    def f(s, y):
        sol = motion.solve(y[:n], y[n:], seg.modes, seg.rho, s)
        if sol is None:
            raise ValueError(f"{motion.mech.name}: the phase {modes_text(motion, seg)} has "
                             f"no accelerations at t = {s:.6g} (its linear system is "
                             "singular there)")
        return np.concatenate([y[n:], sol[0]])

    scale = 1.0 + float(np.max(np.abs(z)))
    sol = solve_ivp(f, (t, t + tau), z, method="DOP853", rtol=rtol, atol=rtol * scale,
                    dense_output=dense)
    if not sol.success:
        raise ValueError(f"{motion.mech.name}: a segment ({modes_text(motion, seg)}) could "
                         f"not be integrated from t = {t:.6g}: {sol.message}")
    return sol


def end(motion, z, t, tau, seg, rtol):
    """The end of :func:`flow`'s integration, on the compiled flow (scipy's DOP853 in
    machine code); on ``solve_ivp`` where the kernel cannot (and for its errors)."""
    scale = 1.0 + float(np.max(np.abs(z)))
    got = motion.flow.segment(z, t, tau, seg.modes, seg.rho, rtol, rtol * scale)
    return got if got is not None else flow(motion, z, t, tau, seg, rtol).y[:, -1]


def samples(motion, z, t, tau, seg, rtol, times):
    """``(end, states)``: :func:`end` and the states at ``times`` on the steps'
    dense output, on the compiled flow; on ``solve_ivp`` where the kernel cannot."""
    scale = 1.0 + float(np.max(np.abs(z)))
    got = motion.flow.segment(z, t, tau, seg.modes, seg.rho, rtol, rtol * scale, times=times)
    if got is not None:
        return got
    sol = flow(motion, z, t, tau, seg, rtol, dense=True)
    return sol.y[:, -1], np.array([sol.sol(s) for s in times])


def at(motion, z, t, tau, seg, rtol, s):
    """The state at the time ``s`` of the segment of length ``tau`` that starts at
    ``(t, z)``, on the dense output of the segment's own steps (a point a search asks for
    between the samples): at a sample's time, the sample's own bits, so that a search
    bracketed by the samples sees the signs they had."""
    return samples(motion, z, t, tau, seg, rtol, np.array([float(s)]))[1][0]


def steps(motion, z, t, tau, seg, rtol):
    """The segment's steps with their dense output, kept (an object with ``end`` and
    ``at(times)``, the bits :func:`end` and :func:`samples` give): on the compiled flow
    (:meth:`phasemap.motion.hybrid.binding.Phase.steps`); on ``solve_ivp`` where the
    kernel cannot."""
    scale = 1.0 + float(np.max(np.abs(z)))
    got = motion.flow.steps(z, t, tau, seg.modes, seg.rho, rtol, rtol * scale)
    return got if got is not None else _Solved(flow(motion, z, t, tau, seg, rtol, dense=True))


class _Solved:
    """:func:`steps` on ``solve_ivp``'s dense output."""

    def __init__(self, sol):
        self.sol, self.end = sol, sol.y[:, -1]

    def at(self, times):
        return np.array([self.sol.sol(s) for s in np.atleast_1d(times)])


class Traced:
    """The segments of the orbit ``w`` (``segs`` from ``t_a``), each integrated once, when
    first asked for, with its dense output kept (:func:`steps`): what the checks of one
    orbit share (its ends, its samples, the states a search asks for between them), in
    the bits :func:`end`, :func:`samples` and :func:`at` give."""

    def __init__(self, motion, segs, w, t_a, rtol):
        n2 = 2 * motion.n
        K = len(segs)
        self.motion, self.segs, self.rtol = motion, segs, rtol
        self.zs = [w[j * n2:(j + 1) * n2] for j in range(K)]
        self.taus = w[K * n2:]
        self.starts, t = [], t_a
        for tau in self.taus:       # (summed in turn, as the checks step through them)
            self.starts.append(t)
            t = t + tau
        self._steps = [None] * K

    def steps(self, j):
        if self._steps[j] is None:
            self._steps[j] = steps(self.motion, self.zs[j], float(self.starts[j]),
                                   self.taus[j], self.segs[j], self.rtol)
        return self._steps[j]

    def end(self, j):
        return self.steps(j).end

    def samples(self, j, times):
        """``(end, states)`` as :func:`samples` gives them."""
        got = self.steps(j)
        return got.end, got.at(times)

    def at(self, j, s):
        return self.steps(j).at(np.array([float(s)]))[0]


def modes_text(motion, seg) -> str:
    return ", ".join(f"{c.name} {MODE_NAMES[m]}" for c, m in zip(motion.mech.contacts,
                                                                  seg.modes))


def transition(motion, X0, tau, seg, rtol, directions=None):
    """``Phi``, the variational equations' solution over the segment, or with
    ``directions`` (m x c) ``Phi @ directions`` from the variational equations of those
    directions alone: on the compiled flow
    (:func:`phasemap.motion.hybrid.flow.transition`), else on ``solve_ivp`` as it steps them
    (where the kernel cannot: redundant contacts, no finite solution; and for its
    errors)."""
    tol = max(rtol, 1e-11)
    Phi = motion.flow.transition(X0, tau, seg.modes, seg.rho, tol,
                                 tol * (1.0 + float(np.max(np.abs(X0)))),
                                 fq.STEP if directions is None else fq.DIRECTIONAL_STEP,
                                 directions=directions)
    if Phi is not None:
        return Phi
    Phi = _solved_transition(motion, X0, tau, seg, rtol)
    return Phi if directions is None else Phi @ directions


def _solved_transition(motion, X0, tau, seg, rtol):
    """:func:`transition`'s matrix on ``solve_ivp``."""
    from scipy.integrate import solve_ivp

    m = X0.size

    def f(s, Y):
        X = Y[:m]
        X = X.copy()
        X[-1] = s
        P = Y[m:].reshape(m, m)
        A = fq.jacobian(motion, X, seg.modes, seg.rho)
        return np.concatenate([fq.field(motion, X, seg.modes, seg.rho), (A @ P).ravel()])

    Y0 = np.concatenate([X0, np.eye(m).ravel()])
    scale = 1.0 + float(np.max(np.abs(X0)))
    sol = solve_ivp(f, (X0[-1], X0[-1] + tau), Y0, method="DOP853", rtol=max(rtol, 1e-11),
                    atol=max(rtol, 1e-11) * scale)
    return sol.y[m:, -1].reshape(m, m)
