r"""Study: the pendulum with dry friction in its hinge (Lapshin 2021, Fig. 4, eq. (29)-(36)).

A point mass m on a weightless rod of length l; the hinge friction moment is
M = -delta |R| sgn(omega) (29), with R the hinge reaction and delta a length.
Squaring the implicit equation (32) gives (33), whose coefficient of the
senior derivative is l^2 - delta^2.  This study measures, with l = 1 m (so
the delta axes read delta/l):

* the stagnation zone over (phi, delta/l) at rest against the paper's (35),
  |tan phi| <= delta / sqrt(l^2 - delta^2), and its equivalent l |sin phi| <= delta,
  which holds for delta >= l too;
* solvability for delta > l in motion: no solution except on the curve
  l omega^2 + g cos phi = 0, where the hinge reaction vanishes and the free
  motion l phi'' = -g sin phi is the unique solution (a continuum at delta = l);
  and the two solutions at rest at phi = +-pi/2 for delta > l;
* phase curves (phasemap.phase_curve) from several amplitudes, swings decaying
  to rest inside the zone;
* the weightless pendulum g = 0 (phasemap.simulate) against its exact solution (36);
* a fate map over the initial state (phi0, omega0).

Run as ``python studies/hinge_pendulum.py`` (:mod:`phasemap.study`).
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import to_hex
from matplotlib.lines import Line2D

import phasemap
from phasemap.claims import threshold_claims
from phasemap import plot as pplot
from phasemap import study
from phasemap.systems.hinge_pendulum import weightless_motion
from phasemap.study import Claim, verdict

NAME = "hinge_pendulum"
MODEL = phasemap.get_model(NAME)
G = MODEL.variables["g"].default
L = 1.0
#: delta of the phase curves, the fate map and the weightless motion.
DELTA = MODEL.variables["delta"].default
DELTA_WEIGHTLESS = 0.3
#: Angular velocity of the (phi, delta) map in motion, and delta of the (phi, omega) map.
OMEGA_MOVING = 2.0
DELTA_ABOVE = 1.5
#: Initial states of the phase curves: (phi0, omega0).
SWINGS = ((1.0, 0.0), (2.0, 0.0), (3.0, 0.0), (0.0, 8.0))
#: Initial states of the weightless motions: (phi0, omega0).
WEIGHTLESS = ((0.0, 5.0), (1.0, -3.0))
#: Time horizon of the fate map (s).
T_FATE = 40.0
DELTA_LABEL = r"$\delta/l$"
#: What delta and l are, for the key under a figure.
DELTA_KEY = [r"$\delta$: radius of the hinge's friction circle (friction moment "
             r"$\delta|R|$)", r"$l$: rod length"]
#: The looks of the phase curves (and of the weightless runs), one per start: a colour
#: none of the study's classes fills, and a dash pattern, so that greyscale tells them apart.
CURVE_LOOKS = [{"color": pplot.OKABE_ITO[c], "ls": pplot.DASHES[i]}
               for i, c in enumerate(("blue", "orange", "black", "sky_blue"))]
#: The curve l omega^2 + g cos phi = 0 (the hinge reaction vanishes): a reference curve.
FREE_STYLE = {"color": "black", "lw": 1.4, "ls": pplot.DASHES[1], "path_effects": pplot.HALO}


def free_angle(omega):
    """The angles in (-pi, pi] where l omega^2 + g cos phi = 0 (the hinge reaction vanishes)."""
    c = -L * omega ** 2 / G
    return () if abs(c) > 1 else (-math.acos(c), math.acos(c))


def _signed(x):
    """``x`` for a label, with a typographic minus."""
    return f"{x:g}".replace("-", "\u2212")


def zone_35(phi, delta):
    """The paper's (35) for delta < l: |tan phi| <= delta / sqrt(l^2 - delta^2)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(np.tan(phi)) <= delta / np.sqrt(L * L - delta * delta)


# --------------------------------------------------------------------------- measurements


