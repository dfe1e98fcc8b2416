"""Study: the wheel with a displaced centre of mass (Lapshin 2021, Fig. 2, eq. (10)-(15)).

A disc of radius r rolls without slip; its centre of mass is l from the
centre, J_c = m rho^2, and a rolling-friction couple delta N opposes the
rotation.  Fixed throughout: r = 1 m, l = 0.5 m, rho = 0.5 m, g = 9.81 m s-2,
m = 1 kg (phasemap's defaults), so delta/l = 2 delta.  This study

* maps the stagnation zones (15), l |sin phi| <= delta, over (phi, delta/l) and
  checks that for delta >= l they cover every angle;
* follows phase curves at delta/l = 0.1 (damped oscillations that stop in the
  zone near the lowest position) and at delta/l = 1.2 (the disc moves one way
  and stops at the first zero of omega: no reversal), with a time integration
  beside them;
* maps the bounce condition (12), N < 0, over (phi, omega) and compares it with
  N from an unreduced Newton-Euler solve, the paper's condition after (13) and
  the printed (13) (a sign erratum);
* maps the fate of every initial state (phi0, omega0) at both delta/l;
* measures where the bracket of (13) can vanish (the Painleve analogue) against
  the sharp bound the README states (``phasemap.facts.wheel_singular_delta``).

    python studies/wheel.py [--quick] [--out DIR]

Writes ``wheel_*.nc`` atlases and ``wheel_*.pdf``/``.png`` figures, and ends
with the table of the claims checked, measured value beside the paper's.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

import phasemap
from phasemap.claims import threshold_claims
from phasemap.facts import wheel_singular_delta
from phasemap import plot as pplot
from phasemap.study import (Claim, arguments, collect_legend, finish, save_atlas,
                            save_figures, verdict)

STUDY = "wheel"
G = 9.81
#: The fixed parameters of the study (phasemap's defaults for the wheel).
FIXED = {"r": 1.0, "l": 0.5, "rho": 0.5, "g": G, "m": 1.0}
L = FIXED["l"]
#: What delta, l, r and rho are, for the key under a figure.
KEY = [r"$\delta$: rolling-friction length (couple $\delta N$)",
       r"$l$: offset of the centre of mass from the centre",
       r"$r$: radius", r"$\rho$: radius of gyration"]
#: delta/l of the oscillating regime and of the one-way regime.
LOW, HIGH = 0.1, 1.2
#: Initial states (phi0, omega0) of the phase portraits, per delta/l.
STARTS = {LOW: [(2.0, 0.0), (-1.0, 5.0)],
          HIGH: [(-3.0, 2.0), (-2.0, 4.0), (0.5, 6.0), (1.0, -3.0), (-0.5, -4.0), (-0.5, -6.0)]}
#: Time horizon of the fate maps (s): every motion at delta/l = 0.1 has ended by then.
T_END = 30.0


def main(argv=None) -> list[Claim]:
    args = arguments(__doc__, argv)
    out = args.out
    files, claims = [], []
    n_phi, n_delta, n_omega, n_fate = (241, 151, 200, 240) if args.quick else \
        (1441, 601, 800, 481)

    # -- stagnation zones (15) over (phi, delta/l) ----------------------------------
    stag = phasemap.Scene(
        "wheel", axes={"phi": np.linspace(-math.pi, math.pi, n_phi),
                       "delta": L * np.linspace(0.0, 1.5, n_delta)},
        fixed={"omega": 0.0, **FIXED}, layers=["stagnation", "n_solutions"]).compute()
    files.append(save_atlas(stag, out, "wheel_stagnation", STUDY))
    claims += stagnation_claims(stag)

    # -- phase portraits: damped oscillation (delta < l), one way (delta >= l) -----
    curves = {k: [phasemap.phase_curve("wheel", phi=p, omega=w, delta=k * L, **FIXED)
                  for p, w in STARTS[k]] for k in (LOW, HIGH)}
    runs = {k: phasemap.simulate("wheel", t_end=T_END, rtol=1e-10, phi=p, omega=w,
                                 delta=k * L, **FIXED)
            for k, (p, w) in ((LOW, STARTS[LOW][0]), (HIGH, STARTS[HIGH][1]))}
    claims += portrait_claims(curves, runs)
    files += save_figures(lambda size: portrait_figure(curves, runs[LOW], size), out,
                          "wheel_portraits", args.sizes)

    # -- the bounce condition (12) over (phi, omega) ----------------------------------
    omega = np.linspace(-8.0, 8.0, n_omega)  # an even count: omega = 0 is not on the grid
    bounce = phasemap.Scene(
        "wheel", axes={"phi": np.linspace(-math.pi, math.pi, n_phi), "omega": omega},
        fixed={"delta": LOW * L, **FIXED}, layers=["n_solutions", "contact_lost"]).compute()
    files.append(save_atlas(bounce, out, "wheel_bounce", STUDY))
    normal = bounce_normals(bounce)
    claims += bounce_claims(bounce, normal)
    files += save_figures(lambda size: maps_figure(stag, bounce, normal, size), out,
                          "wheel_maps", args.sizes)

    # -- fate maps over (phi0, omega0) -------------------------------------------------
    fates = {}
    for k, name in ((LOW, "wheel_fates"), (HIGH, "wheel_fates_one_way")):
        fates[k] = phasemap.Scene(
            "wheel", axes={"phi": np.linspace(-math.pi, math.pi, n_fate),
                           "omega": np.linspace(-8.0, 8.0, n_fate)},
            fixed={"delta": k * L, **FIXED}, layers=["fate", "phi_rest", "n_reversals"],
            options={"t_end": T_END}).compute()
        files.append(save_atlas(fates[k], out, name, STUDY))
    claims += fate_claims(fates)
    files += save_figures(lambda size: fates_figure(fates, size), out, "wheel_fates",
                          args.sizes)

    # -- where the bracket of (13) vanishes ---------------------------------------
    sing = singular_atlas(n_phi, n_delta)
    files.append(save_atlas(sing, out, "wheel_singular", STUDY))
    claims += singular_claims(sing)

    claims += threshold_claims("wheel")  # exact, beside the closed form
    finish("wheel study", claims, files)
    return claims


# --------------------------------------------------------------------------- stagnation


def stagnation_claims(ds: xr.Dataset) -> list[Claim]:
    phi, delta = ds.phi.values[:, None], ds.delta.values[None, :]
    stag = ds.stagnation.transpose("phi", "delta").values == 1
    margin = delta - L * np.abs(np.sin(phi))
    tie = np.abs(margin) <= 1e-12 * (delta + L)
    expect = margin >= 0.0
    wrong = int(np.count_nonzero((stag != expect) & ~tie))
    high = ds.delta.values >= L
    all_rest = bool(stag[:, high].all())
    unique = bool((ds.n_solutions == 1).all())
    ties_rest = bool(stag[tie].all())
    return [
        Claim("wheel: stagnation zone (15)", "|sin phi| <= delta/l",
              f"stagnation layer = (l|sin phi| <= delta) in {stag.size - wrong} of {stag.size} "
              f"cells ({int(tie.sum())} ties to rest); unique at rest: "
              f"{'yes' if unique else 'no'}", verdict(wrong == 0 and unique and ties_rest)),
        Claim("wheel: delta >= l, zone (15) covers all positions", "yes",
              f"every phi at rest in all {int(high.sum())} rows delta/l = "
              f"{ds.delta.values[high][0] / L:.2f}...{ds.delta.values[high][-1] / L:.2f}",
              verdict(all_rest and high.any())),
    ]


def _per_l(ds: xr.Dataset) -> xr.Dataset:
    """A copy for plotting with delta/l on the delta axis."""
    return ds.assign_coords(delta=ds.delta / L)


def maps_figure(stag: xr.Dataset, bounce: xr.Dataset, n: dict, size="two_column"):
    """(a) the zones (15) over (phi, delta/l) at rest; (b) the bounce region (12)."""
    from matplotlib.lines import Line2D

    black = pplot.OKABE_ITO["black"]
    zone = {"color": black, "lw": 0.9, "ls": pplot.DASHES[1], "path_effects": pplot.HALO}
    newton = {"color": black, "lw": 0.9, "ls": pplot.DASHES[0], "path_effects": pplot.HALO}
    printed = {"color": black, "lw": 0.9, "ls": pplot.DASHES[2], "path_effects": pplot.HALO}
    with pplot.style():
        fig, (a, b) = pplot.panels(2, size, height=3.5, panel_height=2.6, extra=1.1)
        pplot.map_figure(_per_l(stag), "n_solutions", x="phi", ax=a)
        pp = np.linspace(-math.pi, math.pi, 721)
        a.plot(pp, np.abs(np.sin(pp)), **zone)
        a.axhline(1.0, color=black, lw=0.6, ls=pplot.DASHES[2])
        a.set_ylabel(r"$\delta/l$")
        a.set_title(r"(a) at rest, $\omega$ = 0 rad s$^{-1}$", loc="left")
        pplot.legend_above(a, _entries(a) + [
            Line2D([], [], label=r"$|\sin\varphi| = \delta/l$", **zone),
            Line2D([], [], color=black, lw=0.6, ls=pplot.DASHES[2], label=r"$\delta = l$")],
            ncols=2)

        # n_solutions with contact_lost hatched: rolling on (N >= 0), a hop (the rolling
        # would pull; hatched), or neither (N < 0 and free flight closes the gap: none)
        pplot.map_figure(bounce, "n_solutions", x="phi", ax=b)
        phi, w = bounce.phi.values, bounce.omega.values
        b.contour(phi, w, n["unreduced"].T, levels=[0.0], colors=[black], linewidths=0.9,
                  linestyles=[newton["ls"]]).set_path_effects(pplot.HALO)
        b.contour(phi, w, n["printed_13"].T, levels=[0.0], colors=[black], linewidths=0.9,
                  linestyles=[printed["ls"]]).set_path_effects(pplot.HALO)
        b.set_title(rf"(b) bounce (12), $\delta/l$ = {LOW:g}", loc="left")
        names = {"none": r"none: $N < 0$, no hop",
                 "a contact would pull": "a contact would pull: hops"}
        pplot.legend_above(b, _entries(b, names) + [
            Line2D([], [], label=r"$N = 0$, Newton–Euler", **newton),
            Line2D([], [], label=r"$N = 0$, (13) as printed", **printed)],
            ncols=2 if pplot.width_of(size) >= pplot.WIDE else 1)
        pplot.define_symbols(fig, [pplot.fixed_values_text(stag.drop_vars("delta"))
                                   .replace(r"$\omega$ = 0 rad s$^{-1}$, ", ""), *KEY])
    return fig


def _entries(ax, names: dict | None = None) -> list:
    """The handles of the legend above ``ax``, renamed by ``names`` (label -> new label)."""
    legend = ax.get_legend()
    out = []
    for h, t in zip(legend.legend_handles, legend.get_texts()):
        h.set_label((names or {}).get(t.get_text(), t.get_text()))
        out.append(h)
    return out


# --------------------------------------------------------------------------- portraits


def _in_zone(phi: float, delta_per_l: float) -> bool:
    return abs(math.sin(phi)) <= delta_per_l + 1e-12


def portrait_claims(curves, runs) -> list[Claim]:
    claims = []
    low = curves[LOW]
    ok = all(pc.attrs["end_reason"] == "rest" and int(pc.n_reversals) >= 1
             and _in_zone(float(pc.stage_end_phi[-1]), LOW)
             and math.cos(float(pc.stage_end_phi[-1])) > 0 for pc in low)
    ends = ", ".join(f"{float(pc.stage_end_phi[-1]):.3f}" for pc in low)
    revs = ", ".join(str(int(pc.n_reversals)) for pc in low)
    claims.append(Claim(
        f"wheel, delta/l = {LOW:g}: damped oscillation, stop near the lowest position",
        "stop in zone (15), cos phi > 0",
        f"{len(low)} phase curves: reversals {revs}; rest at phi = {ends} (cos > 0, "
        f"|sin| <= {LOW:g})", verdict(ok)))
    # the phase curve against the time integration from the same state
    pc, tr = low[0], runs[LOW]
    d_phi = abs(float(pc.stage_end_phi[-1]) - float(tr.event_phi[-1]))
    same = tr.attrs["end_reason"] == "rest" and int(tr.n_reversals) == int(pc.n_reversals)
    claims.append(Claim(
        f"wheel, delta/l = {LOW:g}: phase curve = time integration", "-",
        f"both {int(pc.n_reversals)} reversals, rest angles {d_phi:.0e} rad apart "
        f"(simulate, rtol 1e-10)", verdict(same and d_phi < 1e-6)))

    high = curves[HIGH]
    one_way = all(pc.attrs["end_reason"] == "rest" and int(pc.n_reversals) == 0
                  and int(pc.sizes["stage"]) == 1 for pc in high)
    tr = runs[HIGH]
    sign = np.sign(tr.omega.values[tr.omega.values != 0.0])
    one_way_t = tr.attrs["end_reason"] == "rest" and int(tr.n_reversals) == 0 and \
        np.all(sign == sign[0])
    claims.append(Claim(
        f"wheel, delta/l = {HIGH:g} >= 1: moves one way, stops at the first omega = 0",
        "no change of the sign of omega",
        f"{len(high)} phase curves: one stage each, rest, 0 reversals; time integration: "
        f"omega keeps its sign, rest at t = {float(tr.event_t[-1]):.3f} s",
        verdict(one_way and one_way_t)))
    return claims


def portrait_figure(curves, run: xr.Dataset, size="two_column"):
    """Phase portraits at delta/l = 0.1 and 1.2, and phi(t) of the first curve at 0.1.

    At two-column width (a) and (b) stand side by side above (c); narrower,
    the three are stacked.
    """
    import matplotlib.pyplot as plt

    width = pplot.width_of(size)
    wide = width >= pplot.WIDE
    with pplot.style():
        fig, axes = plt.subplot_mosaic(
            [["a", "b"], ["c", "c"]] if wide else [["a"], ["b"], ["c"]],
            figsize=(width, 0.68 * width if wide else 7.0), layout="constrained",
            height_ratios=[1.6, 1.0] if wide else [1.6, 1.6, 1.0])
        handles: dict[str, object] = {}
        for key, ratio in (("a", LOW), ("b", HIGH)):
            ax = axes[key]
            lo = min(float(pc.phi.min()) for pc in curves[ratio]) - 0.3
            hi = max(float(pc.phi.max()) for pc in curves[ratio]) + 0.3
            _zone_spans(ax, lo, hi, ratio)
            for pc in curves[ratio]:
                pplot.phase_curve_figure(pc, ax=ax)
                collect_legend(ax, handles)
            ax.set_xlim(lo, hi)
            pplot.angle_ticks(ax)
            ax.set_title(rf"({key}) $\delta/l$ = {ratio:g}"
                         + (" < 1: damped oscillation" if ratio < 1 else
                            r" $\geq$ 1: one way only"), loc="left")
        ax = axes["c"]
        pplot.trajectory_figure(run, states="phi", ax=ax)
        collect_legend(ax, handles)
        half = math.asin(LOW)
        pplot.stagnation_span(ax, -half, half, axis="y")
        ax.set_title(pplot.wrap([
            rf"(c) the motion of (a) from $\varphi_0$ = {STARTS[LOW][0][0]:g} rad",
            rf"$\omega_0$ = {STARTS[LOW][0][1]:g} rad s$^{{-1}}$ in time (simulate)"],
            0.95 * width), loc="left")
        handles[r"stagnation: $|\sin\varphi| \leq \delta/l$ (15)"] = pplot.stagnation_patch()
        pplot.figure_legend(fig, list(handles.values()), list(handles),
                            ncols=len(handles) if wide else None,
                            title=pplot.wrap(_fixed_items(), 0.95 * width))
        pplot.define_symbols(fig, KEY)
    return fig


def _zone_spans(ax, lo: float, hi: float, ratio: float) -> None:
    """Hatch the zones (15), |sin phi| <= delta/l, about each multiple of pi in [lo, hi]."""
    half = math.asin(min(ratio, 1.0))
    if half >= math.pi / 2:
        pplot.stagnation_span(ax, lo, hi)
        return
    for k in range(math.floor(lo / math.pi) - 1, math.ceil(hi / math.pi) + 2):
        pplot.stagnation_span(ax, k * math.pi - half, k * math.pi + half)


def _fixed_items() -> list[str]:
    return [rf"$r$ = {FIXED['r']:g} m", rf"$l$ = {L:g} m", rf"$\rho$ = {FIXED['rho']:g} m",
            rf"$g$ = {G:g} m s$^{{-2}}$", rf"$m$ = {FIXED['m']:g} kg"]


# --------------------------------------------------------------------------- bounce (12)


def _unreduced_normal(phi, omega, delta, r, l, rho, g, m):
    """N from momentum and angular momentum about C, unreduced (omega != 0).

    Unknowns z = (phi'', F, N), sigma = sgn omega, (10) and (11):
      m ((r - l cos phi) phi'' + l sin phi omega^2) = F
      m (l sin phi phi'' + l cos phi omega^2) = N - m g
      m rho^2 phi'' = -delta sigma N - F (r - l cos phi) - N l sin phi
    """
    phi, omega = np.broadcast_arrays(np.asarray(phi, float), np.asarray(omega, float))
    s, c, sigma = np.sin(phi), np.cos(phi), np.sign(omega)
    one, zero = np.ones_like(phi), np.zeros_like(phi)
    A = np.stack([np.stack([m * (r - l * c), -one, zero], -1),
                  np.stack([m * l * s, zero, -one], -1),
                  np.stack([m * rho * rho * one, r - l * c, delta * sigma + l * s], -1)], -2)
    b = np.stack([-m * l * s * omega ** 2, -m * g - m * l * c * omega ** 2, zero], -1)
    z = np.linalg.solve(A, b[..., None])[..., 0]
    return z[..., 2]


def bounce_normals(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """N/m over the bounce atlas: unreduced, the paper's condition after (13), printed (13)."""
    p = {k: float(ds.attrs[f"phasemap_fixed_{k}"]) for k in ("delta", "r", "l", "rho", "g", "m")}
    delta, r, l, rho, g, m = (p[k] for k in ("delta", "r", "l", "rho", "g", "m"))
    phi, w = ds.phi.values[:, None], ds.omega.values[None, :]
    s, c, sigma = np.sin(phi), np.cos(phi), np.sign(w)
    bracket = rho ** 2 + r ** 2 + l ** 2 - 2 * r * l * c + delta * l * s * sigma
    # the paper's condition after (13) puts phi'' = -[l (r s + delta c sigma) w^2 + g l s
    # + delta g sigma] / bracket into (12), i.e. into N/m = g + l (s phi'' + c w^2)
    centrifugal = l * (r * s + delta * c * sigma) * w ** 2
    acc_paper = -(centrifugal + g * l * s + delta * g * sigma) / bracket
    # (13) as printed: + l (r s + delta c sigma) w^2 on the right
    acc_printed = (centrifugal - g * l * s - delta * g * sigma) / bracket
    return {
        "unreduced": _unreduced_normal(phi, w, delta, r, l, rho, g, m) / m,
        "paper_12": g + l * (s * acc_paper + c * w ** 2),
        "printed_13": g + l * (s * acc_printed + c * w ** 2),
        "scale": g + l * w ** 2 + l * np.abs(acc_paper),
    }


