r"""Study: Painleve's elliptic pendulum (Lapshin 2021, Fig. 3, eq. (16)-(28)).

A slider on a rough two-sided horizontal guide carries a pendulum.  With
F = -k f N, k = sgn(N xdot), the normal reaction solves lambda_k N = 2 m Q
(23), with Q = g + l cos(phi) omega^2 and

    lambda_k = 1 + sin^2 phi - k f sin phi cos phi.                           (26)

The paper proves lambda_k > 0, hence a unique solution, for f <= 2 (27).
Beyond, in phi in (0, pi/2), lambda_1 < 0 (28) leaves no solution for
xdot > 0 and two for xdot < 0.  This study measures:

* the solvability over (phi, f) for both slider directions at omega = 0, the
  smallest f at which a paradox cell appears (the sharp threshold 2 sqrt 2,
  where min_phi lambda_k = (3 - sqrt(1 + f^2))/2 reaches zero), and every
  cell against the closed form n = [Q lambda_s > 0] + [Q lambda_-s < 0], s = sgn xdot;
* the curve lambda_k = 0, f = (1 + sin^2 phi)/(k sin phi cos phi), in closed
  form, against the ``singular`` layer and the boundary of the paradox regions;
* the degenerate case lambda = 0: no solution unless Q = 0 too, then a
  continuum (the paper says "(22)-(23) have no solutions");
* the solvability over (phi, omega) at f = 4, where Q < 0 (a fast swing with
  the bar above the guide) swaps the no-solution and two-solution regions;
* a motion (phasemap.simulate) from a unique state that runs into a paradox,
  checked with phasemap.classify at the event and drawn on the (phi, omega) map;
* a stick-slip motion at small f, the slider's velocity exactly 0 while it sticks.

Run as ``python studies/elliptic_pendulum.py`` (:mod:`phasemap.study`).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib import patheffects
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

import phasemap
from phasemap.claims import threshold_claims
from phasemap import plot as pplot
from phasemap import study
from phasemap.study import Claim, verdict

NAME = "elliptic_pendulum"
MODEL = phasemap.get_model(NAME)
G = MODEL.variables["g"].default
L = MODEL.variables["l"].default
#: The sharp threshold: paradox regions exist iff f > 2 sqrt 2.
SHARP = 2.0 * math.sqrt(2.0)
#: The paper's sufficient condition for uniqueness (27).
PAPER = 2.0
#: Friction coefficient of the (phi, omega) maps and of the paradox motion.
F_MAP = 4.0
#: The motion that runs into a paradox: starts unique, sticks, slips, then two solutions.
PARADOX_START = {"phi": 0.0, "omega": 5.0, "xdot": 1.0, "f": F_MAP}
#: A stick-slip motion at small f.
STICK_SLIP_START = {"phi": 1.0, "omega": 0.0, "xdot": 0.0, "f": 0.3}
#: Offset either side of a root of lambda_k, where the class must differ.
EPS = 1e-6
STICK = MODEL.branches.index("stick")


# --------------------------------------------------------------------------- closed forms


def lam(phi, f, k):
    """lambda_k of (26)."""
    s, c = np.sin(phi), np.cos(phi)
    return 1.0 + s * s - k * f * s * c


def predicted_n(phi, omega, f, sigma):
    """Number of solutions for xdot of sign sigma (!= 0), from the signs in (23).

    Branch N > 0 has k = sigma and needs Q / lambda_sigma > 0 (Q = 0 counts
    here: N = 0); branch N < 0 has k = -sigma and needs Q / lambda_-sigma < 0.
    """
    q = G + L * np.cos(phi) * omega ** 2
    return ((q * lam(phi, f, sigma) > 0) | (q == 0)).astype(int) + \
        (q * lam(phi, f, -sigma) < 0).astype(int)


def lambda_zero_f(phi, k):
    """f on the curve lambda_k = 0 as a function of phi (NaN where k sin cos <= 0)."""
    s, c = np.sin(phi), np.cos(phi)
    ksc = k * s * c
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ksc > 0, (1.0 + s * s) / ksc, np.nan)


def lambda_roots(f, k):
    """The angles in (-pi, pi] where lambda_k(phi) = 0, for f > 2 sqrt 2.

    lambda_k = (3 - R cos(2 phi - k alpha))/2, R = sqrt(1 + f^2), alpha = arctan f,
    so the roots are phi = (k alpha +- arccos(3/R))/2 + n pi.
    """
    r = math.hypot(1.0, f)
    if 3.0 / r >= 1.0:
        return np.empty(0)
    alpha, beta = math.atan(f), math.acos(3.0 / r)
    base = np.array([(k * alpha + beta) / 2, (k * alpha - beta) / 2])
    roots = np.concatenate([base, base + math.pi, base - math.pi])
    return np.sort(roots[(roots > -math.pi) & (roots <= math.pi)])


# --------------------------------------------------------------------------- measurements


def threshold_maps(quick, out, files):
    """n_solutions over (phi, f) at omega = 0, both slider directions."""
    n_phi, n_f = (721, 2401) if quick else (2881, 9601)
    axes = {"phi": np.linspace(-math.pi, math.pi, n_phi), "f": np.linspace(0.0, 6.0, n_f)}
    maps = {}
    for xdot, side in ((1.0, "right"), (-1.0, "left")):
        ds = phasemap.Scene(NAME, axes=axes, fixed={"xdot": xdot, "omega": 0.0},
                            layers=["n_solutions", "singular"]).compute(progress=not quick)
        files.append(study.save_atlas(ds, out, f"{NAME}_threshold_{side}", NAME))
        maps[side] = ds
    return maps


def first_paradox(ds, code):
    """Smallest f of the atlas with a cell of class ``code`` (inf if none)."""
    hit = (ds.n_solutions == code).any("phi").values
    return float(ds.f.values[np.argmax(hit)]) if hit.any() else math.inf


def mismatches(ds, sigma):
    """Cells whose n_solutions differs from the closed form (cells on lambda = 0 aside)."""
    phi = ds.phi.values[:, None]
    f = ds.f.values[None, :] if "f" in ds.dims else ds.attrs["phasemap_fixed_f"]
    omega = ds.omega.values[None, :] if "omega" in ds.dims else 0.0
    n = ds.n_solutions.transpose("phi", ...).values
    pred = predicted_n(phi, omega, f, sigma)
    pred = np.broadcast_to(pred, n.shape)
    tie = np.broadcast_to((np.abs(lam(phi, f, 1.0)) < 1e-9) | (np.abs(lam(phi, f, -1.0)) < 1e-9),
                          n.shape)
    return int(((n != pred) & ~tie).sum()), pred


def lambda_zero_atlas(quick, out, files):
    """The singular layer on the closed-form roots of lambda_k = 0, and either side of them."""
    fs = np.linspace(2.9, 6.0, 16 if quick else 64)
    roots = {(i, k): lambda_roots(f, k) for i, f in enumerate(fs) for k in (1.0, -1.0)}
    centre = np.concatenate(list(roots.values()))
    phi = np.sort(np.concatenate([centre - EPS, centre, centre + EPS]))
    ds = phasemap.Scene(NAME, axes={"phi": phi, "f": fs}, fixed={"xdot": 1.0, "omega": 0.0},
                        layers=["n_solutions", "singular"]).compute()
    files.append(study.save_atlas(ds, out, f"{NAME}_lambda_zero", NAME))
    expected = np.zeros((phi.size, fs.size), dtype=bool)
    changes = total = 0
    n = ds.n_solutions.transpose("phi", "f").values
    for (i, _k), rs in roots.items():
        for r in rs:
            j = int(np.searchsorted(phi, r))
            expected[j, i] = True
            total += 1
            changes += int(n[j - 1, i] != n[j + 1, i])
    singular = ds.singular.transpose("phi", "f").values == 1
    return {"on": int((singular & expected).sum()), "total": total,
            "off": int((singular & ~expected).sum()), "changes": changes}


def degenerate_case():
    """Classify on lambda_k = 0: the lambda = 0 branch with Q != 0 and with Q = 0."""
    none = none_total = cont = cont_total = 0
    for f in np.linspace(2.9, 6.0, 32):
        for k in (1.0, -1.0):
            for phi in lambda_roots(f, k):
                for xdot in (1.0, -1.0):
                    c = phasemap.classify(NAME, phi=phi, omega=0.0, xdot=xdot, f=f)
                    zero = [b for b in c.candidates if b.singular]
                    none_total += 1
                    none += int(c.singular and len(zero) == 1
                                and zero[0].status is phasemap.BranchStatus.NO_SOLUTION)
                    if math.cos(phi) < 0:  # Q = 0 needs cos phi < 0
                        for sign in (1.0, -1.0):
                            omega = sign * math.sqrt(-G / (L * math.cos(phi)))
                            c = phasemap.classify(NAME, phi=phi, omega=omega, xdot=xdot, f=f)
                            cont_total += 1
                            cont += int(c.singular and c.solvability is
                                        phasemap.Solvability.CONTINUUM)
    return none, none_total, cont, cont_total


def phi_omega_maps(quick, out, files):
    """n_solutions over (phi, omega) at f = 4, both slider directions."""
    n_phi, n_om = (361, 321) if quick else (1441, 1281)
    axes = {"phi": np.linspace(-math.pi, math.pi, n_phi), "omega": np.linspace(-8.0, 8.0, n_om)}
    maps = {}
    for xdot, side in ((1.0, "right"), (-1.0, "left")):
        ds = phasemap.Scene(NAME, axes=axes, fixed={"xdot": xdot, "f": F_MAP},
                            layers=["n_solutions", "singular"]).compute()
        files.append(study.save_atlas(ds, out, f"{NAME}_phi_omega_{side}", NAME))
        maps[side] = ds
    return maps


def paradox_motion(out, files):
    """A motion that runs into a paradox; the event state classified."""
    t_end = 2.0
    # t_eval stops short of t_end: simulate labels a point at t_end itself with branch -1
    # dense near t = 0, where the slider comes to a stick within a few milliseconds
    t_eval = np.union1d(np.linspace(0.0, 0.01, 201), np.linspace(0.0, t_end - 1e-3, 2000))
    ds = phasemap.simulate(NAME, t_end=t_end, rtol=1e-10, t_eval=t_eval, **PARADOX_START)
    files.append(study.save_atlas(ds, out, f"{NAME}_paradox_motion", NAME))
    start = phasemap.classify(NAME, **PARADOX_START)
    end = {n: float(ds[f"event_{n}"][-1]) for n in ("phi", "omega", "xdot")}
    at_event = phasemap.classify(NAME, f=PARADOX_START["f"], **end)
    return ds, start, at_event


def stick_slip_motion(out, files):
    """A stick-slip motion at small f; the slider's velocity where it sticks, and classify there."""
    t_end = 4.0
    ds = phasemap.simulate(NAME, t_end=t_end + 1e-3, rtol=1e-10,
                           t_eval=np.linspace(0.0, t_end, 2001), **STICK_SLIP_START)
    files.append(study.save_atlas(ds, out, f"{NAME}_stick_slip", NAME))
    sticking = ds.branch.values == STICK
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    checked = np.flatnonzero(sticking)[::10]
    admissible = sum(
        phasemap.classify(NAME, phi=float(ds.phi[i]), omega=float(ds.omega[i]),
                          xdot=float(ds.xdot[i]), f=STICK_SLIP_START["f"]).stagnation
        for i in checked)
    return ds, {"max_xdot": float(np.abs(ds.xdot.values[sticking]).max()),
                "phases": kinds.count("stick") + int(kinds[0] == "start" and sticking[0]),
                "slips": kinds.count("slip"),
                "admissible": int(admissible), "checked": int(checked.size)}