def delta_axis(quick):
    """delta/l from 0 to 1.5 with delta = l exactly on the grid."""
    d = np.linspace(0.0, 1.5 * L, 151 if quick else 601)
    assert np.any(d == L)
    return d


def phi_axis(quick, extra=()):
    """phi in [-pi, pi] plus ``extra`` angles exactly."""
    return np.unique(np.r_[np.linspace(-math.pi, math.pi, 361 if quick else 1441), list(extra)])


def rest_map(quick, out, files):
    """Solvability and stagnation over (phi, delta/l) at rest, phi = +-pi/2 on the grid."""
    phi = phi_axis(quick, (math.pi / 2, -math.pi / 2))
    ds = phasemap.Scene(NAME, axes={"phi": phi, "delta": delta_axis(quick)},
                        fixed={"omega": 0.0, "l": L},
                        layers=["n_solutions", "stagnation", "singular"]).compute()
    files.append(study.save_atlas(ds, out, f"{NAME}_rest", NAME))
    return ds


def moving_maps(quick, out, files):
    """Solvability in motion: over (phi, delta/l) at omega = 2, (phi, omega) at delta/l = 1.5."""
    angles = free_angle(OMEGA_MOVING)
    by_delta = phasemap.Scene(
        NAME, axes={"phi": phi_axis(quick, angles), "delta": delta_axis(quick)},
        fixed={"omega": OMEGA_MOVING, "l": L},
        layers=["n_solutions", "singular", "phi_ddot_turn_pos", "R_n_turn_pos"]).compute()
    files.append(study.save_atlas(by_delta, out, f"{NAME}_moving_phi_delta", NAME))
    n_om = 200 if quick else 800  # even: omega = 0 (rest) is not on this grid
    by_omega = phasemap.Scene(
        NAME, axes={"phi": phi_axis(quick), "omega": np.linspace(-6.0, 6.0, n_om)},
        fixed={"delta": DELTA_ABOVE, "l": L}, layers=["n_solutions"]).compute()
    files.append(study.save_atlas(by_omega, out, f"{NAME}_phi_omega_delta_above_l", NAME))
    return by_delta, by_omega


def phase_curves(out, files):
    """Phase curves from each of SWINGS at delta/l = 0.1, to their fate."""
    curves = []
    for i, (phi0, omega0) in enumerate(SWINGS):
        ds = phasemap.phase_curve(NAME, phi=phi0, omega=omega0, delta=DELTA, l=L)
        files.append(study.save_atlas(ds, out, f"{NAME}_phase_curve_{i}", NAME))
        curves.append(ds)
    return curves


def weightless(out, files):
    """The weightless pendulum (g = 0) from each of WEIGHTLESS, tightly integrated."""
    t_end = 10.0
    runs = []
    for i, (phi0, omega0) in enumerate(WEIGHTLESS):
        ds = phasemap.simulate(NAME, t_end=t_end, rtol=1e-10, phi=phi0, omega=omega0,
                               delta=DELTA_WEIGHTLESS, l=L, g=0.0)
        files.append(study.save_atlas(ds, out, f"{NAME}_weightless_{i}", NAME))
        runs.append(ds)
    return runs


def fate_map(quick, out, files):
    """Fate, rest angle and number of swings from every (phi0, omega0) of a grid."""
    n = 241 if quick else 481  # odd: phi = 0 on the grid; a cell under 3 px at 300 dpi
    ds = phasemap.Scene(NAME, axes={"phi": np.linspace(-math.pi, math.pi, n),
                                    "omega": np.linspace(-9.0, 9.0, n)},
                        fixed={"delta": DELTA, "l": L},
                        layers=["fate", "phi_rest", "n_reversals"],
                        options={"t_end": T_FATE}).compute(progress=not quick)
    files.append(study.save_atlas(ds, out, f"{NAME}_fates", NAME))
    return ds


# --------------------------------------------------------------------------- figures


