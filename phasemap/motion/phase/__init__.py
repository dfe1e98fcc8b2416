r"""Phase curves omega(phi) of every one-degree-of-freedom model: :func:`phase_curve`.

A model whose :class:`phasemap.Dynamics` has one coordinate triple
``(phi, omega, phi_ddot)`` has a phase plane.  On a *stage* one branch b of
the friction law is active and the sign sigma of omega is fixed; with
u = omega^2 and phi'' = (1/2) du/dphi the motion equation becomes a
first-order equation for u(phi),

    du/dphi = 2 F_b(phi, u),

where F_b is the senior derivative phi'' read from the model's own branch row
(``branch_row_inline`` of the generated contract, evaluated at omega =
sigma sqrt(u)): the same physics as :func:`phasemap.classify`, the grid and
the integrator.  :func:`phase_curve` follows u stage by stage in phi, with no
time stepping and no per-system code, and ends every stage at an exactly
located event.  Like the integrator it is compiled once per model
(:func:`phasemap.core.compile.specialize`) and cached on disk.

Method: exponential Gauss collocation in phi
--------------------------------------------
For the seed systems F_b is affine in u (the ladder with a constant slope,
the wheel with slope -l (r sin phi + delta sigma cos phi)/bracket) or
piecewise affine (the hinge pendulum, through |Q_n|), and the slope can be
huge: the ladder's is 3 sigma f/(2 - f^2), unbounded as f -> sqrt 2.  So
each panel [phi_k, phi_k + sigma h] (s = sigma (phi - phi_k) in [0, h]) splits
the right-hand side f = 2 sigma F_b into a frozen linear part and a remainder,

    du/ds = beta u + N(s, u),   beta = df/du at the panel start,

and solves it by variation of constants, u(s) = e^{beta s} u_k +
int_0^s e^{beta (s - t)} N(t) dt, with N replaced by its polynomial
interpolant at the :data:`NODES` Gauss-Legendre points of the panel
(collocation: the stage values U_i solve the same formula at the nodes, by
Newton's method with the slopes dF/du taken from two evaluations of the
branch row per node; for an affine F_b one step is exact).  The iteration
stops where its correction (relative to |u| + u_ref) is below 1e-14 or, at a
loose rtol, below :data:`NEWTON` rtol times 1 - its contraction (measured
between two corrections, 1/2 before).  N is evaluated at the iterate before
the last correction, about correction / (1 - contraction) from the solution,
which moves u at the panel's end by h |dN/du| (below about 1) times that: a
thousandth of what the panel may err.  The weights
int e^{z (theta - t)} t^k dt are the phi-functions of exponential integrators,
z = beta h, computed without cancellation for every z (Taylor series and a
downward recurrence for |z| < 6, the upward recurrence beyond), so that

* for a moderate slope the method is Gauss collocation: **order 2 NODES = 12**
  in the panel width (the test suite measures it);
* for a huge slope it is exact for the linear part: a boundary layer of width
  1/|beta| is resolved by the exponential, not by panels, and a decaying
  exponential (f just above sqrt 2) puts u on its slow curve in one panel;
  a growing one is followed at most :data:`Z_GROW` e-folds per panel.

The panel width adapts: the error estimate is the tail of the Legendre
expansion of the interpolated N, extrapolated to the degree the collocation
actually errs at (see ``_panel``), against ``rtol (|u| + u_ref)`` with u_ref
the square of the model's velocity scale.  The interpolant is also the dense
output: u at any phi of a panel with the same accuracy, which the event
location and the output points use (where |z| <= 1 evaluated by its Taylor
series in the panel's variable, with no phi-functions per point).  The next
width heeds the last panel's estimate (scaled as h^11) as well as this one's,
so that a tail coefficient passing near zero does not suggest a panel that
fails.

Where a reaction the model names in ``Model.kinks`` changes sign inside a panel
(the hinge's R_n = m Q_n, where |Q_n| has its kink), the panel is redone to end
at that sign change, so that no panel straddles a kink of F_b; the next one
resumes the width chosen before.  A reaction that enters F_b without a kink
(the wheel's contact force F) is not split at: a declared system's modes fix
every sign their laws depend on, so its kinks are empty, and a model that does
not say splits at every reaction.

Events (the codes of :class:`phasemap.Event`)
---------------------------------------------
After every panel the end state is classified with the model's ``point``
function, exactly as :func:`phasemap.classify` does (and as the integrator
does after every step).  The stage goes on while u > 0 and the classification
is unique, on the stage's branch, with the coefficient of the senior
derivative keeping its sign.  Otherwise the first state where that stops is
located on the dense output to double precision in phi and classified there.
A zero of u, of a reaction or of the coefficient is found by Newton's method
(a few Gauss passes; for u with the slope the equation gives, one or two); a
change of classification by bisection, on the
straight line u is within 1e-8 of such a zero, or on Gauss passes where there
is none:

* u = 0 (or an omega the model counts as zero): the rest state (phi, 0) is
  classified: a unique solution on the stick branch is ``rest``; a unique
  solution on a slip (roll, turn) branch is ``reversal`` and the next stage
  starts from rest in that branch's direction; no solution is
  ``no_solution`` (``singular`` if a coefficient of the senior derivative
  vanishes, ``contact_lost`` if a branch needs a one-sided contact to pull);
  two or more solutions are ``indeterminate`` (a continuum at a vanishing
  coefficient is ``singular``).  The tracer never picks a branch.
* the stage's branch needs a one-sided contact to pull: ``contact_lost``, at
  the crossing N = 0 (the ladder's floor or wall, the wheel's bounce (12)).
* the coefficient of the senior derivative vanishes or changes sign
  (the wheel's bracket): ``singular``; a state with no solution or several:
  ``no_solution``, ``indeterminate``, ``continuum`` as the integrator names
  them; another branch of the same direction takes over: ``switch``, and a
  new stage starts there.
* phi leaves ``phi_range``: ``horizon``, at the boundary; where that boundary
  is the model's own domain edge (the ladder lying flat at pi/2),
  ``left_domain``.
* the stage count runs out: the last stage's reason becomes ``max_events``.
* u would exceed :data:`U_MAX` = 1e300 rad2 s-2, or the panel width falls
  below double-precision resolution: ``step_failure`` (``singular`` when the
  active coefficient has fallen below 1e-6 of its value at the stage start).

Ties: at a stage start, the model's ``point`` decides (a grazing N = 0 is
kept); along a stage a state counts as leaving the stage where its
classification does.

Dataset
-------
Dimension ``point``: ``phi``, ``omega`` (signed: the sign of the stage, 0 at
rest), ``omega_squared`` and ``point_stage`` (the index of the stage each
point belongs to; the stage coordinate is called ``stage``, so the per-point
index cannot be).  Each stage contributes ``points_per_stage`` points evenly
spaced in phi from its start to its exact end point (one point for a stage
that ends where it starts); consecutive stages share their reversal point.
Dimension ``stage``: ``stage_sign``, ``stage_start_phi``,
``stage_start_omega``, ``stage_end_reason`` (int8 CF flags of
:class:`phasemap.Event`), ``stage_end_phi`` and ``stage_end_omega``.
Global attributes: ``phasemap_kind = "phase_curve"``, the model, the version,
``phasemap_initial_<state>``, ``phasemap_fixed_<param>``, ``phasemap_phi_range``,
``end_reason`` and ``end_message``.

For developers
--------------
Nothing: any model with one coordinate triple in its ``dynamics`` gets phase
curves from its branch functions.  A hand-written model whose law bends where a
reaction changes sign within one branch names that reaction in ``Model.kinks``
(declared systems need not: their modes fix those signs).  The names of the coordinate and its
velocity are read from the declaration.

Layout: :mod:`phasemap.motion.phase.collocation` (the maths of a panel),
:mod:`phasemap.motion.phase.tracer` (the numba templates of a stage and a curve,
compiled per model) and this module (:func:`phase_curve` and its Dataset).
"""