def bounce_claims(ds: xr.Dataset, n: dict) -> list[Claim]:
    # rolling on needs a pull: the wheel hops (unique, contact_lost) or nothing is consistent
    counts = ds.n_solutions.transpose("phi", "omega").values
    lost = (counts == 0) | ((counts == 1) & (ds.contact_lost.transpose("phi", "omega").values == 1))
    ref = n["unreduced"] < 0
    tie = np.abs(n["unreduced"]) <= 1e-9 * n["scale"]
    mism = {k: int(np.count_nonzero(((n[k] < 0) != ref) & ~tie)) for k in ("paper_12",
                                                                             "printed_13")}
    mine = int(np.count_nonzero((lost != ref) & ~tie))
    hop, none = int(np.count_nonzero(lost & (counts == 1))), int(np.count_nonzero(counts == 0))
    area = 100.0 * ref.mean()
    return [
        Claim("wheel: no-bounce condition (12) after substituting (13)",
              "min[-(...)/(...) sin phi + cos phi phi'^2] >= -g/l",
              f"N < 0 on {area:.1f} % of (phi, omega) (a hop in {hop} cells, no "
              f"consistent motion in {none}); phasemap's and the paper's condition differ "
              f"from the unreduced solve in {mine} and {mism['paper_12']} cells",
              verdict(mine == 0 and mism["paper_12"] == 0)),
        Claim("wheel (13): sign of the omega^2 term", "+l(r sin phi + delta cos phi sgn)phi'^2",
              f"printed sign puts N < 0 wrongly in {mism['printed_13']} cells "
              f"({100 * mism['printed_13'] / ref.size:.1f} %); the minus sign in 0",
              verdict(mism["printed_13"] > 0 and mism["paper_12"] == 0, "erratum")),
    ]