def _zone_bands(ax, lo, hi, delta):
    """Hatch l |sin phi| <= delta (stagnation) around every multiple of pi in [lo, hi]."""
    half = math.asin(min(delta / L, 1.0))
    for k in range(math.floor(lo / math.pi) - 1, math.ceil(hi / math.pi) + 2):
        pplot.stagnation_span(ax, k * math.pi - half, k * math.pi + half)


def _wide(size) -> bool:
    return pplot.width_of(size) >= pplot.WIDE


def figure_rest(ds, size="two_column"):
    """Stagnation over (phi, delta/l) with the closed-form boundary l |sin phi| = delta;
    off the zone the motion is unique (checked here), so the plain class is named so."""
    n = ds.n_solutions.values[ds.stagnation.values == 0]
    if not np.all(n == 1):
        raise AssertionError("a state at rest off the stagnation zone is not unique")
    with pplot.style():
        fig = pplot.map_figure(ds, "stagnation", x="phi", overlays=False, size=size)
        ax = fig.axes[0]
        phi = np.linspace(-math.pi, math.pi, 2001)
        ax.plot(phi, L * np.abs(np.sin(phi)), color="black", lw=1.0)
        ax.axhline(L, color="black", lw=0.8, ls=pplot.DASHES[1])
        ax.set_ylabel(DELTA_LABEL)
        leg = ax.get_legend()
        cats = list(leg.legend_handles)
        for h, t in zip(cats, leg.get_texts()):
            # the plain class reads as in the study's other maps
            h.set_label({"no stagnation": "unique (no stagnation)"}.get(t.get_text(),
                                                                         t.get_text()))
        handles = cats + [
            Line2D([], [], color="black", lw=1.0, label=r"$l|\sin\varphi| = \delta$, i.e. (35)"),
            Line2D([], [], color="black", lw=0.8, ls=pplot.DASHES[1],
                   label=r"$\delta = l$: singular")]
        pplot.legend_above(ax, handles, title=pplot.fixed_values_text(
            ds, 0.9 * fig.get_figwidth()), ncols=2)
        pplot.define_symbols(fig, DELTA_KEY)
    return fig


def figure_moving(by_delta, by_omega, size="two_column"):
    """No solution for delta > l, except where l omega^2 + g cos phi = 0.

    One panel over (phi, delta/l) at omega = 2 rad/s.  The map over (phi,
    omega) at delta/l = 1.5 is one class (none) but for that curve, where the
    hinge reaction vanishes; the key says so rather than drawing a panel of
    one colour (the study checks every cell of it).

    No ``boundaries=True``: the only piece phasemap.boundaries traces on this
    slice is delta = l (a grid row, drawn already as the singular line); the
    curve where R = 0 is a line of cells, not a region's edge, and is drawn
    from its closed form.  Tracing would redraw delta = l at the cost of
    compiling the tracer (about 40 s with empty caches, as CI runs).
    """
    cont = pplot.CATEGORY_COLOURS["continuum"]
    with pplot.style():
        fig = pplot.map_figure(by_delta, "n_solutions", x="phi", size=size)
        ax = fig.axes[0]
        leg = ax.get_legend()
        handles = {}
        for h, t in zip(leg.legend_handles, leg.get_texts()):
            h.set_label(t.get_text())
            handles[t.get_text()] = h
        angles = free_angle(OMEGA_MOVING)
        for a in angles:
            ax.plot([a, a], [L, by_delta.delta.values[-1]], solid_capstyle="butt",
                    **FREE_STYLE)
        ax.plot(angles, [L] * len(angles), ls="none", marker="*", ms=8, mfc=cont, mec="black",
                mew=0.5, zorder=6, clip_on=False)
        ax.set_ylabel(DELTA_LABEL)
        cats = [handles[k] for k in ("none", "unique", "continuum") if k in handles]
        cats += [h for k, h in handles.items() if k.startswith("singular")]
        items = cats + [
            Line2D([], [], label=r"$l\omega^2 + g\cos\varphi = 0$: unique ($R = 0$)",
                   **FREE_STYLE),
            Line2D([], [], ls="none", marker="*", ms=8, mfc=cont, mec="black", mew=0.5,
                   label=r"continuum ($\delta = l$ on that curve)")]
        pplot.legend_above(ax, items, title=pplot.fixed_values_text(
            by_delta, 0.9 * fig.get_figwidth()), ncols=2 if _wide(size) else 1)
        pplot.define_symbols(fig, DELTA_KEY + [
            rf"not drawn: at $\delta/l$ = {DELTA_ABOVE / L:g}, none at every $\omega \neq 0$ "
            r"but on $l\omega^2 + g\cos\varphi = 0$ (each cell checked)"])
    return fig