from __future__ import annotations

import inspect
import math
import warnings

import numpy as np
from phasemap.core.lazy import xarray as xr

from phasemap.core import args as _args
from phasemap.core import events as ev
from phasemap.core.compile import contract_constants, remember, specialize
from phasemap.atlas.dataset import assemble, cf_header, squared_units
from phasemap.core.model import Model
from phasemap.core.progress import human_bytes
from phasemap.core.resources import MEMORY_COPIES, MEMORY_SHARE, available_memory
from phasemap.systems import get_model
from phasemap.motion.phase import tracer
from phasemap.motion.phase.collocation import NODES
from phasemap.motion.phase.tracer import NEWTON, U_MAX, Z_GROW

__all__ = ["H_MAX", "NEWTON", "NODES", "RTOL", "U_MAX", "Z_GROW", "first_width", "kernel",
           "phase_curve", "trace"]

#: Relative accuracy asked of every panel (of |u| + u_ref): the default rtol.
RTOL = 1e-14
#: Widest panel (rad).
H_MAX = 0.5
#: Default half width of the phi range of the unbounded models.
_DEFAULT_SPAN = 4.0 * math.pi


# ---------------------------------------------------------------- the compiled tracer

def coordinate(m: Model) -> tuple[str, str, str]:
    """The model's one coordinate triple, or a ValueError that says why there is none."""
    dyn = m.dynamics
    if dyn is None:
        raise ValueError(f"{m.name}: phase_curve needs a model that moves (Model.dynamics is "
                         f"None); {m.name} can be classified and mapped only")
    if len(dyn.coordinates) != 1:
        names = ", ".join(c[0] for c in dyn.coordinates)
        raise ValueError(
            f"{m.name}: phase_curve follows one-degree-of-freedom models only, and {m.name} "
            f"has {len(dyn.coordinates)} coordinates ({names}); use phasemap.simulate for "
            f"{m.name}")
    pos, vel, acc = dyn.coordinates[0]
    if vel != m.velocity:
        raise ValueError(f"{m.name}: phase_curve needs the velocity of the coordinate {pos!r} "
                         f"to be the model's relative velocity {m.velocity!r}, got {vel!r}")
    return pos, vel, acc


