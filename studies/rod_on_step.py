r"""Study: a rod on a step, two frictional contacts (docs/systems/rod_on_step.md).

A uniform rod (length 2l) has its end A on a rough floor and lies across the
rough edge K = (0, h) of a step, friction f at both; theta is its angle to the
floor, a = AK/l = h/(l sin theta) <= 2.  With both contacts kept and slipping
(s = sgn omega) the coefficient of theta'' is, up to a positive factor,

    D = 3a^2 - (6a - 4) sin^2 - f^2 (3a - 4) sin^2 + s f 3a sin cos      (S3, f_edge = f)

and docs/systems/rod_on_step.md claims that it first vanishes at
f* = 2/sqrt 3 at a = 5/3, tan theta = 5/sqrt 3, h/l = 25/(6 sqrt 7), for
s = -1 (theta decreasing: the rod slides down).  This study, at that h/l:

* maps n_solutions (contact_lost and stagnation overlaid) over (theta, f) at
  rest and in motion (omega = -1, -3 rad/s sliding down, +1 rad/s), measures
  where phasemap's kept-kept coefficient (the ``coef_`` layer) first vanishes
  and compares its sign with (S3) cell by cell;
* measures where the full enumeration has no solution, two or three or more,
  the smallest f of each over a scan of omega < 0, and which coefficient
  bounds those regions (the one-contact Painleve rod, edge left, for omega < 0);
* at rest: the stagnation region, and at a low step (h/l = 0.6) rest and
  sliding from rest coexisting;
* integrates the rod sliding down from rest with simulate, which ends the
  motion where its upper end passes the edge (it leaves the step: the edge
  contact's declared extent).

Run as ``python studies/rod_on_step.py`` (:mod:`phasemap.study`).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import FormatStrFormatter, MultipleLocator

import phasemap
from phasemap import plot as pplot
from phasemap import study
from phasemap.study import Claim, verdict

NAME = "rod_on_step"
MODEL = phasemap.get_model(NAME)
G = MODEL.variables["g"].default
L = 1.0
M = 1.0
#: The critical geometry of the doc: f*, theta*, a* and h/l.
F_STAR = 2.0 / math.sqrt(3.0)
THETA_STAR = math.atan(5.0 / math.sqrt(3.0))
A_STAR = 5.0 / 3.0
H_STAR = 25.0 / (6.0 * math.sqrt(7.0)) * L
#: A low step, where rest and sliding from rest coexist.
H_LOW = 0.6 * L
#: Angular velocities of the maps in motion, and of the scan for the smallest paradox f.
OMEGAS = (-1.0, -3.0, 1.0)
#: Branch names: both contacts slipping, and the floor alone (the edge left).
KEPT = {-1: "floor_slip_neg_edge_slip_neg", 1: "floor_slip_pos_edge_slip_pos"}
FLOOR_ONLY = "floor_slip_neg_edge_separated"
#: The slide from rest: friction and initial angle (outside the stagnation region).
F_SLIDE = 0.2
THETA_SLIDE = 1.0
KEY = [r"$a = AK/l = h/(l\sin\theta)$", r"$2l$: rod length",
       r"$h$: height of the step's edge $K$", r"$f$: friction at floor and edge"]
N_TEXT = {0: "none", 1: "unique", 2: "two", 3: "continuum", 4: "three or more"}


def theta_min(h):
    """The smallest angle at which the edge still touches the rod: 2 l sin theta = h."""
    return math.asin(h / (2.0 * L))


def coefficient_s3(theta, f, h, s):
    """(S3) with f_edge = f: the kept-kept coefficient of theta'', up to a positive factor."""
    sn, cs = np.sin(theta), np.cos(theta)
    a = h / (L * sn)
    return (3 * a * a - (6 * a - 4) * sn ** 2 - f * f * (3 * a - 4) * sn ** 2
            + 2 * s * f * (3 * a - 2) * sn * cs - s * f * (3 * a - 4) * sn * cs)


def painleve_f(theta):
    """Where the one-contact rod (end on the floor, sliding back) is singular:
    f = (1 + 3 cos^2) / (3 sin cos), least 4/3 at tan theta = 2."""
    return (1.0 + 3.0 * np.cos(theta) ** 2) / (3.0 * np.sin(theta) * np.cos(theta))


def first_zero(ds, layer):
    """Per theta column, the smallest f where ``layer`` turns negative (interpolated);
    the least of those, and its theta.  (nan, nan) when it never does."""
    z = ds[layer].transpose("theta", "f").values
    f = ds.f.values
    best = (math.nan, math.nan)
    for i, th in enumerate(ds.theta.values):
        neg = np.flatnonzero(z[i] < 0)
        if neg.size == 0 or neg[0] == 0:
            continue
        j = neg[0]
        z0, z1 = z[i, j - 1], z[i, j]
        fz = f[j - 1] + (f[j] - f[j - 1]) * z0 / (z0 - z1)
        if not fz >= best[0]:
            best = (float(fz), float(th))
    return best


def least_f(ds, mask):
    """The smallest f of the cells in ``mask`` (theta, f), and its theta; nan when empty."""
    i, j = np.nonzero(mask)
    if i.size == 0:
        return math.nan, math.nan
    k = int(np.argmin(ds.f.values[j]))
    return float(ds.f.values[j[k]]), float(ds.theta.values[i[k]])


# --------------------------------------------------------------------------- measurements


def axes(quick, h):
    # print resolution even when quick: a cell under 1.5 px at 300 dpi in every figure.
    # The maps do not trace exact boundaries (boundaries=True): compiling the rod's
    # condition functions takes about 2.5 min with empty caches, as CI runs
    n_th, n_f = (641, 401) if quick else (641, 801)
    theta = np.unique(np.r_[np.linspace(theta_min(h), math.pi / 2, n_th),
                            [THETA_STAR] if h == H_STAR else []])
    return {"theta": theta, "f": np.linspace(0.0, 2.0, n_f)}


def rest_maps(quick, out, files):
    """n_solutions and stagnation at rest, at h* and at the low step."""
    maps = []
    for h, tag in ((H_STAR, "rest"), (H_LOW, "rest_low_step")):
        ds = phasemap.Scene(NAME, axes=axes(quick, h), fixed={"omega": 0.0, "h": h, "l": L},
                            layers=["n_solutions", "stagnation", "contact_lost"]).compute()
        files.append(study.save_atlas(ds, out, f"{NAME}_{tag}", NAME))
        maps.append(ds)
    return maps


def motion_maps(quick, out, files):
    """n_solutions over (theta, f) at h*, at each of OMEGAS, with the coefficient layers."""
    ds = phasemap.Scene(NAME, axes={**axes(quick, H_STAR), "omega": sorted(OMEGAS)},
                        fixed={"h": H_STAR, "l": L},
                        layers=["n_solutions", "stagnation", "contact_lost",
                                f"coef_{KEPT[-1]}", f"coef_{KEPT[1]}",
                                f"coef_{FLOOR_ONLY}"]).compute()
    files.append(study.save_atlas(ds, out, f"{NAME}_motion", NAME))
    return ds


def omega_scan(quick, out, files):
    """n_solutions over (theta, f, omega < 0): the smallest f of each paradox, per omega."""
    n_w = 12 if quick else 48
    ds = phasemap.Scene(NAME, axes={**axes(quick, H_STAR),
                                    "omega": np.linspace(-6.0, -0.5, n_w)},
                        fixed={"h": H_STAR, "l": L}, layers=["n_solutions"]).compute()
    files.append(study.save_atlas(ds, out, f"{NAME}_omega_scan", NAME))
    return ds


def energy(theta, omega, h):
    """Kinetic plus potential energy of the rod with both contacts kept (J, m = 1 kg)."""
    sn, cs = np.sin(theta), np.cos(theta)
    vx = (h / sn ** 2 - L * sn) * omega
    vy = L * cs * omega
    return 0.5 * M * (vx * vx + vy * vy) + 0.5 * M * L * L / 3.0 * omega ** 2 + M * G * L * sn


def slide(out, files):
    """The rod from rest at THETA_SLIDE, simulated until it leaves the step.

    The edge contact declares its extent (the rod's length), so the motion
    ends with ``left_domain`` exactly where the rod's upper end passes the
    edge (2 l sin theta = h), located like any other event.
    """
    values = dict(theta=THETA_SLIDE, omega=0.0, f=F_SLIDE, h=H_STAR, l=L)
    ds = phasemap.simulate(NAME, t_end=10.0, rtol=1e-10, max_step=0.005, **values)
    files.append(study.save_atlas(ds, out, f"{NAME}_slide", NAME))
    return ds, float(ds.event_t[-1])


# --------------------------------------------------------------------------- figures


def _wide(size) -> bool:
    return pplot.width_of(size) >= pplot.WIDE


def _plain(ds):
    """The layers map_figure draws (no coefficient contours of its own)."""
    return ds[[v for v in ("n_solutions", "stagnation", "contact_lost") if v in ds]]


#: The step's height as every figure states it: one form, one precision.
H_TEXT = rf"$h/l$ = 25/(6$\sqrt{{7}}$) = {H_STAR / L:.5g}"
#: What "a contact would pull" means here: the solution leaves the floor or the edge.
PULL_KEY = "a contact would pull: the solution leaves the floor or the edge"
#: The reference curves: black, told apart by their dashes, haloed in white.
S3_STYLE = {"color": "black", "lw": 1.0, "ls": pplot.DASHES[1], "path_effects": pplot.HALO}
FLOOR_STYLE = {"color": "black", "lw": 1.2, "ls": pplot.DASHES[3], "path_effects": pplot.HALO}
STAR_STYLE = {"ls": "none", "marker": "*", "ms": 8, "mfc": "white", "mec": "black", "mew": 0.6}


def _legend(fig, handles, size, ds, h_text: str | None = H_TEXT):
    """One legend over the panels, headed by what was held fixed: the step's height as
    ``h_text`` (h/l, the form every figure uses), not as h in metres."""
    order = ["unique", "none", "two", "three or more", "continuum", "a contact would pull",
             "stagnation"]
    keys = sorted(handles, key=lambda s: order.index(s) if s in order else len(order))
    ncols = -(-len(keys) // 2) if _wide(size) else 2
    plain = ds.drop_attrs().assign_attrs({k: v for k, v in ds.attrs.items()
                                          if not k.endswith("_h")})
    items = pplot.fixed_values(plain) + ([h_text] if h_text else [])
    pplot.figure_legend(fig, [handles[k] for k in keys], keys, ncols=ncols,
                        title=pplot.wrap(items, 0.95 * fig.get_figwidth()))


def figure_rest(rest, low, size="two_column"):
    """n_solutions at rest, stagnation hatched: at h* (unique everywhere) and at h/l = 0.6."""
    with pplot.style():
        fig, axs = pplot.panels(2, size, height=3.2, panel_height=2.3, extra=1.5, sharey=True)
        handles: dict[str, object] = {}
        for k, (ax, ds) in enumerate(zip(axs, (rest, low))):
            pplot.map_figure(_plain(ds), "n_solutions", x="theta", ax=ax)
            study.collect_legend(ax, handles)
            h = float(ds.attrs["phasemap_fixed_h"])
            ax.set_title(f"({'ab'[k]}) " + (H_TEXT if h == H_STAR else rf"$h/l$ = {h / L:.5g}"),
                         loc="left")
        pplot.outer_labels(axs)
        _legend(fig, handles, size, rest, h_text=None)
        pplot.define_symbols(fig, KEY + [PULL_KEY])
    return fig


def figure_motion(ds, size="two_column"):
    """n_solutions in motion at h*, the zero sets of (S3) and of the one-contact rod.

    Sliding down (a, b) the panels share their axes; sliding up (c) the only
    paradox sits in a corner, and the panel shows that corner.
    """
    with pplot.style():
        fig, axs = pplot.panels(len(OMEGAS), size, height=3.4, panel_height=2.1, extra=1.9)
        axs[1].sharex(axs[0])
        axs[1].sharey(axs[0])
        handles: dict[str, object] = {}
        th = np.linspace(float(ds.theta[0]), float(ds.theta[-1]), 600)
        ff = np.linspace(0.0, 2.0, 600)
        T, F = np.meshgrid(th, ff)
        for k, (ax, w) in enumerate(zip(axs, OMEGAS)):
            pplot.map_figure(_plain(ds.sel(omega=w)), "n_solutions", x="theta", ax=ax)
            study.collect_legend(ax, handles)
            s = 1 if w > 0 else -1
            ax.contour(th, ff, coefficient_s3(T, F, H_STAR, s), levels=[0.0],
                       colors=[S3_STYLE["color"]], linewidths=S3_STYLE["lw"],
                       linestyles=[S3_STYLE["ls"]], zorder=5).set_path_effects(pplot.HALO)
            if s < 0:
                ax.plot(th, painleve_f(th), zorder=5, **FLOOR_STYLE)
                ax.plot([THETA_STAR], [F_STAR], zorder=6, **STAR_STYLE)
                ax.set_ylim(0.0, 2.0)
            else:
                _corner(ax, ds.sel(omega=w))
            value = f"{w:g}".replace("-", "\u2212")
            ax.set_title(rf"({'abc'[k]}) $\omega$ = {value} rad s$^{{-1}}$", loc="left")
        pplot.outer_labels(axs)
        for ax in axs:  # one tick format in every panel ((c) shows a corner of (a)'s axes)
            ax.xaxis.set_major_formatter(FormatStrFormatter("%.2f"))
            ax.yaxis.set_major_formatter(FormatStrFormatter("%.2f"))
        handles["(S3) = 0: both contacts slipping"] = Line2D([], [], **S3_STYLE)
        handles[r"floor alone: $f = (1 + 3\cos^2\theta)/(3\sin\theta\,\cos\theta)$"] = \
            Line2D([], [], **FLOOR_STYLE)
        handles[r"$f^* = 2/\sqrt{3}$, $\tan\theta^* = 5/\sqrt{3}$"] = Line2D([], [],
                                                                            **STAR_STYLE)
        _legend(fig, handles, size, ds)
        pplot.define_symbols(fig, KEY + [PULL_KEY])
    return fig


def _corner(ax, ds) -> None:
    """Limit ``ax`` to the cells of ``ds`` with other than one solution, and a margin."""
    n = ds.n_solutions.transpose("f", "theta").values
    jj, ii = np.nonzero(n != 1)
    if not ii.size:
        return
    th, f = ds.theta.values, ds.f.values
    lo_t = th[max(ii.min() - 40, 0)]
    lo_f = f[max(jj.min() - 40, 0)]
    ax.set_xlim(lo_t, th[-1])
    ax.set_ylim(lo_f, f[-1])
    ax.xaxis.set_major_locator(MultipleLocator(0.05))  # ticks that two decimals state


def figure_slide(ds, t_off, size="two_column"):
    """theta(t) and omega(t) of the rod sliding down from rest until it leaves the step."""
    motion = {"color": "black", "lw": 1.2}
    leave = {"color": "black", "lw": 0.9, "ls": pplot.DASHES[1]}
    with pplot.style():
        fig, axs = pplot.panels(2, size, height=2.9, panel_height=1.8, extra=1.4, sharex=True)
        t = ds.t.values
        axs[0].plot(t, ds.theta.values, **motion)
        axs[0].axhline(theta_min(H_STAR), **leave)
        axs[0].set_ylabel(r"$\theta$ (rad)")
        axs[1].plot(t, ds.omega.values, **motion)
        axs[1].set_ylabel(r"$\omega$ (rad s$^{-1}$)")
        for ax, what in zip(axs, ("angle", "angular velocity")):
            ax.axvline(t_off, **leave)
            ax.set_xlim(0.0, t_off * 1.02)
            ax.set_xlabel(r"$t$ (s)")
            ax.set_title(what, loc="left")
        pplot.outer_labels(axs)
        pplot.label_panels(axs)
        head = pplot.wrap([rf"$\theta_0$ = {THETA_SLIDE:g} rad",
                           r"$\omega_0$ = 0 rad s$^{-1}$;", rf"$f$ = {F_SLIDE:g}", H_TEXT,
                           rf"$l$ = {L:g} m", rf"$g$ = {G:g} m s$^{{-2}}$", "$m$ = 1 kg"],
                          0.95 * fig.get_figwidth()).replace(";,", ";")
        pplot.figure_legend(fig, [Line2D([], [], **motion), Line2D([], [], **leave)],
                            ["simulate: both contacts slipping",
                             rf"$2l\sin\theta = h$: the rod leaves the step ($t$ = {t_off:.3f} s)"],
                            ncols=2 if _wide(size) else 1, title=head)
    return fig


# --------------------------------------------------------------------------- the study


def main(argv=None) -> list[Claim]:
    args = study.arguments(__doc__, argv)
    out, quick, files, claims = args.out, args.quick, [], []

    # 1. the kept-kept coefficient: (S3) against phasemap's own derivation
    motion = motion_maps(quick, out, files)
    T, F = study.mesh(motion, "theta", "f")
    agree, total = 0, 0
    for w in OMEGAS:
        s = 1 if w > 0 else -1
        coef = motion[f"coef_{KEPT[s]}"].sel(omega=w).transpose("theta", "f").values
        d = coefficient_s3(T, F, H_STAR, s)
        clear = np.abs(d) > 1e-9 * np.abs(d).max()
        agree += int((np.sign(coef) == np.sign(d))[clear].sum())
        total += int(clear.sum())
    claims.append(Claim(
        "(S3) is the kept-kept coefficient", "D = 3a^2 - (6a-4) sin^2 - f fe (3a-4) sin^2 + ...",
        f"sign of phasemap's coef layer = sign of (S3) on {agree}/{total} cells "
        f"(omega = {', '.join(f'{w:g}' for w in OMEGAS)})", verdict(agree == total > 0)))

    down = motion.sel(omega=OMEGAS[0])
    f0, th0 = first_zero(down, f"coef_{KEPT[-1]}")
    ok = abs(f0 - F_STAR) < 2e-3 and abs(th0 - THETA_STAR) < 0.05
    claims.append(Claim(
        "kept-kept coefficient first vanishes (omega < 0)",
        f"f* = 2/sqrt3 = {F_STAR:.4f} at theta* = {THETA_STAR:.4f} rad (h/l = {H_STAR:.4f})",
        f"coef layer: first zero at f = {f0:.4f}, theta = {th0:.3f} rad", verdict(ok)))

    # below f* no geometry is singular; above it some is (over theta and a in (0, 2])
    th = np.linspace(1e-3, math.pi / 2 - 1e-3, 1201)[:, None]
    a = np.linspace(1e-3, 2.0, 1201)[None, :]
    lo = min(float(coefficient_s3(th, F_STAR - 1e-3, a * L * np.sin(th), s).min())
             for s in (-1, 1))
    hi = float(coefficient_s3(th, F_STAR + 1e-3, a * L * np.sin(th), -1).min())
    claims.append(Claim(
        "no geometry is singular below f*", "(S3) keeps its sign for f < f*",
        f"least (S3) over theta, a <= 2, both s: {lo:.2e} at f* - 1e-3, {hi:.2e} at f* + 1e-3",
        verdict(lo > 0 > hi)))

    ends = []
    for w in (-0.5, -1.0, -2.0, -3.0, -4.0, -6.0):
        for f in (F_STAR - 0.01, F_STAR + 0.01):
            c = phasemap.classify(NAME, theta=THETA_STAR, omega=w, f=f, h=H_STAR, l=L)
            kept = [b.name for b in c.branches]
            ends.append((c.n_solutions, c.contact_lost, tuple(kept)))
    left = sorted({k[0] for _, _, k in ends})
    ok = all(n == 1 and lost for n, lost, _ in ends)
    claims.append(Claim(
        "at theta*, h* the count stays 1 across f*", "the rod leaves the floor or the edge",
        f"f* -+ 0.01, omega = -0.5...-6: {sum(n == 1 for n, _, _ in ends)}/{len(ends)} unique, "
        f"all contact lost ({', '.join(left)})", verdict(ok)))

    # 2. the paradoxes of the full enumeration in motion
    n_down = {w: motion.n_solutions.sel(omega=w).transpose("theta", "f").values
              for w in OMEGAS}
    floor = down[f"coef_{FLOOR_ONLY}"].transpose("theta", "f").values < 0
    same = bool(np.array_equal(n_down[-1.0] != 1, floor))
    fp, thp = first_zero(down, f"coef_{FLOOR_ONLY}")
    ok = same and abs(fp - 4.0 / 3.0) < 2e-3 and abs(thp - math.atan(2.0)) < 0.05
    claims.append(Claim(
        "omega = -1: no solution where the floor-only rod is singular",
        "(smallest paradox f: open in the doc)",
        f"n != 1 on {int((n_down[-1.0] != 1).sum())} cells, "
        f"{'exactly' if same else 'not'} where coef_{FLOOR_ONLY} < 0; its first zero "
        f"f = {fp:.4f} at theta = {thp:.3f} (Painleve: 4/3 at arctan 2)",
        verdict(ok, "finding")))

    scan = omega_scan(quick, out, files)
    lowest = {}
    for k in (0, 2, 4):
        best = (math.inf, math.nan, math.nan)
        for w in scan.omega.values:
            nn = scan.n_solutions.sel(omega=w).transpose("theta", "f").values
            fk, tk = least_f(scan, nn == k)
            if fk < best[0]:
                best = (fk, tk, float(w))
        lowest[k] = best
    txt = "; ".join(f"{N_TEXT[k]} from f = {v[0]:.3f} (theta {v[1]:.3f}, omega {v[2]:.2f})"
                    for k, v in lowest.items() if math.isfinite(v[0]))
    least = min(v[0] for v in lowest.values())
    claims.append(Claim(
        "omega < 0: smallest f of a paradox on the map",
        "open in the doc; above f* = 1.1547",
        f"{txt} (omega = -6...-0.5, step {np.diff(scan.f.values)[0]:.3g} in f)",
        verdict(all(math.isfinite(v[0]) for v in lowest.values()) and F_STAR < least
                < 4.0 / 3.0, "finding")))

    up = motion.sel(omega=1.0)
    kept_up = up[f"coef_{KEPT[1]}"].transpose("theta", "f").values < 0
    # below the edge theta = pi/2, where the rod lies on the step and the edge's own
    # modes (the floor's slip factor vanishes there) decide the count
    inner = np.broadcast_to(up.theta.values[:, None] < math.pi / 2, kept_up.shape)
    same_up = bool(np.array_equal((n_down[1.0] != 1)[inner], kept_up[inner]))
    a_top = H_STAR / L  # at theta = pi/2, a = h/l: (S3) = 3a^2 - 6a + 4 - f^2 (3a - 4)
    f_top = math.sqrt((3 * a_top ** 2 - 6 * a_top + 4) / (3 * a_top - 4))
    fu, tu = first_zero(up, f"coef_{KEPT[1]}")
    claims.append(Claim(
        "omega = +1: no solution where (S3) < 0", "-",
        f"n != 1 on {int((n_down[1.0] != 1).sum())} cells, {'exactly' if same_up else 'not'} "
        f"where the kept-kept coef < 0; first zero f = {fu:.4f} at theta = {tu:.3f} "
        f"((S3) at pi/2: {f_top:.4f})",
        verdict(same_up and abs(fu - f_top) < 2e-3 and abs(tu - math.pi / 2) < 1e-9,
                "finding")))

    c = phasemap.classify(NAME, theta=1.128, omega=-2.70, f=1.3, h=1.59, l=L)
    ok_names = [b.name for b in c.branches]
    claims.append(Claim(
        "three solutions (f = 1.3, h/l = 1.59, theta = 1.128, omega = -2.7)",
        "keep both, leave the floor, leave the edge",
        f"{N_TEXT[c.n_solutions]}: {', '.join(ok_names)}",
        verdict(c.n_solutions == 4 and len(ok_names) == 3)))

    # 3. at rest
    rest, low = rest_maps(quick, out, files)
    n_rest = rest.n_solutions.transpose("theta", "f").values
    stag = rest.stagnation.transpose("theta", "f").values == 1
    monotone = bool(np.all(np.diff(stag.astype(int), axis=1) >= 0))
    f_rest = [float(rest.f.values[np.argmax(row)]) for row in stag if row.any()]
    vertical = rest.theta.values == math.pi / 2  # the rod upright: the edge cannot slip
    claims.append(Claim(
        f"rest at h/l = {H_STAR:.4f}: stagnation region", "-",
        f"unique on {int((n_rest[~vertical] == 1).sum())}/{n_rest[~vertical].size} cells "
        f"below theta = pi/2 (upright: {N_TEXT[int(n_rest[vertical].max())]}, rest, as the "
        f"oracle says); rest possible on {100 * stag.mean():.0f} %, for f above a threshold "
        f"per theta ({min(f_rest):.2f}...{max(f_rest):.2f})",
        verdict(bool((n_rest == 1).all()) and bool(stag[vertical].all()) and vertical.any()
                and monotone and stag.any() and not stag.all(), "finding")))

    c = phasemap.classify(NAME, theta=1.30478, omega=0.0, f=0.5, h=0.60257, l=L)
    slip = [b for b in c.branches if b.name != "stick"]
    acc = slip[0].accelerations["theta_ddot"] if len(slip) == 1 else math.nan
    claims.append(Claim(
        "rest and sliding from rest coexist (f = 0.5, h/l = 0.60257)",
        "theta'' = -0.0817 rad/s^2, both slipping",
        f"{N_TEXT[c.n_solutions]}: {', '.join(b.name for b in c.branches)}; theta'' = {acc:.4f}",
        verdict(c.n_solutions == 2 and c.stagnation and len(slip) == 1
                and slip[0].name == KEPT[-1] and abs(acc + 0.0817) < 5e-5)))

    n_low = low.n_solutions.transpose("theta", "f").values
    stag_low = low.stagnation.transpose("theta", "f").values == 1
    two = n_low == 2
    f2, t2 = least_f(low, two)
    claims.append(Claim(
        f"rest at h/l = {H_LOW:g}: rest and sliding from rest", "ambiguous at f = 0.5",
        f"two solutions on {int(two.sum())} cells, all with rest possible: "
        f"{bool(stag_low[two].all())}; smallest f = {f2:.3f} (theta = {t2:.3f} rad)",
        verdict(bool(two.any() and stag_low[two].all()) and f2 < 0.5, "finding")))

    # 4. the slide from rest, off the step
    start = phasemap.classify(NAME, theta=THETA_SLIDE, omega=0.0, f=F_SLIDE, h=H_STAR, l=L)
    traj, t_off = slide(out, files)
    e = energy(traj.theta.values, traj.omega.values, H_STAR)
    index = [b.name for b in MODEL.candidates].index(KEPT[-1])
    kept = bool(np.all(traj.branch.values[1:] == index))
    falls = bool(np.all(np.diff(e) <= 1e-9 * abs(e).max()))
    claims.append(Claim(
        "the rod slides down from rest off the step",
        "-",
        f"theta0 = {THETA_SLIDE:g}, f = {F_SLIDE:g} (no rest: {not start.stagnation}): both "
        f"slipping ({kept}) until 2 l sin theta = h at t = {t_off:.4f} s, omega = "
        f"{float(traj.omega[-1]):.3f} rad/s; energy falls ({falls}) by "
        f"{e[0] - e[-1]:.3f} J",
        verdict(not start.stagnation and kept and falls and e[0] > e[-1], "finding")))
    th_end = float(traj.theta[-1])
    claims.append(Claim(
        "the motion ends where the rod leaves the step", "-",
        f"simulate ends '{traj.attrs['end_reason']}' at theta = {th_end:.9f}; "
        f"2 l sin theta = h at theta = {theta_min(H_STAR):.9f}",
        verdict(traj.attrs["end_reason"] == "left_domain"
                and abs(th_end - theta_min(H_STAR)) < 1e-8, "finding")))

    for name, draw in (("rest", lambda size: figure_rest(rest, low, size)),
                       ("motion", lambda size: figure_motion(motion, size)),
                       ("slide", lambda size: figure_slide(traj, t_off, size))):
        files += study.save_figures(draw, out, f"{NAME}_{name}", args.sizes)

    study.finish("Rod on a step", claims, files)
    return claims


if __name__ == "__main__":
    main()