def figure_phase(curves, size="two_column"):
    """The phase curves (a), and (b) the zone at phi = 0 enlarged, where three of them come
    to rest within 0.1 rad of each other (their rest squares would overlap in (a): there
    they are left to (b), whose window (a) outlines)."""
    with pplot.style():
        width = pplot.width_of(size)
        if _wide(size):
            fig, (ax, zoom) = plt.subplots(1, 2, figsize=(width, 3.2), layout="constrained",
                                           width_ratios=[4.0, 1.0])
        else:
            fig, (ax, zoom) = plt.subplots(2, 1, figsize=(width, 5.6), layout="constrained",
                                           height_ratios=[2.2, 1.2])
        starts = []
        for i, ds in enumerate(curves):
            before = len(ax.lines)
            pplot.phase_curve_figure(ds, ax=ax)
            look = CURVE_LOOKS[i % len(CURVE_LOOKS)]
            phi0, omega0 = SWINGS[i]
            for line in ax.lines[before:]:
                # the curve is black and drawn with a line; the markers and zero line stay
                if line.get_linestyle() != "None" and to_hex(line.get_color()) == "#000000":
                    line.set_color(look["color"])
                    line.set_linestyle(look["ls"])
                    line.set_label(f"swing {i}")  # the same curve in (b): one look
            starts.append(Line2D([], [], lw=1.0, **look,
                                 label=rf"$\varphi_0$ = {phi0:g} rad, "
                                       rf"$\omega_0$ = {omega0:g} rad s$^{{-1}}$"))
        lo = min(float(ds.phi.min()) for ds in curves)
        hi = max(float(ds.phi.max()) for ds in curves)
        pad = 0.1
        ax.set_xlim(lo - pad, hi + pad)
        _zone_bands(ax, lo - pad, hi + pad, DELTA)
        ax.set_xlabel(r"$\varphi$ (rad)")
        leg = ax.get_legend()
        events = list(leg.legend_handles)
        for h, t in zip(events, leg.get_texts()):
            h.set_label(t.get_text())
        leg.remove()
        _zoom_on_zone(ax, zoom)
        zone = pplot.stagnation_patch(rf"stagnation: zone (35), $\delta/l$ = {DELTA / L:g}")
        head = pplot.fixed_values_text(curves[0].drop_attrs().assign_attrs(
            {k: v for k, v in curves[0].attrs.items() if "initial" not in k}), 0.95 * width)
        pplot.figure_legend(fig, starts + events + [zone], title=head,
                            ncols=4 if _wide(size) else None)
        ax.set_title("phase curves to their fates", loc="left")
        zoom.set_title(r"near $\varphi = 0$", loc="left")
        pplot.label_panels([ax, zoom])
    return fig


