"""A declaration's compiled flow (:mod:`.flow`) bound to its parameters:
its functions compiled and the addresses of their machine code, the workspace, and the
choice between the machine code and its interpreted twins (:mod:`phasemap.core.tiers`)."""

from __future__ import annotations

import hashlib
import threading

import numpy as np
from numba import njit

from phasemap.core import tiers
from phasemap.motion.hybrid.flow import (FINISHED, FULL, FUNCTION, OK, _dip_rates, _rhs,
                                         _rows, accel, admits, advance, dense_at, dense_many,
                                         groups, jacobian, locate, project, project_many,
                                         project_sizes, reactions, scales, scales_at,
                                         sizes, steps_of, survey, survey_cells, survey_range,
                                         transition, watch, watch_many, workspace)

_LOCK = threading.Lock()
_FUNCTIONS: dict = {}


def preferences(k: int, prefer) -> np.ndarray:
    """``prefer`` (``{contact: mode}``, or None) as :func:`flow.admits` takes it: per
    contact the mode its event points to, -1 where none."""
    out = np.full(k, -1, dtype=np.int64)
    for c, m in (prefer or {}).items():
        out[c] = m
    return out


def functions(mech, twin: bool):
    """The declaration's rewritten functions (:mod:`phasemap.motion.hybrid.flowtext`) as
    the kernels take them, in the order of :data:`phasemap.motion.hybrid.flowtext.NAMES`:
    the addresses of their machine code (compiled, or loaded from the cache), or, for the
    kernels' interpreted twins (``twin``), handles of their own twins
    (:func:`phasemap.core.tiers.handle`)."""
    from phasemap.core.cache import load_module
    from phasemap.motion.hybrid import flowtext

    key = (mech.source, twin)
    with _LOCK:
        if key in _FUNCTIONS:
            return _FUNCTIONS[key][0]
        with open(mech.source, encoding="utf-8") as fh:
            text = flowtext.text(fh.read(), mech.n, len(mech.contacts), len(mech.parameters))
        digest = hashlib.sha256(f"{flowtext.LAYOUT}\n{text}".encode()).hexdigest()[:16]
        module = load_module(f"flow_declared_{digest}", lambda: text)
        jitted = [njit(cache=True, error_model="numpy")(getattr(module, name))
                  for name in flowtext.NAMES]
        made = tuple(tiers.handle(fn) if twin else tiers.addressed(fn, FUNCTION.args)
                     for fn in jitted)
        # (the dispatchers held beside their addresses: their machine code lives as long)
        _FUNCTIONS[key] = made, jitted
        return made


#: How many steps' ends one :func:`advance` call saves at most (it returns ``FULL``).
BUFFER = 4096


