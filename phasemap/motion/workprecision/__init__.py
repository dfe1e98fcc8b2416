r"""Error against run time (work-precision), in the manner of DiffEqDevTools.

For one :class:`Problem` (a model, an initial state, a horizon and a
:class:`Reference`), :func:`work_precision` runs every method at every
tolerance, measures the error of each run against the reference and the run
time per trajectory, and returns one row (a dict) per (method, tolerance).
:func:`report` turns the rows into a markdown table; the figure is
:func:`phasemap.plot.work_precision_figure`.

>>> import phasemap.motion.workprecision as wp
>>> rows = wp.work_precision(wp.PROBLEMS["hinge_weightless"], tolerances=[1e-6],
...                          methods=["phasemap", "RK45"], repeats=1)   # doctest: +SKIP
>>> print(wp.report(rows))                                            # doctest: +SKIP

Methods
-------
``phasemap``, ``phasemap_DOP853``
    the numba integrator of :mod:`phasemap.motion.integrate` with its Dormand-Prince
    5(4) (the default) or 8(5,3) method, called directly (its jitted kernel,
    the same call :func:`phasemap.simulate` and the fate maps make), with
    ``rtol = atol = tol``.
``simulate``
    :func:`phasemap.simulate` itself: the same kernel plus input validation and
    the :class:`xarray.Dataset` it returns.
``RK45``, ``DOP853``, ``Radau``, ``LSODA``
    :func:`scipy.integrate.solve_ivp` driven stage by stage by
    :func:`solve_ivp_staged`, with ``rtol = atol = tol``: the same problem,
    stage switching included.
``phase_curve``
    the first-integral tracer :func:`phasemap.motion.phase.phase_curve` (one-degree-of-
    freedom models only), with ``rtol = tol`` (its error of omega^2 per panel;
    clipped to its range [1e-14, 1e-3]).  It has no time: its error is
    measured in the phase plane (below).

The scipy stage driver
----------------------
:func:`solve_ivp_staged` (:mod:`phasemap.motion.workprecision.staged`) runs
``solve_ivp`` stage by stage on the model's own branch functions, with terminal
events derived from the model (its velocity, its coefficient, its
classification) and the integrator's own compiled event piece deciding what
happens at each event: the same problem as :func:`phasemap.simulate`, no
physics written per system.

Errors
------
Every method's solution is saved at ``n_save`` times evenly spaced on
[0, t_end] (``t_eval``; a motion that ends before t_end at a fate other than
rest has fewer); after a rest the state is the rest state.

* ``error_final``: max over components of |y_end - y_end_ref|, where y_end is
  the state where the motion ends: at t_end, or at the fate (rest, contact
  loss).
* ``error_l2``: the root mean square over the saved points (and the compared
  components) of y - y_ref, DiffEqDevTools' L2.

For the phase-curve tracer, which has no time, both are measured in the phase
plane: ``error_l2`` is the RMS over its points of omega - omega_ref(phi) on
the same stage, ``error_final`` the max difference of its end state (phi,
omega).

These mix units (rad and rad s-1) wherever they take a maximum or a mean over
components.  The **scaled errors**, ``error_scaled_final`` and
``error_scaled_l2``, are dimensionless: each component's error is first divided
by its scale y_hat_i, the largest magnitude that component reaches along the
reference motion (:attr:`Reference.scales`, stated in each row as
``scales``):

* ``error_scaled_final`` = max_i |y_end,i - y_end,i_ref| / y_hat_i;
* ``error_scaled_l2`` = the RMS over the saved points and the compared
  components of (y_i - y_i_ref) / y_hat_i; for the tracer, of
  (omega^2 - omega_ref(phi)^2) / omega_hat^2 over its points: omega^2 is the
  variable it integrates, and stays smooth where a stage turns, where omega
  ~ sqrt(phi - phi_turn) makes a tiny shift of the turn a large error of
  omega at the tracer's last points.

They are what the figures draw (:func:`phasemap.plot.work_precision_figure`
labels them with this definition).

References (:class:`Reference`, :mod:`phasemap.motion.workprecision.problems`): a closed form in time (the weightless hinge
pendulum, eq. (36)); a first integral omega(phi) (the ladder's omega^2(phi),
compared at each method's own phi, with the exact contact-loss state where
N_wall or N_floor vanishes on the closed form); or ``"tight"``: the driver
with DOP853 at rtol = atol = 1e-13 (:func:`tight_reference`).  Its ``floor``
is its difference from DOP853 at 1e-12, errors below about that are not
resolved; it is cross-checked against the numba integrator at 1e-13.

Timing
------
The run time of a method is the median over ``repeats`` rounds; in each
round the methods alternate, tolerance by tolerance.  Every (method,
tolerance) runs once before timing (this gives the errors); each method's
first tolerance runs once more before that, to warm numba's JIT, so that the
``budget`` below judges a run and never a compilation: a cold cache cannot
skip the tight tolerances, and the same inputs give the same errors.  A sample repeats a fast run until it lasts ``min_time`` seconds and
divides.  Preparation that is not per trajectory (model lookup, input
validation, the input vector) is outside the timing for ``phasemap`` and the
scipy driver alike; ``simulate`` and ``phase_curve`` are timed as a user calls
them.  A method whose warm-up run exceeds ``budget`` seconds skips its tighter
tolerances (its rows say ``skipped``).
"""