def kernel(m: Model):
    """The model's compiled curve function (specialised once per model, cached on disk)."""
    return remember(("phase_curve", m.name), m, lambda: _build(m))


def _build(m: Model):
    pos, vel, acc = coordinate(m)
    consts = contract_constants(m)
    consts.update(
        PHI=int(consts["Y_SLOT"][0]), OMEGA=int(consts["Y_SLOT"][1]),
        ACC=int(consts["ACC_COL"][0]),
        OMEGA_DERIVED=any(d.source == vel for d in m.derived),
        KINKS=np.array([q for q, r in enumerate(m.reactions)
                        if m.kinks is None or r.name in m.kinks], dtype=np.int64),
    )
    for name, template, inline in tracer.PIECES:
        consts[name] = specialize(template, m, f"phase_{name.lower()}", inline=inline,
                                  counts=name in tracer.COUNTED, **consts)
    return consts["CURVE"]


def velocity_reference(m: Model, full: dict) -> float:
    """u_ref: the square of the model's natural velocity scale at these values."""
    scale_of = m.velocity_scale.py_func
    names = remember(("velocity_scale", m.name), m,
                     lambda: tuple(inspect.signature(scale_of).parameters))
    scale = float(scale_of(*[full[n] for n in names]))
    return scale * scale if scale > 0.0 and math.isfinite(scale) else 1.0


def first_width(rtol: float, h_max: float) -> float:
    """The first panel's width: h_max where rtol >= 1e-10, else h_max / 20.

    A panel's error grows as its width to the 12th power, so at a loose rtol the
    widest panel is accepted from the start; growing to it from h_max / 20 cost the
    ladder's curve a fifth and the wheel's and the hinge's 7-12 % at rtol 1e-6 to
    1e-10 (benchmarks/phase_curve.py's curves).  At tighter rtol a wide first panel
    is rejected about as often as it saves growth, and the default curves (rtol
    1e-14) keep their panels.
    """
    return h_max if rtol >= 1e-10 else 0.05 * h_max


def trace(m: Model, full: dict, phi_range, max_stages: int, points: int,
          rtol: float = RTOL, h_max: float = H_MAX, h_first: float | None = None):
    """Run the compiled tracer: (points (phi, u, stage), stages (sign, phi0, u0, reason,
    phi_end, u_end)).

    ``rtol``, ``h_max`` and ``h_first`` (the first panel's width, default
    :func:`first_width`) are for measurements: ``rtol = inf`` accepts every panel (and
    converges each one's Newton iteration to 1e-14), so that panels of width h_max
    measure the order of the method.
    """
    pos, vel, _ = coordinate(m)
    v = m.input_vector(full)
    return kernel(m)(v, float(full[pos]), float(full[vel]), float(phi_range[0]),
                     float(phi_range[1]), int(max_stages), int(points),
                     velocity_reference(m, full), float(rtol), float(h_max),
                     float(first_width(rtol, h_max) if h_first is None else h_first))