class Phase:
    """A declaration's compiled flow at its parameters: what a
    :class:`phasemap.motion.hybrid.Motion` calls for a phase's accelerations, its event
    functions and its steps (machine code, or the interpreted twins while numba compiles;
    :mod:`phasemap.core.tiers`).  ``warm``: the picklable call that compiles the kernels
    in a background process."""

    def __init__(self, mech, p, one_sided, rolls, warm=None):
        n, k = mech.n, len(mech.contacts)
        self.n, self.k = n, k
        self.p = np.ascontiguousarray(p, dtype=float)
        self.lay = np.array([n, k, mech.n_domain, mech._surface is not None,
                             mech._kinetic is not None], dtype=np.int64)
        self.one_sided = np.ascontiguousarray(one_sided, dtype=np.bool_)
        self.rolls = np.ascontiguousarray(rolls, dtype=np.bool_)
        self.bounds = np.ascontiguousarray(mech.bounds(self.p), dtype=float)
        self.W, self.I = workspace(n, k)
        nz, nI = project_sizes(n, k)
        self.Z, self.Iz = np.zeros(nz), np.zeros(nI, dtype=np.int64)
        self.S = np.zeros(n * n + n)
        #: the candidate phases a survey's outputs hold at first: grown where a state has
        #: more (the most, 4 ** k, would take 0.5 GB for ten contacts)
        self.rows = 16
        self.none = np.zeros(k, dtype=np.bool_)
        self._n_pieces = sizes(n, k)[0]
        #: every contact's friction as a pressing contact's (rho = +1; the kernels read it)
        self.pressing = np.ones(k)
        #: no contact's mode preferred (:func:`preferences` of none)
        self.no_preference = preferences(k, None)
        #: :meth:`survey`'s candidates (k, 4), their counts, the contacts whose sign of N
        #: it tries -1 first, the scales, and the kernel's per-contact scratch
        self._survey_scratch = (np.zeros((k, 4), dtype=np.int64), np.zeros(k, dtype=np.int64),
                                np.zeros(k, dtype=np.bool_), np.zeros(4), self._scratch())
        self.ud, self.N, self.F = np.zeros(n), np.zeros(k), np.zeros(k)
        self.a = np.zeros((k, 3))
        self.n_watch = 2 * k + 2 * n + mech.n_domain + 1
        self._buffers = None
        self.mech, self.warm = mech, warm
        self.twin = True
        self._tiers()

    def _tiers(self):
        """Machine code where it is compiled (or ``$PHASEMAP_JIT`` is ``eager``); else the
        interpreted twins, while a background process compiles it."""
        from phasemap.core import tiers
        from phasemap.core.interpret import interpreted

        twin = tiers.mode() == "off"
        if not twin:
            fns = functions(self.mech, False)
        if not twin and not transition.overloads:   # (not yet in this process: the cache?)
            # the kernel the background compile (engine.warm) builds last: where it is in
            # the cache, so are the others, and no call compiles one in the foreground
            m = 2 * self.n + 1
            probe = (*fns[:3], self.p, self.lay, self.rolls, np.zeros(self.k, dtype=np.int64),
                     np.ones(self.k), self.none, self.W, self.I, self.ud, self.N, self.F,
                     self.a, np.zeros(m), 0.0, 1e-8, 1e-8, 1e-6, 1, np.zeros((m, m)),
                     np.eye(m), False)
            twin = tiers.is_twin(tiers.runner(transition, probe, self.warm))
        kernels = (accel, watch, advance, _rhs, _dip_rates, locate, dense_at, jacobian,
                   transition, reactions, survey, admits, scales, groups, survey_range,
                   project, scales_at, steps_of, dense_many, watch_many, project_many)
        if twin:
            fns = functions(self.mech, True)
            kernels = tuple(interpreted(k) for k in kernels)
        (self.accel, self.watch_fn, self.advance_fn, self.rhs_fn, self.rates_fn,
         self.locate_fn, self.dense_fn, self.jacobian_fn, self.transition_fn,
         self.reactions_fn, self.survey_fn, self.admits, self.scales_fn,
         self.groups, self.range_fn, self.project_fn, self.scales_at_fn, self.steps_fn,
         self.dense_many_fn, self.watch_many_fn, self.project_many_fn) = kernels
        self.twin, self.fns = twin, fns

    def refresh(self):
        """Machine code from now on where its background compile has ended (the twins give
        the same bits: a motion may change tiers between its phases)."""
        if self.twin:
            self._tiers()

    def buffers(self, cap: int):
        """The arrays :func:`phasemap.motion.hybrid.stepping.phase` steps in (``cap`` saved
        states at least), made once and kept between phases:
        ``(out_t, out_y, y_old, w1, yt, K, Fd, gr0, gr1, state, w0, f)``."""
        kept = self._buffers
        if kept is None or kept[0].size < cap:
            ny, n_watch = 2 * self.n, self.n_watch
            kept = self._buffers = (np.empty(cap), np.empty((cap, ny)), np.empty(ny),
                                    np.empty(n_watch), np.empty(ny), np.zeros((16, ny)),
                                    np.zeros((7, ny)), np.empty(self.k), np.empty(self.k),
                                    np.empty(5), np.empty(n_watch), np.empty(ny))
        return kept

    def solve(self, y, t, modes, rho, start, want_det):
        """``(status, det)`` of :func:`accel`; the results in ``ud``, ``N``, ``F``, ``a`` and
        the pieces in :meth:`pieces`."""
        PC, SF, KN, _ = self.fns
        return self.accel(PC, SF, KN, y, float(t), self.p, self.lay, self.rolls, modes, rho,
                          start, want_det, self.W, self.I, self.ud, self.N, self.F, self.a)

    def survey(self, y, t, flip, prefer, plain):
        """``(sc, candidates, found)`` at ``(t, y)`` (:func:`flow.survey`): the scales, per
        contact the modes it may take, and every admissible phase among them in
        :meth:`phasemap.motion.hybrid.Motion.enumerate`'s order, a list of
        ``(modes, (ud, N, F, a, rho), group)`` (phases of one group move the body alike:
        :func:`flow.groups`), or None where a phase's contacts are redundant.
        ``flip``: the contacts whose sign of N is tried -1 first; ``prefer``:
        ``{contact: mode}``."""
        n, k = self.n, self.k
        # (the kernel's inputs and scratch, kept between calls: what it returns is read
        # out of them below, and the phases' rows are new arrays each call)
        cand, ncand, flips, sc, scratch = self._survey_scratch
        flips[:] = False
        for c in flip:
            flips[c] = True
        PC, SF, KN, _ = self.fns
        most = self.rows
        while True:     # rows for the state's candidate phases (flow.survey says how many)
            *out, group = _rows.py_func(most, n, k)
            count = self.survey_fn(PC, SF, KN, self.p, self.lay, self.one_sided, self.rolls,
                                   y, float(t), flips,
                                   preferences(k, prefer) if prefer else self.no_preference,
                                   bool(plain), self.W, self.I, self.S, sc, cand, ncand,
                                   self.ud, self.N, self.F, self.a, *scratch, *out, group)
            if count > -2:
                break
            most = -2 - count
        rows, lengths = cand.tolist(), ncand.tolist()
        candidates = [tuple(rows[c][:lengths[c]]) for c in range(k)]
        scales = tuple(sc.tolist())
        if count < 0:
            return scales, candidates, None
        modes, rho, ud, N, F, a = out
        return (scales, candidates,
                [(tuple(m), (ud[i], N[i], F[i], a[i], rho[i]), g) for i, (m, g) in
                 enumerate(zip(modes[:count].tolist(), group[:count].tolist()))])

    def project(self, y, t, closed, moving, held, fixed):
        """:func:`project` of the state ``y`` at ``t`` (the contacts and coordinates as
        boolean arrays): the projected state, or None where a solve has no finite
        result."""
        PC, SF, _, _ = self.fns
        out = np.empty(2 * self.n)
        st = self.project_fn(PC, SF, self.p, self.lay, self.rolls, y, float(t), closed,
                             moving, held, fixed, self.W, self.Z, self.Iz, out)
        return out if st == OK else None

    def project_many(self, ys, ts, closed, moving, held, fixed):
        """:func:`project_many`: the projected states, a row each, or None where one has no
        finite result."""
        PC, SF, _, _ = self.fns
        ts = np.ascontiguousarray(ts, dtype=float)
        out = np.empty((ts.size, 2 * self.n))
        status = np.empty(ts.size, dtype=np.int64)
        self.project_many_fn(PC, SF, self.p, self.lay, self.rolls,
                             np.ascontiguousarray(ys, dtype=float), ts, closed, moving, held,
                             fixed, self.W, self.Z, self.Iz, out, status)
        return out if np.all(status == OK) else None

    def cells(self, P, Y, T, moving, want_singular):
        """:func:`flow.survey_cells` of the cells ``(P[i], Y[i], T[i])`` (parameters, full
        state, time): ``(n, flags, rows)``."""
        cells = Y.shape[0]
        n_out = np.zeros(cells, dtype=np.int8)
        flags = np.zeros(cells, dtype=np.int8)
        rows = np.zeros((cells, len(moving) + 2 * self.k))
        PC, SF, KN, _ = self.fns
        # (writable: the kernel passes rows of them to the declaration's functions, typed for
        # writable arrays)
        args = (PC, SF, KN, np.require(P, float, ("C", "W")), self.lay, self.one_sided,
                self.rolls, np.require(Y, float, ("C", "W")), np.require(T, float, ("C", "W")),
                bool(self.mech.plain), np.asarray(moving, dtype=np.int64), bool(want_singular))
        if self.twin:       # the parallel kernel has no twin: its cells one after another
            self.range_fn(*args, self.rows, 0, cells, n_out, flags, rows)
        else:
            survey_cells(*args, self.rows, n_out, flags, rows)
        return n_out, flags, rows

    def _scratch(self):
        """The per-contact scratch of :func:`flow.survey`."""
        k = self.k
        return (np.zeros(k, dtype=np.int64), np.zeros(k), np.zeros(k, dtype=np.bool_),
                np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k))

    def scales(self, P, y):
        """:func:`flow.scales` of the pieces ``P`` (``(M, h, g, J, b, mu)``) at the state
        ``y``: ``(velocity, force, acceleration, length)``."""
        base = getattr(P[0], "base", None)
        if base is not None and base.size == self._n_pieces and all(
                getattr(x, "base", None) is base for x in P):
            flat = base     # (the views of one array :meth:`Mechanics.pieces` makes)
        else:
            flat = np.concatenate([np.ravel(x) for x in P])
        sc = np.zeros(4)
        self.scales_fn(flat, self.lay, y, self.S, self.I, sc)
        return tuple(float(x) for x in sc)

    def scales_at(self, y, t):
        """:func:`flow.scales_at`: the scales of the state ``y`` at ``t``, its pieces the
        declaration's machine code's (the numbers :meth:`survey` finds)."""
        sc = np.zeros(4)
        self.scales_at_fn(self.fns[0], self.p, self.lay, y, float(t), self.W, self.S, self.I,
                          sc)
        return tuple(float(x) for x in sc)

    def pieces(self):
        """``(M, h, g, J, b, mu)`` the last call left in the workspace (copies)."""
        n, k = self.n, self.k
        W = self.W
        o = n * n
        M = W[:o].reshape(n, n).copy()
        h = W[o:o + n].copy()
        o += n
        g = W[o:o + k].copy()
        o += k
        J = W[o:o + 3 * k * n].reshape(k, 3, n).copy()
        o += 3 * k * n
        b = W[o:o + 3 * k].reshape(k, 3).copy()
        o += 3 * k
        return M, h, g, J, b, W[o:o + k].copy()

    def rate(self, y, t, modes, rho, out):
        """``out`` <- the phase's ``y'`` (:func:`_rhs`); its status."""
        PC, SF, KN, _ = self.fns
        rhs = self.rhs_fn
        return rhs(PC, SF, KN, self.p, self.lay, self.rolls, modes, rho, self.none, self.W,
                   self.I, self.ud, self.N, self.F, self.a, float(t), y, out)

    def _phase(self, modes, rho):
        """``(modes, rho)`` as the kernels take them: int64 modes, and each contact's sign of
        N (all +1 where ``rho`` is None)."""
        return (np.asarray(modes, dtype=np.int64),
                np.ones(self.k) if rho is None else np.asarray(rho, dtype=float))

    def segment(self, z, t, tau, modes, rho, rtol, atol, times=None):
        """The state ``tau`` after ``(t, z)`` in the phase ``modes``, stepped as scipy's
        ``solve_ivp(method="DOP853")`` steps it (its rtol floor of 100 ulps included), no
        event watched; with ``times`` (increasing, in ``[t, t + tau]``), ``(end, states)``
        with the states at those times on the steps' dense output, as ``solve_ivp``'s
        ``dense_output`` gives them.  None where the kernel cannot (redundant contacts, no
        finite solution, a step below scipy's smallest)."""
        self.refresh()
        n2 = 2 * self.n
        y = np.array(z, dtype=float)
        te = np.empty(0) if times is None else np.ascontiguousarray(times, dtype=float)
        if tau == 0.0:
            return y if times is None else (y, np.tile(y, (te.size, 1)))
        modes_a, rho_a = self._phase(modes, rho)
        f = np.empty(n2)
        if self.rate(y, t, modes_a, rho_a, f) != OK:
            return None
        PC, SF, KN, DM = self.fns
        nw = self.n_watch
        out_t = np.empty(te.size + 2)
        out_y = np.empty((out_t.size, n2))
        status, saved, _ = self.advance_fn(
            PC, SF, KN, DM, self.p, self.lay, self.one_sided, self.rolls, modes_a, rho_a, 0.0,
            self.bounds, self.none, np.array([float(t), 0.0, float(t), 0.0, 0.0]), y, f,
            np.empty(n2), np.zeros(nw), np.zeros(nw), np.zeros(self.k), np.zeros(self.k),
            np.zeros((16, n2)), np.zeros((7, n2)), te, float(t + tau),
            max(float(rtol), 100 * np.finfo(float).eps), float(atol), np.inf, 1 << 40,
            out_t, out_y, self.W, self.I, self.ud, self.N, self.F, self.a,
            np.empty(n2), True)
        if status != FINISHED:
            return None
        if times is None:
            return y
        return (y, out_y[:saved].copy()) if saved == te.size else None

    def steps(self, z, t, tau, modes, rho, rtol, atol):
        """:meth:`segment`'s steps with their dense output kept (:func:`steps_of`): a
        :class:`Steps`, whose states anywhere in ``[t, t + tau]`` are the bits
        :meth:`segment` gives at those times; None where :meth:`segment` gives None, or
        where the segment takes more than 65 536 steps (their dense output is kept in
        memory: the caller integrates it otherwise)."""
        self.refresh()
        n2 = 2 * self.n
        y = np.array(z, dtype=float)
        if tau == 0.0:
            return Steps(self, np.empty(0), np.empty(0), np.empty((0, n2)),
                         np.empty((0, 7, n2)), 0, y)
        modes_a, rho_a = self._phase(modes, rho)
        f = np.empty(n2)
        if self.rate(y, t, modes_a, rho_a, f) != OK:
            return None
        PC, SF, KN, DM = self.fns
        most = 64
        while True:
            T, TE = np.empty(most), np.empty(most)
            Y0, FD = np.empty((most, n2)), np.empty((most, 7, n2))
            yy, ff = y.copy(), f.copy()
            status, count = self.steps_fn(
                PC, SF, KN, DM, self.p, self.lay, self.one_sided, self.rolls, modes_a, rho_a,
                self.bounds, self.none, float(t), yy, ff, float(t + tau),
                max(float(rtol), 100 * np.finfo(float).eps), float(atol), self.W, self.I,
                self.ud, self.N, self.F, self.a, T, TE, Y0, FD)
            if status != FULL:
                break
            if most >= 1 << 16:     # (7 coefficients a step: 22 MB for three coordinates)
                return None
            most *= 4
        if status != FINISHED:
            return None
        return Steps(self, T, TE, Y0, FD, count, yy)

    def jacobian(self, X, modes, rho, step):
        """``dF/dX`` of the phase at ``X = (q, u, t)`` by :func:`jacobian`, or None where a
        solve on the way is not the plain one (redundant contacts, no finite solution)."""
        self.refresh()
        PC, SF, KN, _ = self.fns
        m = 2 * self.n + 1
        A = np.empty((m, m))
        st = self.jacobian_fn(PC, SF, KN, self.p, self.lay, self.rolls,
                              *self._phase(modes, rho), self.none, self.W, self.I,
                              self.ud, self.N, self.F, self.a,
                              np.ascontiguousarray(X, dtype=float), float(step), A,
                              np.empty(m), np.empty(m), np.empty(self.n))
        return A if st == OK else None

    def transition(self, X0, tau, modes, rho, rtol, atol, step, max_steps=100_000,
                   directions=None):
        """The transition matrix of the phase over ``tau`` from ``X0 = (q, u, t)`` by
        :func:`transition` (the variational equations, the Jacobian by central differences
        of relative step ``step``), or, given ``directions`` (m x c), the matrix applied to
        them (the variational equations of those directions alone, each ``A d`` by
        central differences along ``d``: two solves a direction, not two a coordinate);
        None where the kernel cannot (redundant contacts, no finite solution, a step below
        scipy's smallest, ``max_steps``)."""
        self.refresh()
        PC, SF, KN, _ = self.fns
        m = 2 * self.n + 1
        P0 = (np.eye(m) if directions is None else
              np.ascontiguousarray(directions, dtype=float))
        Phi = np.empty((m, P0.shape[1]))
        st = self.transition_fn(PC, SF, KN, self.p, self.lay, self.rolls,
                                *self._phase(modes, rho), self.none, self.W, self.I,
                                self.ud, self.N, self.F, self.a,
                                np.ascontiguousarray(X0, dtype=float), float(tau), float(rtol),
                                float(atol), float(step), int(max_steps), Phi, P0,
                                directions is not None)
        return Phi if st == OK else None

    def reactions(self, ts, ys, modes):
        """``(N, F, status)`` of the phases ``modes[i]`` at the states ``(ts[i], ys[i])`` by
        :func:`reactions` (every contact's friction assuming N >= 0; the reactions NaN where
        the status is not ``OK``)."""
        self.refresh()
        PC, SF, KN, _ = self.fns
        ts = np.ascontiguousarray(ts, dtype=float)
        Ns, Fs = np.full((ts.size, self.k), np.nan), np.full((ts.size, self.k), np.nan)
        status = np.empty(ts.size, dtype=np.int64)
        self.reactions_fn(PC, SF, KN, self.p, self.lay, self.rolls, np.ones(self.k), self.none,
                          self.W, self.I, self.ud, self.N, self.F, self.a, ts,
                          np.ascontiguousarray(ys, dtype=float),
                          np.ascontiguousarray(modes, dtype=np.int64), Ns, Fs, status)
        return Ns, Fs, status

    def dense(self, Fd, t_old, h, y_old, t):
        """The state at ``t`` on a step's dense output (:func:`dense_at`)."""
        out = np.empty(2 * self.n)
        self.dense_fn(Fd, float(t_old), float(h), y_old, float(t), out)
        return out

    def locate(self, Fd, t_old, t1, h, y_old, w0, w1, modes, rho, jam):
        """``(t, index)`` of the step's first event by :func:`locate`, or None."""
        PC, SF, KN, DM = self.fns
        wt, yt = np.empty(w0.size), np.empty(2 * self.n)
        t, i = self.locate_fn(PC, SF, KN, DM, self.p, self.lay, self.one_sided, self.rolls,
                              modes, rho, self.none, float(jam), self.bounds, self.W, self.I,
                              self.ud, self.N, self.F, self.a, Fd, float(t_old), float(t1),
                              float(h), y_old, w0, w1, wt, yt)
        return None if i < 0 else (float(t), int(i))

    def watch(self, y, t, modes, rho, jam, out):
        """:func:`watch` into ``out``; its status."""
        PC, SF, KN, DM = self.fns
        return self.watch_fn(PC, SF, KN, DM, y, float(t), self.p, self.lay, self.one_sided,
                             self.rolls, modes, rho, self.none, float(jam), self.bounds,
                             self.W, self.I, self.ud, self.N, self.F, self.a, out)

    def watch_many(self, ys, ts, modes, rho, jam, out):
        """:func:`watch_many` into ``out`` (a row per state); the statuses."""
        PC, SF, KN, DM = self.fns
        status = np.empty(len(ts), dtype=np.int64)
        self.watch_many_fn(PC, SF, KN, DM, ys, ts, self.p, self.lay, self.one_sided,
                           self.rolls, modes, rho, self.none, float(jam), self.bounds,
                           self.W, self.I, self.ud, self.N, self.F, self.a, out, status)
        return status


class Steps:
    """A segment's steps with their dense output (:meth:`Phase.steps`): ``end``, the state
    after the last, and :meth:`at`, the states at given times."""

    def __init__(self, phase, T, TE, Y0, FD, count, end):
        self.phase, self.T, self.TE, self.Y0, self.FD = phase, T, TE, Y0, FD
        self.count, self.end = int(count), end

    def at(self, times):
        """The states at ``times`` (in the segment), a row each: on the dense output of the
        step that :meth:`Phase.segment` saves each of them from."""
        times = np.ascontiguousarray(np.atleast_1d(times), dtype=float)
        out = np.empty((times.size, self.end.size))
        self.phase.dense_many_fn(self.T, self.TE, self.Y0, self.FD, self.count, self.end,
                                 times, out)
        return out
