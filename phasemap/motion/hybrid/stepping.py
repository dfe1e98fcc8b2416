"""One phase of a motion in full coordinates stepped from its start to its first event
(:meth:`phasemap.motion.hybrid.Motion.run`): the compiled flow
(:mod:`phasemap.motion.hybrid.flow`), or scipy's DOP853 over the Python accelerations
where the phase's contacts are redundant (a family of reactions, chosen by linear
programming each step).  Both return what follows: ``(t, q, u, modes, rho)`` of the next
phase, or None where the motion ends.  Each function takes the Motion as ``self``."""

from __future__ import annotations

import numpy as np

from phasemap.core import events as ev
from phasemap.motion.hybrid import binding, flow, jam, landing


#: No requested times (the flow's ``te`` when every step is saved).
_NO_TIMES = np.empty(0)


def phase(self, t, q, u, modes, rho, sc, t_stop, jam_sign, w0, atol):
    """The phase ``modes`` from ``(t, q, u)`` (``w0``: its event functions there) to its
    first event, on the compiled flow."""
    o, n, rec, fl = self.o, self.n, self.rec, self.flow
    fl.refresh()
    y = np.concatenate([q, u])
    modes_a = np.asarray(modes, dtype=np.int64)
    rho_a = fl.pressing if rho is None else np.asarray(rho, dtype=float)
    te = self.t_eval if self.t_eval is not None else _NO_TIMES
    # (the stepping's arrays, kept by the flow between phases: none leaves this function,
    # what is saved or kept is copied out of them)
    out_t, out_y, y_old, w1, yt, K, Fd, gr0, gr1, state, w0_kept, f = fl.buffers(
        max(binding.BUFFER, te.size - self.i_eval + 2))
    if fl.rate(y, t, modes_a, rho_a, f) != flow.OK:
        return scipy_phase(self, t, y, modes, rho, sc, t_stop, jam_sign, w0, atol)
    fl.rates_fn(fl.W, fl.a, fl.lay, modes_a, y, gr0)
    w0_kept[:] = w0
    w0 = w0_kept
    state[:] = t, 0.0, t, 0.0, float(self.i_eval)
    PC, SF, KN, DM = fl.fns
    while True:
        status, saved, steps = fl.advance_fn(
            PC, SF, KN, DM, fl.p, fl.lay, fl.one_sided, fl.rolls, modes_a, rho_a,
            float(jam_sign), fl.bounds, fl.none, state, y, f, y_old, w0, w1, gr0, gr1, K, Fd,
            te, float(t_stop), float(o.rtol), float(atol), float(o.max_step),
            int(o.max_steps - rec.n_steps), out_t, out_y, fl.W, fl.I, fl.ud, fl.N, fl.F, fl.a,
            yt, False)
        rec.n_steps += steps
        rec.points(out_t[:saved], out_y[:saved], modes)
        self.i_eval = int(state[4])
        t1 = state[0]
        if status == flow.FULL:
            continue
        if status == flow.MAX_STEPS:
            self._end(t1, y[:n], y[n:], modes, ev.MAX_STEPS)
            return None
        if status in (flow.FAILED, flow.SINGULAR):
            # the step size collapsed: at a slip's singular point, a dynamic jam
            return jam.at_singular(self, t1, y[:n], y[n:], modes, rho, ev.STEP_FAILURE)
        if status == flow.REDUNDANT:    # (w0: the event functions there, rounding zeroed)
            return scipy_phase(self, t1, y, modes, rho, sc, t_stop, jam_sign, w0.copy(), atol)
        if status == flow.EVENT:
            t_old, h = state[2], state[3]
            F, y0 = Fd.copy(), y_old.copy()

            def dense(s, F=F, y0=y0, t_old=t_old, h=h):
                return fl.dense(F, t_old, h, y0, s)

            first = fl.locate(F, t_old, t1, h, y0, w0, w1, modes_a, rho_a, jam_sign)
            hit, after = _at_event(self, dense, t_old, t1, first, modes, rho)
            state[4] = self.i_eval
            if hit:
                return after
            if self.t_eval is None:       # no event after all: the step as any other
                rec.point(t1, y, modes)
            w0[:] = w1
            gr0[:] = gr1
            if t1 < t_stop:
                continue
        return _finished(self, t1, y, modes)


def _at_event(self, dense, t_old, t1, hit, modes, rho):
    """``(True, what follows)`` where an event function reaches zero in the step ``t_old``
    to ``t1`` (its dense output ``dense``; ``hit``: ``(t, index)`` of the first, or None),
    else ``(False, None)``; saves the requested times up to the event or the step's end."""
    n = self.n
    self._save_eval(dense, t_old, hit[0] if hit else t1, modes)
    if hit is None:
        return False, None
    th, i = hit
    y = dense(th)
    if self.t_eval is None:
        self.rec.point(th, y, modes)
    return True, self._event(th, y[:n], y[n:], modes, rho, i)


def _finished(self, t, y, modes):
    n = self.n
    if t >= self.o.t_end:
        self._end(self.o.t_end, y[:n], y[n:], modes, ev.HORIZON)
        return None
    return landing.zeno(self, t, y[:n], y[n:], modes)   # the impacts' accumulation time


def scipy_phase(self, t, y0, modes, rho, sc, t_stop, jam_sign, w0, atol):
    """:func:`phase` on scipy's DOP853 and the Python accelerations (redundant contacts)."""
    from scipy.integrate import DOP853

    o, n, rec = self.o, self.n, self.rec

    def f(s, y):
        return np.concatenate([y[n:], self.solve(y[:n], y[n:], modes, rho, s)[0]])

    solver = DOP853(f, t, np.array(y0, dtype=float), t_stop, rtol=o.rtol, atol=atol,
                    max_step=o.max_step)
    while True:
        if rec.n_steps >= o.max_steps:
            self._end(solver.t, solver.y[:n], solver.y[n:], modes, ev.MAX_STEPS)
            return None
        t_old = solver.t
        solver.step()
        rec.n_steps += 1
        if solver.status == "failed":
            y = solver.y
            return jam.at_singular(self, t_old, y[:n], y[n:], modes, rho, ev.STEP_FAILURE)
        y1 = solver.y
        w1 = self.watch(y1[:n], y1[n:], modes, rho, sc, solver.t, jam_sign)
        dense = solver.dense_output()
        first = self._first_event(dense, t_old, solver.t, w0, w1, modes, rho, sc, jam_sign)
        hit, after = _at_event(self, dense, t_old, solver.t, first, modes, rho)
        if hit:
            return after
        if self.t_eval is None:
            rec.point(solver.t, y1, modes)
        w0 = w1
        if solver.status == "finished":
            return _finished(self, solver.t, solver.y, modes)