#: The tracer under its former name (the tests call it directly).
_trace = trace


# ---------------------------------------------------------------- public API

#: The most stages of a curve (an int32 in the kernel) and points per stage (each
#: stage's points are stored as it ends: 10^6 of them are 24 MB a stage).
MAX_STAGES = 2 ** 31 - 1
MAX_POINTS = 10 ** 6


def phase_curve(model: str | Model, *, phi: float | None = None, omega: float | None = None,
                phi_range: tuple[float, float] | None = None, max_stages: int = 50,
                points_per_stage: int = 200, rtol: float = RTOL,
                **params: float) -> xr.Dataset:
    """The phase curve omega(phi) from (phi, omega), stage by stage, to its fate.

    Parameters
    ----------
    model:
        any one-degree-of-freedom model (``"ladder"``, ``"wheel"``,
        ``"hinge_pendulum"``, or a :class:`phasemap.Model` whose dynamics has
        one coordinate); the two-degree-of-freedom elliptic pendulum has no
        phase curve of this kind (use :func:`phasemap.simulate`).
    phi, omega:
        the initial state: the model's coordinate and its velocity (rad,
        rad s-1 for the built-in ones).  They may also be given by the model's
        own names (``theta=..., omega=...`` for ``rod_on_step``).  An omega
        the model counts as zero (``|omega| <= 1e-12`` times its velocity
        scale) is a rest state.
    phi_range:
        ``(low, high)`` containing ``phi``: the curve ends with ``horizon``
        where it leaves this range.  Default: the domain of ``phi`` where it is
        bounded (the ladder's [0, pi/2]), else ``(phi - 4 pi, phi + 4 pi)``.
    max_stages:
        the largest number of stages; a curve still reversing after that many
        ends with ``max_events``.  Where that many stages' points would not fit
        in half the memory available, fewer are traced, and a curve cut there
        says so in ``end_message`` and with a RuntimeWarning.
    points_per_stage:
        points evenly spaced in phi on each stage, its ends included (24 bytes
        each; ValueError where not even one stage fits in memory).
    rtol:
        the error of omega^2 allowed per panel, relative to ``|omega^2| +
        u_ref`` (u_ref the square of the model's velocity scale), in
        [1e-14, 1e-3].  The default, 1e-14, traces to about machine precision;
        a looser one takes fewer, longer panels (the method is of order 12) and
        stops each panel's Newton iteration earlier (at :data:`NEWTON` rtol), for
        portraits of many curves.
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
        last stage's reason.  See the module docstring for the method and the
        events.

    Raises
    ------
    ValueError
        for a model without exactly one degree of freedom, an unknown or
        out-of-domain variable, a non-scalar value, a ``phi_range`` that does
        not contain ``phi`` or leaves the model's domain, or bad
        ``max_stages``/``points_per_stage``.

    Examples
    --------
    >>> from phasemap.motion.phase import phase_curve
    >>> ds = phase_curve("hinge_pendulum", phi=0.2, omega=0.0, delta=0.02)
    >>> ds.attrs["end_reason"], int(ds.sizes["stage"])
    ('rest', 5)
    >>> abs(float(ds.stage_end_phi[-1])) <= 0.02      # rest needs l |sin phi| <= delta
    True
    """
    m = get_model(model)
    pos, vel, _ = coordinate(m)
    for name, given in ((pos, phi), (vel, omega)):
        if given is not None and name in params and name not in ("phi", "omega"):
            raise ValueError(f"{m.name}: {name} is given twice")
    phi = params.pop(pos, phi) if pos != "phi" else phi
    omega = params.pop(vel, omega) if vel != "omega" else omega
    given = {k: v for k, v in ((pos, phi), (vel, omega)) if v is not None}
    values = _args.scalars({**given, **params}, m.names, m.name, " for phase_curve()")
    if phi is None or omega is None:
        raise ValueError(f"{m.name}: phase_curve needs the initial {pos} and {vel}")
    full = {k: float(v) for k, v in m.complete(values).items()}
    lo, hi = _checked_range(m, pos, full[pos], phi_range)
    max_stages = _args.count("max_stages", max_stages, m.name, most=MAX_STAGES)
    points = _args.count("points_per_stage", points_per_stage, m.name, least=2,
                         most=MAX_POINTS)
    rtol = _args.real("rtol", rtol, m.name)
    if not RTOL <= rtol <= 1e-3:
        raise ValueError(f"{m.name}: rtol must be in [1e-14, 1e-3], got {rtol!r}")
    capped = _stage_cap(m, max_stages, points)
    pts, stages = trace(m, full, (lo, hi), max_stages if capped is None else capped, points,
                        rtol=rtol)
    stages = stages.copy()
    var = m.variables[pos]
    if stages[-1, 3] == ev.HORIZON and stages[-1, 4] in (var.lower, var.upper):
        stages[-1, 3] = ev.LEFT_DOMAIN  # the model's own edge (the ladder lies flat)
    ds = _dataset(m, full, (lo, hi), max_stages, points, pts, stages, rtol)
    if capped is not None and stages[-1, 3] == ev.MAX_EVENTS:
        message = (f"stopped after {capped:,} stages of the {max_stages:,} allowed: more "
                   f"points would not fit in the memory available "
                   f"({human_bytes(available_memory() or 0)}); pass fewer points_per_stage "
                   f"(now {points:,}) or fewer max_stages")
        ds.attrs["end_message"] = message
        warnings.warn(f"{m.name}: {message}", RuntimeWarning, stacklevel=2)
    return ds