# --------------------------------------------------------------------------- fates


def fate_claims(fates) -> list[Claim]:
    claims = []
    ds = fates[LOW]
    fate = ds.fate.values
    rest = fate == phasemap.Event.REST
    phi_rest = ds.phi_rest.values[rest]
    n_rev = ds.n_reversals.values[rest]
    inside = bool(np.all(L * np.abs(np.sin(phi_rest)) <= LOW * L * (1 + 1e-9)))
    after = n_rev >= 1
    lowest = bool(np.all(np.cos(phi_rest[after]) > 0))
    upper = int(np.count_nonzero(np.cos(phi_rest[~after]) < 0))
    claims.append(Claim(
        f"wheel fate map, delta/l = {LOW:g}: stops after a reversal", "near the lowest position",
        f"{int(after.sum())} of {int(rest.sum())} rest cells reversed first: all in zone (15) "
        f"with cos phi > 0; {upper} stopped at the first zero in the upper zone",
        verdict(inside and lowest and after.any())))
    p = FIXED
    texts, ok = [], True
    for k in (LOW, HIGH):
        f = fates[k].fate.values
        counts = {e.name.lower(): int(np.count_nonzero(f == e)) for e in phasemap.Event
                  if np.any(f == e)}
        # no_solution: rolling on would need a pull and a hop is not consistent either
        # (rolling without slip acts as unbounded friction): a contact state, not (13)
        ok = ok and set(counts) <= {"rest", "contact_lost", "no_solution"}
        texts.append(f"{k:g}: " + ", ".join(f"{n} {v}" for n, v in counts.items()))
    bound = p["rho"] ** 2 + (p["r"] - p["l"]) ** 2 - HIGH * L * p["l"]
    claims.append(Claim(
        "wheel fate maps: no Painleve state of (13), the rolling contact kept, on any motion",
        "(13) has no solution only where its bracket vanishes",
        "bracket >= rho^2 + (r - l)^2 - delta l >= "
        f"{bound:.2f} m2 > 0; fates at delta/l = " + "; ".join(texts)
        + " (no_solution: rolling would pull and a hop is inconsistent)",
        verdict(ok and bound > 0)))

    ds = fates[HIGH]
    never = int(ds.n_reversals.max()) == 0
    rest = ds.fate.values == phasemap.Event.REST
    claims.append(Claim(
        f"wheel fate map, delta/l = {HIGH:g}: no reversal from any initial state",
        "moves one way (delta >= l)",
        f"n_reversals = 0 in all {ds.fate.size} cells; {int(rest.sum())} come to rest",
        verdict(never)))
    return claims