def _zoom_on_zone(ax, zoom):
    """Draw ``ax``'s curves and markers again in ``zoom``, on the zone at phi = 0; outline
    that window in ``ax``, joined to ``zoom``, and leave the rest markers inside it to
    ``zoom``."""
    half = math.asin(min(DELTA / L, 1.0))
    x0, x1, y0, y1 = -1.3 * half, 1.3 * half, -0.8, 0.8
    for line in ax.lines:
        x, y = line.get_data()
        offset, dashes = line._unscaled_dash_pattern  # get_linestyle() names no pattern
        zoom.plot(x, y, color=line.get_color(),
                  ls=(offset, dashes) if dashes else line.get_linestyle(),
                  lw=line.get_linewidth(), marker=line.get_marker(),
                  ms=line.get_markersize(), mfc=line.get_markerfacecolor(),
                  mec=line.get_markeredgecolor(), mew=line.get_markeredgewidth(),
                  zorder=line.get_zorder(), label=line.get_label())
        if line.get_marker() == "s":  # rest
            x, y = np.asarray(x, float), np.asarray(y, float)
            if np.all((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)):
                line.set_visible(False)
    pplot.stagnation_span(zoom, -half, half)
    zoom.set_xlim(x0, x1)
    zoom.set_ylim(y0, y1)
    zoom.set_xlabel(r"$\varphi$ (rad)")
    zoom.set_ylabel(r"$\omega$ (rad s$^{-1}$)")
    # the window alone: lines to (b) would cross the curves and (b)'s tick labels
    box = ax.indicate_inset((x0, y0, x1 - x0, y1 - y0), inset_ax=zoom, edgecolor="0.3",
                            lw=0.6, alpha=1.0, zorder=6)
    for line in box.connectors:
        line.set_visible(False)


#: simulate's states, every few steps: small crosses, not the start's ring.
SIMULATE_DOTS = {"ls": "none", "marker": "x", "ms": 2.6, "mec": "black", "mew": 0.6}