from __future__ import annotations

import gc
import math
import os
import statistics
import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from phasemap.core import events as ev
from phasemap.systems import get_model
from phasemap.motion.simulate import integrated_variables, simulate
from phasemap.motion.workprecision.problems import PROBLEMS, TIGHT, Problem, Reference, kernel_run, tight_reference
from phasemap.motion.workprecision.staged import StageDriver, Staged, solve_ivp_staged

__all__ = ["DEFAULT_METHODS", "DEFAULT_TOLERANCES", "PHASEMAP_METHODS", "PROBLEMS",
           "SCIPY_METHODS", "TIGHT", "Problem", "Reference", "Staged", "equal_error_ratio",
           "report", "solve_ivp_staged", "tight_reference", "time_at_error", "work_precision"]

#: The solve_ivp methods compared.
SCIPY_METHODS = ("RK45", "DOP853", "Radau", "LSODA")
#: The numba integrator's kernel, by the integrator method it runs.
PHASEMAP_METHODS = {"phasemap": "DOPRI5", "phasemap_DOP853": "DOP853"}
#: Every method, in the order of the figure's legend.
DEFAULT_METHODS = ("phase_curve", *PHASEMAP_METHODS, "simulate") + SCIPY_METHODS
#: rtol = atol of the sweep: 1e-3 to 1e-13.
DEFAULT_TOLERANCES = tuple(10.0 ** -k for k in range(3, 14))


def _scales(ref: Reference, ny: int) -> np.ndarray:
    return np.ones(ny) if ref.scales is None else np.asarray(ref.scales, dtype=float)


def _time_errors(ref: Reference, t, y, y_end) -> dict:
    """The errors (module docstring) of a run saved at times ``t``."""
    y = np.asarray(y, dtype=float)
    end = np.abs(np.asarray(y_end, dtype=float) - ref.end)
    scale = _scales(ref, end.size)
    out = dict(error_final=float(np.max(end)), error_scaled_final=float(np.max(end / scale)),
               error_l2=math.nan, error_scaled_l2=math.nan)
    if len(t) == 0:
        return out
    y_ref = ref.states(np.asarray(t, dtype=float), y)
    comps = list(ref.components) if ref.components is not None else list(range(end.size))
    diff = (y - y_ref)[:, comps]
    out["error_l2"] = float(np.sqrt(np.mean(diff ** 2)))
    out["error_scaled_l2"] = float(np.sqrt(np.mean((diff / scale[comps]) ** 2)))
    return out


def scales_of(problem: Problem, ref: Reference) -> tuple[tuple[str, float, str, str], ...]:
    """``(name, y_hat, units, symbol)`` of each state component: the scales of the
    scaled errors."""
    names = integrated_variables(get_model(problem.model))
    return tuple((v.name, float(s), v.units, v.symbol)
                 for v, s in zip(names, _scales(ref, len(names))))


def _methods_for(p: Problem, methods):
    m = get_model(p.model)
    keep = []
    for method in methods:
        if method == "phase_curve":
            if len(m.dynamics.coordinates) != 1:  # phase curves of 1-DOF models only
                continue
        elif method not in (*PHASEMAP_METHODS, "simulate") + SCIPY_METHODS:
            raise ValueError(f"unknown method {method!r}; choose from "
                             f"{', '.join(DEFAULT_METHODS)}")
        keep.append(method)
    return keep