def fates_figure(fates, size="two_column"):
    """(a) fate and (b) reversals at delta/l = 0.1; (c) rest angle at delta/l = 1.2.

    The fate maps at the two delta/l are nearly the same (the bounce depends on
    omega, hardly on delta), so one is drawn and the heading counts the cells
    where the other differs; what changes with delta/l is where and after how
    many reversals the wheel stops.  Side by side at two-column width (colour
    bars on the right), stacked at one-column width (colour bars underneath).
    """
    low, high = fates[LOW], fates[HIGH]
    differ = int((low.fate != high.fate).sum())
    wide = pplot.width_of(size) >= pplot.WIDE
    with pplot.style():
        fig, axes = pplot.panels(3, size, height=3.3, panel_height=2.0, extra=1.5,
                                 sharex=True, sharey=True)
        pplot.fate_figure(low, extra="n_reversals", ax=list(axes[:2]), size=size)
        pplot.map_figure(high, "phi_rest", x="phi", ax=axes[2],
                         colorbar="right" if wide else "bottom")
        legend = axes[0].get_legend()
        handles = list(legend.legend_handles)
        labels = [t.get_text() for t in legend.get_texts()]
        legend.remove()
        for ax in axes:
            ax.set_title("", loc="left")
            if ax.get_legend() is not None:
                ax.get_legend().remove()
        pplot.outer_labels(axes)
        for ax, text in zip(axes, (rf"fate, $\delta/l$ = {LOW:g}",
                                   rf"reversals, $\delta/l$ = {LOW:g}",
                                   rf"rest angle, $\delta/l$ = {HIGH:g}")):
            ax.set_title(text, loc="left")
        pplot.label_panels(axes)
        pplot.figure_legend(fig, handles, labels, title=pplot.wrap(
            _fixed_items() + [rf"$t_\mathrm{{end}}$ = {T_END:g} s",
                              rf"the fate at $\delta/l$ = {HIGH:g} (not drawn) differs from "
                              rf"(a)'s, at $\delta/l$ = {LOW:g}, in {differ} of "
                              f"{low.fate.size} cells"],
            0.95 * fig.get_figwidth()).replace(" kg,", " kg;"))
        pplot.define_symbols(fig, KEY + [pplot.fate_grid_note(low, "phi")])
    return fig