def figure_weightless(runs, size="two_column"):
    """phi and omega of simulate against the exact solution (36), g = 0, and the error of
    each, in its own unit: (a) phi, (b) omega, (c) |d phi|, (d) |d omega|.

    Each start is one look (colour and dashes), named in the legend by its
    initial state; the heading above states what both share.
    """
    from matplotlib.ticker import LogLocator

    width = pplot.width_of(size)
    wide = _wide(size)
    with pplot.style():
        fig, grid = plt.subplots(2 if wide else 4, 2 if wide else 1,
                                 figsize=(width, 3.9 if wide else 6.4), sharex=True,
                                 layout="constrained", squeeze=False)
        axes = list(grid.T.ravel()) if wide else list(grid.ravel())  # phi, omega, errors
        errors = []
        for ds, (phi0, omega0), look in zip(runs, WEIGHTLESS, CURVE_LOOKS):
            t = ds.t.values
            tt = np.linspace(0.0, t[-1], 400)
            exact = weightless_motion(tt, phi0, omega0, DELTA_WEIGHTLESS, L)
            every = max(1, t.size // 25)
            dots = SIMULATE_DOTS
            at = weightless_motion(t, phi0, omega0, DELTA_WEIGHTLESS, L)
            for k, (name, ex, ref) in enumerate(zip(("phi", "omega"), exact, at)):
                axes[k].plot(tt, ex, lw=1.4, solid_capstyle="butt", **look)
                axes[k].plot(t[::every], ds[name].values[::every], **dots)
                err = np.abs(ds[name].values - ref)
                errors.append(err[1:])
                axes[k + 2].semilogy(t[1:], np.maximum(err[1:], 1e-300), lw=0.9, **look)
        worst = max(float(e.max()) for e in errors)
        best = min(float(e[e > 0].min()) for e in errors if (e > 0).any())
        for k, (label, what) in enumerate(((r"$\varphi$ (rad)", "angle"),
                                           (r"$\omega$ (rad s$^{-1}$)", "angular velocity"),
                                           (r"$|\Delta\varphi|$ (rad)", "error of the angle"),
                                           (r"$|\Delta\omega|$ (rad s$^{-1}$)",
                                            "error of the angular velocity"))):
            axes[k].set_ylabel(label)
            axes[k].set_title(what, loc="left")
        lo = 10.0 ** math.floor(math.log10(max(best, worst * 1e-6)))
        # half a decade above the top tick: its label clear of the panel's title
        hi = 10.0 ** (math.ceil(math.log10(worst)) + 0.5)
        for a in axes[2:]:
            a.set_ylim(lo, hi)
            a.yaxis.set_major_locator(LogLocator(base=10.0, numticks=12))
        for a in (axes[1], axes[3]) if wide else axes[3:]:
            a.set_xlabel(r"$t$ (s)")
        for a in axes:
            a.set_xlim(0.0, max(float(ds.t[-1]) for ds in runs))
        fig.align_ylabels(axes)
        pplot.label_panels(axes)
        handles = [Line2D([], [], lw=1.4, **look,
                          label=rf"from $\varphi_0$ = {_signed(p0)} rad, "
                                rf"$\omega_0$ = {_signed(w0)} rad s$^{{-1}}$")
                   for look, (p0, w0) in zip(CURVE_LOOKS, WEIGHTLESS)]
        handles.append(Line2D([], [], label="simulate (every few steps)", **SIMULATE_DOTS))
        pplot.figure_legend(fig, handles, ncols=1,
                            title=rf"$g$ = 0 m s$^{{-2}}$, $\delta$ = {DELTA_WEIGHTLESS:g} m, "
                                  rf"$l$ = {L:g} m")
        pplot.define_symbols(fig, [
            "lines: the exact solution (36) in (a) and (b), the error of simulate in (c) "
            "and (d), one look per start",
            r"$\Delta$: simulate minus the exact solution (36)"])
    return fig


def figure_fates(ds, size="two_column"):
    """Where every initial state comes to rest, and after how many swings.

    Every state of the grid comes to rest within T_FATE (the study checks it),
    so a fate panel would be one colour: the heading says it instead.  Rings
    mark the rare rests in the upper zone (cos phi_rest < 0), the isolated
    cells with 0 reversals.  Side by side at two-column width, stacked (colour
    bars underneath) at one-column width.
    """
    rest = int((ds.fate == phasemap.Event.REST).sum())
    wide = _wide(size)
    with pplot.style():
        fig, axes = pplot.panels(2, size, height=3.2, panel_height=2.5, extra=1.1,
                                 sharex=True, sharey=True)
        for ax, layer in zip(axes, ("phi_rest", "n_reversals")):
            pplot.map_figure(ds, layer, x="phi", ax=ax, colorbar="right" if wide else "bottom")
        pplot.outer_labels(axes)
        rings = pplot.mark_inverted_rests(axes, ds, "phi", "omega", ds.phi.values,
                                           ds.omega.values)
        for ax in axes:
            if ax.get_legend() is not None:
                ax.get_legend().remove()
            ax.set_title("")
        pplot.label_panels(axes)
        head = pplot.wrap(pplot.fixed_values(ds)[:-1] + [
            pplot.fixed_values(ds)[-1] + ";", f"all {rest} of {ds.fate.size} initial "
            f"states come to rest within {T_FATE:g} s"], 0.95 * fig.get_figwidth())
        pplot.figure_legend(fig, rings, title=head.replace(";,", ";"))
        pplot.define_symbols(fig, [pplot.fate_grid_note(ds, "phi")])
    return fig


# --------------------------------------------------------------------------- the study


def rest_claims(rest) -> list[Claim]:
    """The stagnation zone at rest against (35), and rest for delta >= l."""
    claims = []
    phi, delta = study.mesh(rest, "phi", "delta")
    stag = rest.stagnation.transpose("phi", "delta").values == 1
    below = np.broadcast_to(delta < L, stag.shape)
    paper = zone_35(phi, delta) & below
    # on the boundary l |sin phi| = delta (to rounding) phasemap ties to rest
    tie = np.abs(L * np.abs(np.sin(phi)) - delta) <= 1e-12 * (L + delta)
    bad = int(((stag != paper) & ~tie)[below].sum())
    claims.append(Claim(
        "stagnation zone (35), delta < l", "|tan phi| <= delta/sqrt(l^2 - delta^2)",
        f"rest on {int(stag[below].sum())}/{int(below.sum())} cells, {bad} differ from (35) "
        f"({int((tie & below).sum())} ties: rest)",
        verdict(bad == 0 and stag[below].any())))
    above = np.broadcast_to(delta >= L, stag.shape)
    claims.append(Claim(
        "stagnation zone for delta >= l", "(35) needs delta < l",
        f"l|sin phi| <= delta: rest at every angle, {int(stag[above].sum())}/"
        f"{int(above.sum())} cells",
        verdict(bool(stag[above].all()) and above.any(), "finding")))
    n = rest.n_solutions.transpose("phi", "delta").values
    cols = [int(np.flatnonzero(rest.phi.values == s * math.pi / 2)[0]) for s in (1, -1)]
    strictly = rest.delta.values > L
    two = int(sum((n[c, strictly] == 2).sum() for c in cols))
    claims.append(Claim(
        "delta > l, rest at phi = +-pi/2", "(no solution for delta >= l)",
        f"two solutions (rest, free fall with R = 0) on {two}/{2 * int(strictly.sum())} cells",
        verdict(two == 2 * strictly.sum() > 0, "finding")))
    return claims


def moving_claims(by_delta, by_omega) -> list[Claim]:
    """In motion with delta >= l: no solution off the free-fall curve, after (33)."""
    claims = []
    n = by_delta.n_solutions.transpose("phi", "delta").values
    phis, deltas = by_delta.phi.values, by_delta.delta.values
    on = np.isin(phis, free_angle(OMEGA_MOVING))
    strictly = deltas > L
    none_off = int((n[~on][:, strictly] == 0).sum())
    unique_on = int((n[on][:, strictly] == 1).sum())
    acc = by_delta.phi_ddot_turn_pos.transpose("phi", "delta").values[on][:, strictly]
    free_acc = -G * np.sin(phis[on])[:, None] / L
    acc_err = float(np.nanmax(np.abs(acc - free_acc))) if np.isfinite(acc).all() else math.inf
    ok = (none_off == (~on).sum() * strictly.sum() and unique_on == on.sum() * strictly.sum()
          and acc_err <= 1e-12 * G)
    claims.append(Claim(
        "delta > l: no solution (after (33))", "no solution for delta >= l",
        f"omega = {OMEGA_MOVING:g}: none on {none_off} cells, unique on l omega^2 + g cos phi = 0 "
        f"({unique_on}: phi'' = -g sin phi / l, error {acc_err:.1g})",
        verdict(ok, "erratum")))
    at_l = int(np.flatnonzero(deltas == L)[0])
    singular = by_delta.singular.transpose("phi", "delta").values[:, at_l] == 1
    cont_on = int((n[on, at_l] == 3).sum())
    none_at_l = int((n[~on, at_l] == 0).sum())
    claims.append(Claim(
        "delta = l in motion (singular)", "no solution for delta >= l",
        f"singular on {int(singular.sum())}/{singular.size} cells; continuum on the curve "
        f"({cont_on}/{int(on.sum())}), none elsewhere ({none_at_l}/{int((~on).sum())})",
        verdict(bool(singular.all()) and cont_on == on.sum() and none_at_l == (~on).sum(),
                "finding")))
    n_om = by_omega.n_solutions.transpose("phi", "omega").values
    moving = by_omega.omega.values != 0.0
    qn = L * by_omega.omega.values[None, :] ** 2 + G * np.cos(by_omega.phi.values)[:, None]
    off = (np.abs(qn) > 1e-9 * G) & moving[None, :]
    claims.append(Claim(
        f"delta/l = {DELTA_ABOVE:g} over (phi, omega)", "no solution for delta >= l",
        f"none on {int((n_om[off] == 0).sum())}/{int(off.sum())} moving cells off the curve",
        verdict(bool((n_om[off] == 0).all()) and off.any())))
    return claims


def phase_claims(curves) -> list[Claim]:
    """Phase curves: swings from rest decay to rest inside the zone."""
    claims = []
    ends = [(ds.attrs["end_reason"], float(ds.stage_end_phi[-1])) for ds in curves]
    at_rest = [p for r, p in ends if r == "rest"]
    worst = max(L * abs(math.sin(p)) for p in at_rest) if at_rest else math.inf
    swings = sum(int(ds.sizes["stage"]) for ds in curves)
    claims.append(Claim(
        "falling into (35) with omega = 0, the pendulum stops", "stops in the zone",
        f"{len(at_rest)}/{len(curves)} phase curves end at rest after {swings} stages; "
        f"max l|sin phi_rest| = {worst:.4f} <= delta = {DELTA:g}",
        verdict(len(at_rest) == len(curves) and worst <= DELTA)))
    return claims


def weightless_claims(runs) -> list[Claim]:
    """The weightless pendulum against its exact solution (36)."""
    claims = []
    d_phi = d_omega = 0.0  # each in its own unit: rad and rad s-1 are not compared
    for ds, (phi0, omega0) in zip(runs, WEIGHTLESS):
        p, w = weightless_motion(ds.t.values, phi0, omega0, DELTA_WEIGHTLESS, L)
        d_phi = max(d_phi, float(np.abs(ds.phi.values - p).max()))
        d_omega = max(d_omega, float(np.abs(ds.omega.values - w).max()))
    keep = all(ds.attrs["end_reason"] == "horizon" and ds.attrs["n_reversals"] == 0
               for ds in runs)
    claims.append(Claim(
        "g = 0: omega = omega0/(1 + omega0 k t) (36)", "exact solution (36)",
        f"simulate (rtol 1e-10, 10 s): max |d phi| {d_phi:.1e} rad, max |d omega| "
        f"{d_omega:.1e} rad s-1; direction kept",
        verdict(max(d_phi, d_omega) < 1e-7 and keep)))
    return claims


def fate_claims(fates) -> list[Claim]:
    """The fate map: every motion ends at rest, in the lower or the upper part of the zone."""
    claims = []
    rest_cells = fates.fate.values == phasemap.Event.REST
    phi_rest = fates.phi_rest.values[rest_cells]
    worst = float(np.max(L * np.abs(np.sin(phi_rest)))) if phi_rest.size else math.inf
    upper = int((np.cos(phi_rest) < 0).sum())
    claims.append(Claim(
        "every motion ends at rest in the zone", "stops in (35), near bottom and top",
        f"rest from {int(rest_cells.sum())}/{rest_cells.size} states within {T_FATE:g} s, "
        f"{upper} at the top; max l|sin phi_rest| = {worst:.4f}",
        verdict(bool(rest_cells.all()) and worst <= DELTA and 0 < upper < rest_cells.sum())))
    return claims


def main(argv=None) -> list[Claim]:
    args = study.arguments(__doc__, argv)
    out, quick, files = args.out, args.quick, []
    rest = rest_map(quick, out, files)
    by_delta, by_omega = moving_maps(quick, out, files)
    curves = phase_curves(out, files)
    runs = weightless(out, files)
    fates = fate_map(quick, out, files)
    claims = (rest_claims(rest) + moving_claims(by_delta, by_omega) + phase_claims(curves)
              + weightless_claims(runs) + fate_claims(fates))

    for name, draw in (("rest", lambda size: figure_rest(rest, size)),
                       ("moving", lambda size: figure_moving(by_delta, by_omega, size)),
                       ("phase_curves", lambda size: figure_phase(curves, size)),
                       ("weightless", lambda size: figure_weightless(runs, size)),
                       ("fates", lambda size: figure_fates(fates, size))):
        files += study.save_figures(draw, out, f"{NAME}_{name}", args.sizes)

    claims += threshold_claims("hinge_pendulum")  # exact, beside the closed form
    study.finish("Pendulum with hinge friction", claims, files)
    return claims


if __name__ == "__main__":
    main()