# --------------------------------------------------------------------------- figures

#: The reference curves: black, told apart by their dashes (pplot.DASHES), haloed in white.
_REF = {"color": "black", "lw": 0.9, "path_effects": pplot.HALO}
LAMBDA_STYLE = {1.0: {**_REF, "ls": pplot.DASHES[0]}, -1.0: {**_REF, "ls": pplot.DASHES[1]}}
SHARP_STYLE = {**_REF, "lw": 1.1, "ls": pplot.DASHES[3]}
PAPER_STYLE = {**_REF, "lw": 1.1, "ls": pplot.DASHES[2]}
#: The symbols the legends use.
KEY = [r"$\lambda_k = 1 + \sin^2\varphi - k f\,\sin\varphi\,\cos\varphi$, the coefficient of "
       r"$N$ in (23)", r"$k = \mathrm{sgn}(N\dot x)$: $\lambda_{+1}$ for $N\dot x > 0$, "
       r"$\lambda_{-1}$ for $N\dot x < 0$", r"$\lambda_k = 0$ is the singular set"]
Q_STYLE = {**_REF, "ls": pplot.DASHES[4]}
#: The motion drawn over a map: a thick black line on a white halo.
MOTION_STYLE = {"color": "black", "lw": 1.6,
                "path_effects": [patheffects.withStroke(linewidth=3.2, foreground="white"),
                                 patheffects.Normal()]}