def _job(p: Problem, ref: Reference, method: str, tol: float):
    """(go, measure): a timed zero-argument call and the measurement of its result."""
    if method in PHASEMAP_METHODS:
        go = kernel_run(p, tol, PHASEMAP_METHODS[method])

        def measure(r):
            return dict(_time_errors(ref, p.t_save[:len(r.y_eval)], r.y_eval, r.y),
                        fate=ev.Event(int(r.fate)).name.lower(),
                        n_reversals=int(r.n_reversals), n_steps=int(r.n_steps),
                        nfev=math.nan)
    elif method == "simulate":
        values = dict(p.values)

        def go():
            return simulate(p.model, p.t_end, rtol=tol, t_eval=p.t_save, **values)

        def measure(ds):
            names = [v.name for v in integrated_variables(get_model(p.model))]
            y = np.column_stack([ds[n].values for n in names])
            y_end = np.array([float(ds[f"event_{n}"][-1]) for n in names])
            return dict(_time_errors(ref, ds.t.values, y, y_end), fate=ds.attrs["end_reason"],
                        n_reversals=int(ds.attrs["n_reversals"]),
                        n_steps=int(ds.attrs["n_steps"]), nfev=math.nan)
    elif method in SCIPY_METHODS:
        driver = StageDriver(p.model, p.values)
        te = p.t_save

        def go():
            return driver.run(method, tol, tol, float(p.t_end), te)

        def measure(r):
            return dict(_time_errors(ref, r.t, r.y, r.y_final), fate=r.fate,
                        n_reversals=r.n_reversals,
                        n_steps=math.nan, nfev=int(r.nfev))
    elif method == "phase_curve":
        from phasemap.motion.phase import phase_curve

        m = get_model(p.model)
        full = m.complete({k: v for k, v in p.values.items()})
        params = {v.name: float(full[v.name]) for v in m.params}
        kw = {} if p.phi_range is None else {"phi_range": p.phi_range}

        rtol = min(max(tol, 1e-14), 1e-3)  # the tracer's range

        def go():
            return phase_curve(m, phi=float(full["phi"]), omega=float(full["omega"]),
                               rtol=rtol, **kw, **params)

        def measure(ds):
            phi, omega = ds.phi.values, ds.omega.values
            w_ref = ref.omega(phi, ds.point_stage.values) if ref.omega else np.nan * phi
            end = np.abs(np.array([float(ds.stage_end_phi[-1]),
                                   float(ds.stage_end_omega[-1])]) - ref.end)
            scale = _scales(ref, 2)
            # omega^2, the tracer's own variable, is smooth where a stage turns (omega
            # ~ sqrt(phi - phi_turn) there, so a tiny shift of the turn is a large
            # error of omega at the tracer's last points)
            du = (omega ** 2 - w_ref ** 2) / scale[1] ** 2
            return dict(error_final=float(np.max(end)),
                        error_scaled_final=float(np.max(end / scale)),
                        error_l2=float(np.sqrt(np.mean((omega - w_ref) ** 2))),
                        error_scaled_l2=float(np.sqrt(np.mean(du ** 2))),
                        fate=ds.attrs["end_reason"], n_reversals=int(ds.attrs["n_reversals"]),
                        n_steps=math.nan, nfev=math.nan)
    else:
        raise ValueError(f"unknown method {method!r}")
    return go, measure


def _sample(go, min_time: float) -> float:
    """Seconds per call: ``go`` repeated until ``min_time`` has passed."""
    count = 0
    start = time.perf_counter()
    while True:
        go()
        count += 1
        elapsed = time.perf_counter() - start
        if elapsed >= min_time:
            return elapsed / count