# --------------------------------------------------------------------------- the bracket of (13)

#: Parameters where the bracket can vanish with delta < l: a heavy rim, l = r.
SINGULAR_FIXED = {"r": 1.0, "l": 1.0, "rho": 0.3, "g": G, "m": 1.0, "omega": 1.0}


def singular_atlas(n_phi: int, n_delta: int) -> xr.Dataset:
    return phasemap.Scene(
        "wheel", axes={"phi": np.linspace(-math.pi, math.pi, n_phi),
                       "delta": np.linspace(0.0, 1.0, n_delta)},
        fixed=SINGULAR_FIXED, layers=["n_solutions", "coef_roll_pos"]).compute()


def singular_claims(ds: xr.Dataset) -> list[Claim]:
    p = SINGULAR_FIXED
    r, l, rho = p["r"], p["l"], p["rho"]
    total = rho ** 2 + r ** 2 + l ** 2
    # min over phi of total - 2 r l cos phi - delta l |sin phi| is total - l sqrt(4 r^2 + delta^2)
    sharp = wheel_singular_delta(r, l, rho)
    delta = ds.delta.values
    reaches = (ds.coef_roll_pos.min("phi") <= 0.0).values
    first = float(delta[np.argmax(reaches)]) if reaches.any() else math.inf
    step = delta[1] - delta[0]
    claims = [Claim(
        f"wheel: bracket of (13) can vanish (r = l = {r:g}, rho = {rho:g})",
        "(not stated)",
        f"first at delta = {first:.4f} on the grid; the README's sharp bound "
        f"l sqrt(4r^2 + delta^2) >= rho^2 + r^2 + l^2 gives delta >= {sharp:.4f}",
        verdict(sharp <= first <= sharp + step, "finding"))]
    # the paper: (13) has no solution where the bracket vanishes (unless its right side does)
    d = 0.8
    phi0 = -math.atan2(d, 2 * r)  # the bracket's minimum over phi (omega > 0)

    def bracket(x):
        return total - 2 * r * l * math.cos(x) + d * l * math.sin(x)

    from scipy.optimize import brentq

    phi_zero = brentq(bracket, phi0, 0.0, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    c = phasemap.classify("wheel", phi=phi_zero, delta=d, **{**p, "omega": 1.0})
    claims.append(Claim(
        "wheel: (13) has no solution where its bracket vanishes", "no solution (Painleve)",
        f"at phi = {phi_zero:.4f}, delta = {d:g}, omega = 1: n_solutions = {c.n_solutions}, "
        f"singular = {c.singular}", verdict(c.n_solutions == 0 and c.singular)))
    return claims


if __name__ == "__main__":
    main()