#: The slider's stick phases: the stagnation look (hatched), in time.
STICK_LABEL = r"stagnation: the slider sticks ($\dot x \equiv 0$)"


def _thin(ds, limit=700):
    """Every k-th cell along each axis so a figure draws at most ``limit`` per axis."""
    return ds.isel({d: slice(None, None, max(1, -(-ds.sizes[d] // limit))) for d in ds.dims})


def _category_handles(ax):
    """The category patches map_figure put in its legend above ``ax``; the legend removed."""
    leg = ax.get_legend()
    handles = list(leg.legend_handles)
    for h, t in zip(handles, leg.get_texts()):
        h.set_label(t.get_text())
    leg.remove()
    return handles


def _two_panel(maps, x, height, size):
    """The maps for xdot > 0 and xdot < 0: side by side at two-column width, else stacked."""
    fig, axes = pplot.panels(2, size, height=height, panel_height=2.2, extra=2.0,
                             sharex=True, sharey=True)
    handles = {}
    for k, (ax, side, title) in enumerate(zip(axes, ("right", "left"),
                                              (r"$\dot x > 0$", r"$\dot x < 0$"))):
        ds = maps[side]
        # the singular set lambda_k = 0 is drawn as the curves it is (closed form), not as
        # the few cells of the grid that happen to lie on it
        pplot.map_figure(_thin(ds.drop_vars("singular")), "n_solutions", x=x, ax=ax)
        for h in _category_handles(ax):
            handles.setdefault(h.get_label(), h)
        ax.set_title(f"({'ab'[k]}) {title}", loc="left")
    pplot.outer_labels(axes)
    order = ["none", "unique", "two", "continuum"]
    return fig, axes, [handles[k] for k in order if k in handles]


def _fixed(ds, fig, more=""):
    """What the maps held fixed (xdot differs between the panels: only its sign matters),
    and ``more``, wrapped to the width of ``fig``."""
    items = pplot.fixed_values(ds.drop_attrs().assign_attrs(
        {k: v for k, v in ds.attrs.items() if k != "phasemap_fixed_xdot"}))
    if more:
        items[-1] += ";"
        items.append(more)
    return pplot.wrap(items, 0.95 * fig.get_figwidth()).replace(";,", ";")


def _columns(size, wide: int) -> int | None:
    """``wide`` legend columns at two-column width; as many as fit otherwise."""
    return wide if pplot.width_of(size) >= pplot.WIDE else None


def figure_phi_f(maps, size="two_column"):
    """Solvability over (phi, f) with the lambda = 0 curves and the two thresholds."""
    with pplot.style():
        fig, axes, cats = _two_panel(maps, "phi", 3.1, size)
        phi = np.linspace(-math.pi, math.pi, 4001)
        for ax in axes:
            for k, st in LAMBDA_STYLE.items():
                ax.plot(phi, lambda_zero_f(phi, k), **st)
            ax.axhline(SHARP, **SHARP_STYLE)
            ax.axhline(PAPER, **PAPER_STYLE)
            ax.set_ylim(0.0, 6.0)
        lines = [Line2D([], [], label=r"$\lambda_{+1} = 0$ (singular)", **LAMBDA_STYLE[1.0]),
                 Line2D([], [], label=r"$\lambda_{-1} = 0$ (singular)", **LAMBDA_STYLE[-1.0]),
                 Line2D([], [], label=r"$f = 2\sqrt{2}$ (sharp)", **SHARP_STYLE),
                 Line2D([], [], label=r"$f = 2$ (paper, sufficient)", **PAPER_STYLE)]
        handles = cats + lines
        pplot.figure_legend(fig, handles, ncols=_columns(size, 4),
                            title=_fixed(maps["right"], fig))
        pplot.define_symbols(fig, KEY)
    return fig


def _wrapped(phi, *ys):
    """phi wrapped into (-pi, pi], with NaN breaks where it jumps."""
    w = np.angle(np.exp(1j * np.asarray(phi)))
    jump = np.flatnonzero(np.abs(np.diff(w)) > math.pi) + 1
    out = [np.insert(w, jump, np.nan)]
    out += [np.insert(np.asarray(y, float), jump, np.nan) for y in ys]
    return out


def figure_phi_omega(maps, motion, size="two_column"):
    """Solvability over (phi, omega) at f = 4, with the paradox motion on the xdot > 0 map."""
    with pplot.style():
        fig, axes, cats = _two_panel(maps, "phi", 3.1, size)
        phi = np.linspace(-math.pi, math.pi, 4001)
        with np.errstate(invalid="ignore"):
            w = np.sqrt(-G / (L * np.cos(phi)))
        for ax in axes:
            for k, st in LAMBDA_STYLE.items():
                for r in lambda_roots(F_MAP, k):
                    ax.axvline(r, **st)
            ax.plot(phi, w, **Q_STYLE)
            ax.plot(phi, -w, **Q_STYLE)
            ax.set_ylim(-8.0, 8.0)
        # the motion while the slider slides right (xdot > 0: this map); while it sticks
        # (xdot = 0) the state is on neither map: the path breaks there, and the stick and
        # slip events mark where it leaves the map and comes back
        ax = axes[0]
        stick = motion.branch.values == STICK
        x, y = _wrapped(np.where(stick, np.nan, motion.phi.values),
                        np.where(stick, np.nan, motion.omega.values))
        ax.plot(x, y, zorder=5, **MOTION_STYLE)
        kinds = [phasemap.Event(int(k)).name.lower() for k in motion.event_kind.values]
        for kind in ("stick", "slip"):
            at = [i for i, k in enumerate(kinds) if k == kind]
            pplot.mark_event(ax, kind, *_wrapped(motion.event_phi.values[at],
                                                 motion.event_omega.values[at]))
        kind = kinds[-1]
        pplot.mark_event(ax, kind, *_wrapped([float(motion.event_phi[-1])],
                                             [float(motion.event_omega[-1])]))
        pplot.mark_event(ax, "start", *_wrapped([float(motion.phi[0])],
                                                [float(motion.omega[0])]))
        # the first stick lies within a marker of the start: the start's ring is drawn
        # over the stick's square, whole
        ax.lines[-1].set_zorder(8)
        lines = [Line2D([], [], label=r"$\lambda_{+1} = 0$ (singular)", **LAMBDA_STYLE[1.0]),
                 Line2D([], [], label=r"$\lambda_{-1} = 0$ (singular)", **LAMBDA_STYLE[-1.0]),
                 Line2D([], [], label=r"$g + l\cos\varphi\,\omega^2 = 0$", **Q_STYLE),
                 Line2D([], [], label=r"motion, sliding ($\dot x > 0$)", **MOTION_STYLE),
                 pplot.event_handle("start"),
                 pplot.event_handle("stick", r"stick: leaves the map ($\dot x = 0$)"),
                 pplot.event_handle("slip", "slip: back on the map"),
                 pplot.event_handle(kind)]
        handles = cats + lines
        start = [t for t in pplot.fixed_values(motion) if "_0$" in t]
        pplot.figure_legend(fig, handles, ncols=_columns(size, 4), title=_fixed(
            maps["right"], fig, "the motion from " + ", ".join(start)))
        pplot.define_symbols(fig, KEY)
    return fig


def figure_motion(ds, states, inset: float | None = None, size="two_column"):
    """A trajectory with its events marked and the slider's stick phases hatched.

    ``inset``: a panel more, below, of the first state over [0, inset] s, for
    a stick phase that starts too soon after t = 0 to be seen at the scale of
    the motion.
    """
    import matplotlib.pyplot as plt

    stick = ds.branch.values == STICK
    t = ds.t.values
    edges = np.flatnonzero(np.diff(np.r_[0, stick.astype(int), 0]))
    width = pplot.width_of(size)
    n = len(states)
    with pplot.style():
        fig = plt.figure(figsize=(width, 1.3 + 1.1 * (n + (1 if inset else 0))),
                         layout="constrained")
        grid = fig.add_gridspec(n + (1 if inset else 0), 1)
        axes = [fig.add_subplot(grid[0])]
        axes += [fig.add_subplot(grid[i], sharex=axes[0]) for i in range(1, n)]
        pplot.trajectory_figure(ds, states=states, ax=axes, size=size)
        for ax in axes:
            for a, b in zip(edges[::2], edges[1::2]):
                pplot.stagnation_span(ax, t[a], t[b - 1])
            # room for the markers at the top and bottom, inside the hatched band's height
            ax.margins(y=0.12)
        ax = axes[0]
        leg = ax.get_legend()
        handles = list(leg.legend_handles)
        for h, txt in zip(handles, leg.get_texts()):
            h.set_label(txt.get_text())
        handles.append(pplot.stagnation_patch(STICK_LABEL))
        leg.remove()
        pplot.figure_legend(fig, handles, title=pplot.fixed_values_text(ds, 0.95 * width),
                            ncols=_columns(size, 4))
        if inset:
            zoom = fig.add_subplot(grid[n])
            _zoom(zoom, ds, states[0], inset, stick)
            axes.append(zoom)
        for a in axes:
            a.set_title("", loc="left")
        pplot.label_panels(axes)
        if inset:
            zoom.set_title(f"(d) the first {inset * 1e3:g} ms", loc="left")
    return fig


def _zoom(zoom, ds, name, t_max, stick):
    """``name`` over the first ``t_max`` seconds, time in ms, events marked."""
    sel = ds.t.values <= t_max
    t_ms = ds.t.values[sel] * 1e3
    edges = np.flatnonzero(np.diff(np.r_[0, stick[sel].astype(int), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        pplot.stagnation_span(zoom, t_ms[a], t_ms[min(b, t_ms.size - 1)])
    zoom.plot(t_ms, ds[name].values[sel], color="black", lw=1.0)
    kinds = [phasemap.Event(int(k)).name.lower() for k in ds.event_kind.values]
    for k, te, ye in zip(kinds, ds.event_t.values, ds[f"event_{name}"].values):
        if k not in ("start", "horizon") and te <= t_max:
            pplot.mark_event(zoom, k, te * 1e3, ye)
    zoom.set_xlim(0.0, t_max * 1e3)
    zoom.set_xlabel(r"$t$ (ms)")
    zoom.set_ylabel(pplot.axis_label(ds, name))
    zoom.yaxis.set_major_locator(MaxNLocator(nbins=4, min_n_ticks=3))


# --------------------------------------------------------------------------- the study


def main(argv=None) -> list[Claim]:
    args = study.arguments(__doc__, argv)
    out, quick, files, claims = args.out, args.quick, [], []

    # 1. the threshold, and every cell of the (phi, f) maps against the closed form
    maps = threshold_maps(quick, out, files)
    df = float(np.diff(maps["right"].f.values)[0])
    first_none = first_paradox(maps["right"], 0)
    first_two = first_paradox(maps["left"], 2)
    below_paper = all(bool((m.n_solutions.sel(f=slice(None, PAPER)) == 1).all())
                      for m in maps.values())
    sharp = all(SHARP < x <= SHARP + df for x in (first_none, first_two))
    claims.append(Claim(
        "unique solution for f <= 2 (27)", "f <= 2 (sufficient)",
        f"f < 2 sqrt 2 = {SHARP:.4f}: first none, two at f = {first_none:.4f}, "
        f"{first_two:.4f} (step {df:.4f})",
        verdict(below_paper and sharp, "sharper")))
    for side, sigma, code, word in (("right", 1.0, 0, "none"), ("left", -1.0, 2, "two")):
        ds = maps[side]
        bad, _ = mismatches(ds, sigma)
        phi, f = study.mesh(ds, "phi", "f")
        region = (lam(phi, f, 1.0) < 0) & (phi > 0) & (phi < math.pi / 2)
        n = ds.n_solutions.transpose("phi", "f").values
        hit = int((region & (n == code)).sum())
        claims.append(Claim(
            f"xdot {'>' if sigma > 0 else '<'} 0, lambda_1 < 0 (28)",
            "no solution" if code == 0 else "two solutions",
            f"{word} on {hit}/{int(region.sum())} cells; {bad} cells off the closed form",
            verdict(region.any() and hit == region.sum() and bad == 0)))

    # 2. the lambda = 0 curve: singular layer and boundary of the paradox regions
    z = lambda_zero_atlas(quick, out, files)
    claims.append(Claim(
        "lambda_k = 0 bounds the paradox regions", "degeneration at lambda = 0",
        f"singular at {z['on']}/{z['total']} roots, {z['off']} elsewhere; class flips at "
        f"{z['changes']}/{z['total']}",
        verdict(z["on"] == z["total"] > 0 and z["off"] == 0 and z["changes"] == z["total"])))

    # 3. the degenerate case: (23)-(25) at lambda = 0
    none, none_total, cont, cont_total = degenerate_case()
    claims.append(Claim(
        "lambda = 0 (text after (28))", "(22)-(23) have no solutions",
        f"(23)-(25): none if Q != 0 ({none}/{none_total}), continuum if Q = 0 "
        f"({cont}/{cont_total})",
        verdict(none == none_total > 0 and cont == cont_total > 0, "erratum")))

    # 4. (phi, omega) at f = 4: Q < 0 swaps the paradoxes
    pmaps = phi_omega_maps(quick, out, files)
    counts, bad_total, cells = {}, 0, 0
    for side, sigma in (("right", 1.0), ("left", -1.0)):
        ds = pmaps[side]
        bad, _ = mismatches(ds, sigma)
        bad_total += bad
        cells += ds.n_solutions.size
        q = G + L * np.cos(ds.phi.values[:, None]) * ds.omega.values[None, :] ** 2
        n = ds.n_solutions.transpose("phi", "omega").values
        counts[side] = (int(((q < 0) & (n == 2)).sum()), int(((q < 0) & (n == 0)).sum()))
    swapped = counts["right"][0] > 0 and counts["left"][1] > 0
    claims.append(Claim(
        f"Q = g + l cos(phi) omega^2 < 0, f = {F_MAP:g}", "(phi in (0, pi/2) only)",
        f"none, two swap on {counts['right'][0]}, {counts['left'][1]} cells; "
        f"{bad_total}/{cells} off the closed form",
        verdict(swapped and bad_total == 0, "finding")))

    # 5. a motion into a paradox
    motion, start, at_event = paradox_motion(out, files)
    reason = motion.attrs["end_reason"]
    ok = (start.n_solutions == 1 and reason in ("no_solution", "indeterminate")
          and at_event.n_solutions == (0 if reason == "no_solution" else 2))
    claims.append(Claim(
        "a motion from a unique state hits a paradox", "(not discussed)",
        f"{reason} at t = {float(motion.event_t[-1]):.4f} s, phi = "
        f"{float(motion.event_phi[-1]):.4f}; classify: {at_event.n_solutions} solutions",
        verdict(ok, "finding")))

    # 6. stick-slip at small f
    slip_ds, s = stick_slip_motion(out, files)
    claims.append(Claim(
        "at v = 0 sliding can cease (after (5))", "stagnation, |F| <= f|N|",
        f"f = {STICK_SLIP_START['f']:g}: {s['phases']} stick phases, max |xdot| = "
        f"{s['max_xdot']:g}; stick admissible {s['admissible']}/{s['checked']}",
        verdict(s["phases"] >= 2 and s["slips"] >= 1 and s["max_xdot"] == 0.0
                and s["admissible"] == s["checked"] > 0)))

    # figures
    sizes = args.sizes
    files += study.save_figures(lambda size: figure_phi_f(maps, size), out, f"{NAME}_phi_f",
                                sizes)
    files += study.save_figures(lambda size: figure_phi_omega(pmaps, motion, size), out,
                                f"{NAME}_phi_omega", sizes)
    files += study.save_figures(lambda size: figure_motion(
        motion, ["xdot", "phi", "omega"], inset=0.01, size=size), out,
        f"{NAME}_paradox_motion", sizes)
    files += study.save_figures(lambda size: figure_motion(slip_ds, ["xdot", "x", "phi"],
                                                           size=size), out,
                                f"{NAME}_stick_slip", sizes)

    claims += threshold_claims("elliptic_pendulum")  # exact, beside the closed form
    study.finish("Painleve's elliptic pendulum", claims, files)
    return claims


if __name__ == "__main__":
    main()