def work_precision(problem: Problem | str, tolerances: Sequence[float] = DEFAULT_TOLERANCES,
                   methods: Sequence[str] = DEFAULT_METHODS, repeats: int = 3, *,
                   min_time: float = 0.02, budget: float = 10.0, slow: float = 1.0,
                   reference: Reference | None = None,
                   progress: Callable[[str], None] | None = None) -> list[dict]:
    """Error against run time of every method at every tolerance on one problem.

    Parameters
    ----------
    problem:
        a :class:`Problem` or the name of a built-in one (:data:`PROBLEMS`).
    tolerances:
        rtol = atol of each run (the phase-curve tracer's rtol).
    methods:
        any of :data:`DEFAULT_METHODS` (see the module docstring).
    repeats:
        timing rounds; each round alternates the methods tolerance by tolerance
        and the reported time is the median.  A run that took more than
        ``slow`` seconds is timed once.
    min_time:
        a fast run is repeated until one sample lasts this long.
    budget:
        a method whose run exceeds this many seconds skips tighter tolerances.
    reference:
        the reference to use (default: ``problem.resolve()``).
    progress:
        called with a line of text as the sweep goes.

    Returns
    -------
    list of dict
        one per (method, tolerance): ``system`` (the problem's name),
        ``model``, ``method``, ``tol``, ``error_final``, ``error_l2``,
        ``error_scaled_final``, ``error_scaled_l2`` (dimensionless; see the
        module docstring), ``scales`` (``(name, y_hat, units, symbol)`` per
        state component), ``seconds`` (median per trajectory), ``seconds_min`` and
        ``seconds_max`` (the spread of the ``n_samples`` rounds), ``load`` (the
        machine's one-minute load average as the rounds ended) and ``cores``,
        ``fate``, ``n_reversals``,
        ``same_fate`` (fate and reversal count equal the reference's),
        ``n_steps`` (phasemap), ``nfev`` (scipy), ``skipped`` and the
        reference's ``reference`` kind, ``floor`` and ``cross_check``.
    """
    p = PROBLEMS[problem] if isinstance(problem, str) else problem
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    tols = [float(t) for t in tolerances]
    for t in tols:
        if not 1e-14 <= t <= 0.1:
            raise ValueError(f"tolerances must lie in [1e-14, 0.1], got {t!r}")
    ref = reference if reference is not None else p.resolve()
    say = progress or (lambda text: None)
    methods = _methods_for(p, methods)
    jobs: dict[tuple[str, float], dict] = {}
    scales = scales_of(p, ref)
    for method in methods:
        over = False
        for k, tol in enumerate(sorted(tols, reverse=True)):
            row = dict(system=p.name, model=p.model, method=method, tol=tol,
                       reference=ref.kind, floor=ref.floor, floor_scaled=ref.floor_scaled,
                       cross_check=ref.cross_check, scales=scales)
            if over:
                jobs[(method, tol)] = dict(row, error_final=math.nan, error_l2=math.nan,
                                           error_scaled_final=math.nan,
                                           error_scaled_l2=math.nan,
                                           seconds=math.nan, seconds_min=math.nan,
                                           seconds_max=math.nan, n_samples=0,
                                           fate="", n_reversals=-1,
                                           same_fate=False, n_steps=math.nan,
                                           nfev=math.nan, skipped=True)
                continue
            go, measure = _job(p, ref, method, tol)
            if k == 0:
                go()  # numba's JIT and caches: not a run the budget may judge
            start = time.perf_counter()
            result = go()  # the errors
            took = time.perf_counter() - start
            row.update(measure(result))
            # a slow scipy run (no JIT to warm) counts its first run as its one sample
            first = [took] if method in SCIPY_METHODS and took > slow else []
            row.update(same_fate=row["fate"] == ref.fate
                       and row["n_reversals"] == ref.n_reversals,
                       skipped=False, _go=go, _took=took, _samples=first)
            jobs[(method, tol)] = row
            over = took > budget
            say(f"{p.name:18s} {method:11s} tol {tol:7.0e}  error {row['error_final']:.2e}  "
                f"{took:.4f} s  {row['fate']}")
    for r in range(repeats):
        gc.collect()
        for tol in sorted(tols, reverse=True):
            for method in methods:
                row = jobs.get((method, tol))
                if row is None or row["skipped"]:
                    continue
                if row["_took"] > slow and row["_samples"]:
                    continue
                row["_samples"].append(_sample(row["_go"], min_time))
    # the machine's one-minute load average as the rounds end: what a bar's spread says
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    rows = []
    for row in jobs.values():
        row["load"], row["cores"] = float(load), os.cpu_count() or 0
        if not row["skipped"]:
            samples = row.pop("_samples")
            row["seconds"] = float(statistics.median(samples))
            row["seconds_min"], row["seconds_max"] = float(min(samples)), float(max(samples))
            row["n_samples"] = len(samples)
            row.pop("_go")
            row.pop("_took")
        rows.append(row)
    return rows


# ------------------------------------------------------------------ summaries
def _front(rows, system, method, error):
    pts = sorted((r["seconds"], r[error]) for r in rows
                 if r["system"] == system and r["method"] == method and not r["skipped"]
                 and math.isfinite(r["seconds"]) and math.isfinite(r[error])
                 and r["seconds"] > 0)
    front, best = [], math.inf
    for sec, err in pts:
        if err < best:
            front.append((sec, max(err, 1e-300)))
            best = err
    return front