#: Bytes of a phase curve's saved point (phi, omega^2 and its stage) and of a stage's row.
POINT_BYTES, STAGE_BYTES = 24, 48


def _stage_cap(m: Model, max_stages: int, points: int) -> int | None:
    """``max_stages`` lowered so that the curve's points fit in the memory available, or
    None where the stages asked for fit (:data:`MEMORY_COPIES` copies of the points may
    live at once, in :data:`MEMORY_SHARE` of the memory).  A curve that ends before the
    lowered count is what it would be without the cap.  ValueError, in one line, where
    not even one stage fits."""
    avail = available_memory()
    if avail is None:
        return None
    budget = MEMORY_SHARE * avail / MEMORY_COPIES
    per_stage = points * POINT_BYTES + STAGE_BYTES
    if max_stages * per_stage <= budget:
        return None
    if per_stage > budget:
        raise ValueError(f"{m.name}: points_per_stage = {points:,} needs about "
                         f"{human_bytes(MEMORY_COPIES * per_stage / MEMORY_SHARE)} of memory "
                         f"and {human_bytes(avail)} is available; pass fewer points_per_stage")
    return int(budget // per_stage)


def _checked_range(m: Model, pos: str, phi: float, phi_range) -> tuple[float, float]:
    var = m.variables[pos]
    if phi_range is None:
        lo = var.lower if math.isfinite(var.lower) else phi - _DEFAULT_SPAN
        hi = var.upper if math.isfinite(var.upper) else phi + _DEFAULT_SPAN
        return float(lo), float(hi)
    lo, hi = _args.finite_range("phi_range", phi_range, m.name, ("low", "high"))
    if not lo <= phi <= hi:
        raise ValueError(f"{m.name}: phi_range {phi_range!r} must contain {pos} = {phi:g}")
    var.check(m.name, lo)
    var.check(m.name, hi)
    return lo, hi


#: How the curves are computed (the Dataset's ``method`` attribute).
METHOD = (f"exponential Gauss collocation in phi ({NODES} nodes, order {2 * NODES}) of "
          "d(omega^2)/dphi = 2 phi'' from the model's branch rows; events by classification, "
          "located on the dense output")


def _dataset(m: Model, full: dict, phi_range, max_stages: int, points: int,
             pts: np.ndarray, stages: np.ndarray, rtol: float = RTOL) -> xr.Dataset:
    pos, vel, _ = coordinate(m)
    words = remember(("phase_curve_words", m.name), m, lambda: _words(m, pos, vel))
    index = pts[:, 2].astype(np.int32)
    signs = stages[:, 0].astype(np.int8)
    u = np.maximum(pts[:, 1], 0.0)
    omega = np.where(u > 0.0, signs[index] * np.sqrt(u), 0.0)
    reasons = stages[:, 3].astype(np.int8)
    u_ends = stages[:, (2, 5)]  # at the start and the end of each stage
    omega_ends = np.where(u_ends > 0.0, stages[:, :1] * np.sqrt(np.maximum(u_ends, 0.0)),
                          0.0)
    columns = {
        "phi": pts[:, 0].copy(), "omega": omega, "omega_squared": u, "point_stage": index,
        "stage_sign": signs, "stage_start_phi": stages[:, 1].copy(),
        "stage_start_omega": omega_ends[:, 0].copy(), "stage_end_reason": reasons,
        "stage_end_phi": stages[:, 4].copy(), "stage_end_omega": omega_ends[:, 1].copy(),
    }
    # fastpath: every array is a NumPy array made here, which xarray takes as it is
    data = {name: xr.Variable(dim, columns[name], dict(attrs), fastpath=True)
            for name, (dim, attrs) in words.items()}
    data["stage_end_reason"].attrs["flag_values"] = np.array(ev.EVENT_VALUES, dtype=np.int8)
    stage = words["stage_sign"][0]
    coords = {"stage": xr.Variable(stage, np.arange(len(stages), dtype=np.int32),
                                   {"long_name": f"stage index ({vel} keeps its sign on a "
                                                 "stage)", "units": "1"}, fastpath=True)}
    last = ev.Event(int(reasons[-1]))
    attrs = {
        **cf_header(m, "phase_curve", "phasemap.phase_curve"),
        "method": METHOD,
        "end_reason": last.name.lower(),
        "end_message": ev.end_message(m, last, {pos: float(stages[-1, 4])}),
        "n_reversals": np.int32(np.count_nonzero(reasons == ev.REVERSAL)),
        "phasemap_phi_range": np.array(phi_range, dtype=float),
        "phasemap_max_stages": np.int32(max_stages),
        "phasemap_points_per_stage": np.int32(points),
        "phasemap_rtol": float(rtol),
    }
    for v in m.state:
        attrs[f"phasemap_initial_{v.name}"] = float(full[v.name])
    for v in m.params:
        attrs[f"phasemap_fixed_{v.name}"] = float(full[v.name])
    return assemble(data, coords, attrs)


def _words(m: Model, pos: str, vel: str) -> dict:
    """The dimension and attributes of each variable of the model's phase curves, made
    once per model (each Dataset takes copies of the attributes)."""
    var_phi, var_omega = m.variables[pos], m.variables[vel]
    flags = {"flag_values": None, "flag_meanings": ev.EVENT_MEANINGS}  # values: per Dataset

    def angle(name, dim):
        return dim, {"long_name": name, "units": var_phi.units}

    def rate(name, dim):
        return dim, {"long_name": name, "units": var_omega.units}

    words = {"phi": angle(var_phi.long_name, "point"), "omega": rate(var_omega.long_name, "point")}
    # the model's own symbols, for plots of a model whose coordinate is not phi
    words["phi"][1]["phasemap_symbol"] = var_phi.symbol or var_phi.name
    words["omega"][1]["phasemap_symbol"] = var_omega.symbol or var_omega.name
    return words | {
        "omega_squared": ("point", {"long_name": f"square of the {var_omega.long_name}",
                                    "units": squared_units(var_omega.units)}),
        "point_stage": ("point", {"long_name": "index of the stage the point belongs to",
                                  "units": "1"}),
        "stage_sign": ("stage", {"long_name": f"sign of {vel} on the stage (0: no motion)",
                                 "units": "1"}),
        "stage_start_phi": angle(f"{var_phi.long_name} at the start of the stage", "stage"),
        "stage_start_omega": rate(f"{var_omega.long_name} at the start of the stage",
                                  "stage"),
        "stage_end_reason": ("stage", {"long_name": "event that ends the stage", **flags}),
        "stage_end_phi": angle(f"{var_phi.long_name} at the end of the stage", "stage"),
        "stage_end_omega": rate(f"{var_omega.long_name} at the end of the stage", "stage"),
    }