def time_at_error(rows: Sequence[Mapping], system: str, method: str, level: float,
                  error: str = "error_final") -> float:
    """Seconds per trajectory ``method`` needs for an error <= ``level`` on ``system``.

    Log-log interpolation on the method's Pareto front (its runs that no faster
    run beats in error); the time of its fastest run when that already meets
    ``level``; NaN when no run reaches it.
    """
    front = _front(rows, system, method, error)
    if not front or level < front[-1][1]:
        return math.nan
    if level >= front[0][1]:
        return front[0][0]
    for (s0, e0), (s1, e1) in zip(front, front[1:]):
        if e1 <= level <= e0:
            if e0 == e1:
                return s1
            w = math.log(level / e0) / math.log(e1 / e0)
            return math.exp(math.log(s0) + w * math.log(s1 / s0))
    return math.nan


def equal_error_ratio(rows: Sequence[Mapping], system: str, level: float,
                      method: str | Sequence[str] = "phasemap",
                      against: Sequence[str] = SCIPY_METHODS,
                      error: str = "error_final") -> tuple[float, str]:
    """(time of the fastest of ``against`` / time of ``method``, that method) at ``level``.

    ``method`` may be several methods: the fastest of them at ``level`` counts.
    """
    ours = [method] if isinstance(method, str) else list(method)
    mine = min((time_at_error(rows, system, m, level, error) for m in ours),
               key=lambda t: t if math.isfinite(t) else math.inf)
    theirs = [(time_at_error(rows, system, m, level, error), m) for m in against]
    theirs = [(t, m) for t, m in theirs if math.isfinite(t)]
    if not theirs or not math.isfinite(mine):
        return math.nan, ""
    best, name = min(theirs)
    return best / mine, name


def _fmt_time(sec: float) -> str:
    if not math.isfinite(sec):
        return "-"
    if sec >= 1.0:
        return f"{sec:.2f} s"
    if sec >= 1e-3:
        return f"{sec * 1e3:.3g} ms"
    return f"{sec * 1e6:.3g} us"


def report(rows: Sequence[Mapping], levels: Sequence[float] = (1e-3, 1e-5, 1e-7, 1e-9, 1e-11),
           error: str = "error_final",
           method: str | Sequence[str] = tuple(PHASEMAP_METHODS)) -> str:
    """A markdown table: run time per trajectory needed for each error level, per method.

    One block per system: a line per method (its smallest error, and whether
    every run ended like the reference), then for each of ``method`` that ran
    the ratio of the fastest solve_ivp method's time to its time at equal
    error, and, when several ran, the same for the fastest of them at each
    level.  Levels below ten times the reference's floor (``floor_scaled`` for a
    scaled ``error``, so that both are in one unit) are shown as ``(floor)``.
    """
    floor_key = "floor_scaled" if error.startswith("error_scaled") else "floor"
    ours = [method] if isinstance(method, str) else list(method)
    systems = list(dict.fromkeys(r["system"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    head = " | ".join(f"err <= {lv:.0e}" for lv in levels)
    lines = [f"| system | method | {head} | smallest error | fates as reference |",
             "|---|---|" + "---:|" * len(levels) + "---:|---|"]
    for system in systems:
        mine = [r for r in rows if r["system"] == system]
        floor = max((r.get(floor_key, 0.0) for r in mine), default=0.0)
        for m in methods:
            runs = [r for r in mine if r["method"] == m and not r["skipped"]]
            if not runs:
                continue
            cells = [_fmt_time(time_at_error(rows, system, m, lv, error)) for lv in levels]
            errs = [r[error] for r in runs if math.isfinite(r[error])]
            smallest = f"{min(errs):.1e}" if errs else "-"
            same = sum(bool(r["same_fate"]) for r in runs)
            lines.append(f"| {system} | {m} | " + " | ".join(cells)
                         + f" | {smallest} | {same}/{len(runs)} |")
        ran = [m for m in ours if any(r["method"] == m and not r["skipped"] for r in mine)]
        groups = [(m, [m]) for m in ran]
        if len(ran) > 1:
            groups.append((f"best of {', '.join(ran)}", ran))
        for label, group in groups:
            cells = []
            for lv in levels:
                if lv < 10.0 * floor:
                    cells.append("(floor)")
                    continue
                ratio, who = equal_error_ratio(rows, system, lv, group, SCIPY_METHODS, error)
                cells.append(f"**{ratio:.0f}x** ({who})" if math.isfinite(ratio) else "-")
            lines.append(f"| {system} | {label} speed-up over best solve_ivp | "
                         + " | ".join(cells) + f" | floor {floor:.0e} | |")
    return "\n".join(lines)
