"""Study: the ladder (Lapshin 2021, Fig. 1, eq. (6)-(9)), from atlases and phase curves.

A homogeneous bar of length 2l leans against a rough wall and stands on a
rough floor, with the same friction coefficient f at both ends.  Equation
(8), 2 l (2 - f^2) phi'' = 3 [2 f l phi'^2 - 2 f g cos phi + (1 - f^2) g sin phi],
loses its senior derivative at f = sqrt 2.  This study

* maps ``n_solutions``, ``contact_lost``, ``stagnation`` and ``singular`` over
  (phi, f) at omega = 0, 1 and 3 rad/s, checks that ``singular`` is set on the
  row f = sqrt 2 and nowhere else, and that at f = sqrt 2 there is no solution
  unless the right side of (8) vanishes (then a continuum);
* measures the static zone (rest possible) from the atlas at omega = 0 and
  compares it with phasemap's sharp form phi <= 2 arctan f (the classical
  tan phi <= 2 f / (1 - f^2) for f < 1, the whole range for f >= 1);
* draws phase portraits omega^2(phi) for f below and above sqrt 2, each curve
  marked by how it ends (rest, contact lost, the bar lying flat);
* checks the paper's printed formulas, eq. (8), the reactions after (7) and the
  first integral's coefficients, against an unreduced Newton-Euler solve and a
  tight time integration: the errata in the README.

    python studies/ladder.py [--quick] [--out DIR]

Writes ``ladder_*.nc`` atlases and ``ladder_*.pdf``/``.png`` figures, and ends
with the table of the claims checked, measured value beside the paper's.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

import phasemap
from phasemap.claims import threshold_claims
from phasemap import plot as pplot
from phasemap.study import (Claim, arguments, collect_legend, finish, save_atlas,
                            save_figures, verdict)

STUDY = "ladder"
SQRT2 = math.sqrt(2.0)
G = 9.81
#: The angular velocities of the solvability panels (rad/s).
OMEGAS = (0.0, 1.0, 3.0)
#: Friction coefficients of the phase portraits: below and above sqrt 2.
PORTRAIT_F = (0.8, 2.0)
#: Initial states (phi0, omega0 > 0, as in (6)) of the phase portraits, per f.
STARTS = {
    0.8: [(0.45, 0.8), (0.5, 2.0), (0.7, 1.5), (0.9, 0.5), (1.0, 2.0), (1.2, 0.5), (1.3, 1.0)],
    2.0: [(0.9, 4.5), (1.2, 3.2), (1.5, 2.8)],
}
#: f values at which the static-zone boundary is measured (f < 1: 2 arctan f < pi/2).
STATIC_F = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
#: Top of the omega^2 axis of each phase portrait (rad2 s-2).
U_TOP = {0.8: 6.0, 2.0: 22.0}


def main(argv=None) -> list[Claim]:
    args = arguments(__doc__, argv)
    out = args.out
    # the class boundaries are drawn exactly (phasemap.boundaries), so the quick maps need
    # no print resolution for them: a cell of about 3 px at 300 dpi keeps the overlays'
    # edges smooth; n_f odd: f = sqrt 2 mid-axis
    n_phi, n_f = (361, 281) if args.quick else (721, 1001)
    files, claims = [], []

    # -- solvability over (phi, f) at several omega ---------------------------------
    phi = np.linspace(0.0, math.pi / 2, n_phi)
    f = np.linspace(0.0, 2.0 * SQRT2, n_f)
    atlas = phasemap.Scene(
        "ladder", axes={"phi": phi, "f": f, "omega": list(OMEGAS)},
        layers=["n_solutions", "stagnation", "contact_lost", "singular"]).compute()
    files.append(save_atlas(atlas, out, "ladder_solvability", STUDY))
    claims += singular_line_claims(atlas)
    claims += static_zone_claims(atlas.sel(omega=0.0))
    files += save_figures(lambda size: solvability_figure(atlas, size), out,
                          "ladder_solvability", args.sizes)

    # -- phase portraits omega^2(phi), f below and above sqrt 2 ---------------------
    regions, curves = portraits(181 if args.quick else n_phi)  # drawn from closed forms
    files.append(save_atlas(regions, out, "ladder_portraits", STUDY))
    claims += portrait_claims(curves)
    files += save_figures(lambda size: portrait_figure(regions, curves, size), out,
                          "ladder_portraits", args.sizes)

    # -- errata: (8), the reactions after (7), the first integral ------------------
    errata = phasemap.Scene(
        "ladder", axes={"phi": phi, "f": np.linspace(0.0, 1.3, n_f)},
        fixed={"omega": 1.0, "l": 0.5, "m": 2.0},
        layers=["phi_ddot_slide_pos", "N_floor_slide_pos", "N_wall_slide_pos"]).compute()
    files.append(save_atlas(errata, out, "ladder_errata", STUDY))
    claims += equation8_claims(errata)
    integrals = first_integral_runs()
    claims += first_integral_claims(integrals)
    files += save_figures(lambda size: first_integral_figure(integrals, size), out,
                          "ladder_first_integral", args.sizes)

    claims += threshold_claims("ladder")  # exact, beside the closed form
    finish("ladder study", claims, files)
    return claims


# --------------------------------------------------------------------------- the singular line


def singular_line_claims(atlas: xr.Dataset) -> list[Claim]:
    f = atlas.f.values
    row = int(np.argmin(np.abs(f - SQRT2)))
    on_grid = abs(f[row] - SQRT2) <= 1e-12
    sing = atlas.singular.transpose("f", "phi", "omega").values == 1
    others = np.delete(sing, row, axis=0)
    exact = bool(on_grid and sing[row].all() and not others.any())
    claims = [Claim(
        "ladder: coefficient 2 - f^2 of (8) vanishes (singular)", "at f = sqrt 2",
        f"on the row f = {f[row]:.6f} only: {int(sing[row].sum())}/{sing[row].size} cells; "
        f"{int(others.sum())} elsewhere", verdict(exact))]

    # at f = sqrt 2 and omega != 0: no solution unless the right side of (8) vanishes
    moving = atlas.n_solutions.sel(omega=[w for w in OMEGAS if w != 0.0]).isel(f=row)
    n_none = int((moving == 0).sum())
    # the right side vanishes where 2 sqrt2 l omega^2 = g (2 sqrt2 cos phi + sin phi):
    # for l = 1 an omega in (sqrt(g / (2 sqrt 2)), sqrt(3 g / (2 sqrt 2))); take omega = 3
    w, l = 3.0, 1.0
    phi_zero = _brent(lambda p: 2 * SQRT2 * l * w * w - G * (2 * SQRT2 * math.cos(p)
                                                            + math.sin(p)), 0.0, math.pi / 2)
    # (8) is the kept slide: every solution on the row leaves a contact (contact_lost)
    left = atlas.contact_lost.sel(omega=[w for w in OMEGAS if w != 0.0]).isel(f=row) == 1
    n_left = int(((moving > 0) & left).sum())
    c = phasemap.classify("ladder", phi=phi_zero, omega=w, f=SQRT2, l=l, g=G)
    ok = n_none + n_left == moving.size and c.n_solutions == 3 and c.singular
    claims.append(Claim(
        "ladder: at f = sqrt 2 (8) has no solution ...", "unless its right side vanishes",
        f"(8) in no cell of {moving.size} (omega = 1, 3): none in {n_none}, a contact left "
        f"in {n_left}; at phi = {phi_zero:.4f}, omega = 3 (right side 0): "
        f"{_N_TEXT[c.n_solutions]}", verdict(ok)))

    # away from the line, the only cells with no solution are contact losses
    n = atlas.n_solutions.transpose("f", "phi", "omega").values
    lost = atlas.contact_lost.transpose("f", "phi", "omega").values == 1
    off = np.ones(f.size, bool)
    off[row] = False
    sing_off = atlas.singular.transpose("f", "phi", "omega").values[off] == 1
    below = f[off] < SQRT2
    none_off, two_off = n[off] == 0, n[off] == 2
    # (8) is resolved for phi'' off the line; what the whole problem (contacts may
    # open) has there is counted, a finding of its own (README, findings)
    claims.append(Claim(
        "ladder: (8), both contacts kept, solvable for phi'' when f != sqrt 2",
        "yes (resolved for phi'')",
        f"never singular off the line; with contacts that may open, f < sqrt 2: none "
        f"{100 * none_off[below].mean():.1f} %, two {100 * two_off[below].mean():.1f} %, "
        f"leaves a contact {100 * (lost[off][below] & (n[off][below] == 1)).mean():.0f} %; "
        f"f > sqrt 2: none {100 * none_off[~below].mean():.0f} %, two "
        f"{100 * two_off[~below].mean():.0f} %", verdict(not sing_off.any())))
    return claims


_N_TEXT = {0: "no solution", 1: "unique", 2: "two solutions", 3: "continuum",
           4: "three or more"}


def _brent(fn, a: float, b: float) -> float:
    from scipy.optimize import brentq

    return float(brentq(fn, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps))


# --------------------------------------------------------------------------- the static zone


def static_zone_claims(rest: xr.Dataset) -> list[Claim]:
    """Boundary of the stagnation cells at omega = 0 against phi = 2 arctan f."""
    phi, f = rest.phi.values, rest.f.values
    step = phi[1] - phi[0]
    stag = rest.stagnation.transpose("f", "phi").values == 1
    worst, checked, below = 0.0, [], True
    for target in STATIC_F:
        i = int(np.argmin(np.abs(f - target)))
        # rest must hold on [0, boundary] and fail beyond it: one interval from phi = 0,
        # ending at the last grid angle at or below 2 arctan f
        inside = np.flatnonzero(stag[i])
        contiguous = inside.size > 0 and inside[0] == 0 and np.all(np.diff(inside) == 1)
        err = 2.0 * math.atan(f[i]) - phi[inside[-1]] if contiguous else math.inf
        below = below and -1e-12 <= err < step
        worst = max(worst, abs(err))
        checked.append(f[i])
    high = f >= 1.0
    whole = bool(stag[high].all())
    return [
        Claim("ladder: static zone at omega = 0, f < 1",
              "tan phi <= 2f/(1 - f^2) (classical; not in the paper)",
              f"last rest cell within one step below 2 arctan f (worst {worst / step:.2f} "
              f"step) at f = {checked[0]:.2f}...{checked[-1]:.2f}", verdict(below, "finding")),
        Claim("ladder: static zone at omega = 0, f >= 1",
              "tan phi <= 2f/(1 - f^2) reads: none (f > 1)",
              f"rest possible at every phi in [0, pi/2] for all {int(high.sum())} rows "
              f"f >= 1 (phi <= 2 arctan f)", verdict(whole, "finding")),
    ]


#: The closed-form boundary of the static zone, a reference curve.
REST_BOUNDARY = {"color": "black", "lw": 1.0, "ls": pplot.DASHES[1], "path_effects": pplot.HALO}


def solvability_figure(atlas: xr.Dataset, size="two_column"):
    """n_solutions over (phi, f) at each omega, overlays, f = sqrt 2 and 2 arctan f, and the
    exact class boundaries traced by phasemap.boundaries."""
    from matplotlib.lines import Line2D

    with pplot.style():
        fig, axes = pplot.panels(len(OMEGAS), size, height=3.0, panel_height=1.9,
                                 extra=1.3, sharex=True, sharey=True)
        handles: dict[str, object] = {}
        for k, (ax, w) in enumerate(zip(axes, OMEGAS)):
            # the exact class boundaries (phasemap.boundaries) over the cells
            pplot.map_figure(atlas.sel(omega=w), "n_solutions", x="phi", ax=ax,
                             boundaries=True)
            collect_legend(ax, handles)
            if w == 0.0:
                ff = np.linspace(0.0, 1.0, 200)
                ax.plot(2 * np.arctan(ff), ff, zorder=4, **REST_BOUNDARY)
            ax.set_title(rf"({'abc'[k]}) $\omega$ = {w:g} rad s$^{{-1}}$", loc="left")
        pplot.outer_labels(axes)
        n = atlas.n_solutions.transpose("f", ...).values
        lost = atlas.contact_lost.transpose("f", ...).values == 1
        off_line = np.abs(atlas.f.values - SQRT2) > 1e-12
        if "none" in handles and not ((n == 0) & ~lost)[off_line].any():
            handles[r"none (on $f = \sqrt{2}$ only)"] = handles.pop("none")
        if "class boundary" in handles:  # beside the other curves, after the classes
            handles["class boundary"] = handles.pop("class boundary")
        if "singular" in handles:  # the coefficient 2 - f^2 of (8) vanishes
            handles[r"singular: $f = \sqrt{2}$"] = handles.pop("singular")
        # the continuum is the ladder lying flat at rest: the edge column phi = pi/2 of
        # (a), too thin to see, so named in the key rather than the legend
        flat = handles.pop("continuum", None) is not None
        handles[r"$\varphi = 2\,\arctan f$ (rest boundary)"] = Line2D([], [], **REST_BOUNDARY)
        order = ["unique", "contact lost", "a contact would pull", "stagnation"]
        keys = sorted(handles, key=lambda s: order.index(s) if s in order else len(order))
        pplot.figure_legend(fig, [handles[k] for k in keys], keys, ncols=_half(keys, size),
                            title=pplot.fixed_values_text(atlas, 0.95 * fig.get_figwidth()))
        if flat:
            pplot.define_symbols(fig, [r"a continuum at rest where the ladder lies flat "
                                       r"($\varphi = \pi/2$, the right edge of (a))"])
    return fig


# --------------------------------------------------------------------------- phase portraits


def portraits(n_phi: int):
    """The contact-loss regions over (phi, omega^2) and the phase curves, per f."""
    u_max, n_u = 22.0, max(200, n_phi)
    u = (np.arange(n_u) + 0.5) * u_max / n_u  # cell centres: omega = 0 is the rest line
    regions = phasemap.Scene(
        "ladder", axes={"phi": np.linspace(0.0, math.pi / 2, n_phi), "omega": np.sqrt(u),
                        "f": list(PORTRAIT_F)},
        layers=["n_solutions", "contact_lost", "phi_ddot_slide_pos"]).compute()
    curves = {f: [phasemap.phase_curve("ladder", phi=p, omega=w, f=f) for p, w in STARTS[f]]
              for f in PORTRAIT_F}
    return regions, curves


def portrait_claims(curves) -> list[Claim]:
    ends = [(f, pc) for f in PORTRAIT_F for pc in curves[f]]
    rests = [(f, float(pc.stage_end_phi[-1])) for f, pc in ends
             if pc.attrs["end_reason"] == "rest"]
    inside = all(p <= 2 * math.atan(f) + 1e-12 for f, p in rests)
    kinds = sorted({pc.attrs["end_reason"] for _, pc in ends})
    return [
        Claim("ladder: the phase curves stop only in the static zone", "-",
              f"{len(rests)}/{len(ends)} curves end at rest, all at phi <= 2 arctan f; "
              f"ends seen: {', '.join(kinds)}", verdict(bool(rests) and inside, "finding")),
    ]


def _half(labels, size) -> int | None:
    """Two rows of legend entries at two-column width; as many columns as fit otherwise."""
    return -(-len(labels) // 2) if pplot.width_of(size) >= pplot.WIDE else None


def portrait_figure(regions: xr.Dataset, curves, size="two_column"):
    """(a) below sqrt 2: phase curves omega^2(phi) to rest or contact loss, over the region
    where a contact would pull; (b) above sqrt 2: no sliding motion at all, every state
    with omega > 0 indeterminate or leaving a contact, drawn as the map it is."""
    from matplotlib.lines import Line2D

    blue = pplot.OKABE_ITO["blue"]
    c_zero = {"color": "black", "lw": 0.9, "ls": pplot.DASHES[2], "path_effects": pplot.HALO}
    with pplot.style():
        fig, axes = pplot.panels(len(PORTRAIT_F), size, height=3.3, panel_height=2.3,
                                 extra=1.9)
        handles: dict[str, object] = {}
        for k, (ax, f) in enumerate(zip(axes, PORTRAIT_F)):
            reg = regions.sel(f=f)
            if f < SQRT2:
                # every cell but where a contact would pull has one motion: the panel is
                # "unique" as in (b), its grey under the hatch and the curves
                n = reg.n_solutions.transpose("phi", "omega").values
                lost = reg.contact_lost.transpose("phi", "omega").values == 1
                if not np.all((n == 1) | lost):
                    raise AssertionError(f"f = {f}: a class other than unique off the "
                                         "contact region")
                ax.set_facecolor(pplot.CATEGORY_COLOURS["unique"])
                _pull_region(ax, f, U_TOP[f], blue, check=reg)
                for pc in curves[f]:
                    pplot.phase_curve_figure(pc, squared=True, ax=ax)
                    collect_legend(ax, handles)
                title = rf"$f$ = {f:g} < $\sqrt{{2}}$, $2\,\arctan f$ = {2 * math.atan(f):.2f} rad"
            else:
                _squared_map(ax, reg)
                collect_legend(ax, handles)
                for pc in curves[f]:  # each start is indeterminate at once: no curve
                    pplot.mark_event(ax, str(pc.attrs["end_reason"]), float(pc.phi[0]),
                                     float(pc.omega[0]) ** 2)
                handles.setdefault("indeterminate", pplot.event_handle("indeterminate"))
                title = (rf"$f$ = {f:g} > $\sqrt{{2}}$: no sliding motion from any start "
                         r"($\omega > 0$)")
            _, a, b = _coefficients(f, 1.0, corrected=True)
            pp = np.linspace(0.0, math.pi / 2, 200)
            ax.plot(pp, a * np.sin(pp) + b * np.cos(pp), zorder=2, **c_zero)
            ax.set_xlim(0.0, math.pi / 2)
            ax.set_ylim(0.0, U_TOP[f])
            ax.set_ylabel(r"$\omega^2$ (rad$^{2}$ s$^{-2}$)")
            ax.set_title(pplot.wrap([f"({'ab'[k]}) " + title], 0.45 * pplot.width_of(size)
                                    if pplot.width_of(size) >= pplot.WIDE else
                                    0.95 * pplot.width_of(size)), loc="left")
        if "left domain" in handles:
            handles[r"lying flat ($\varphi = \pi/2$)"] = handles.pop("left domain")
        handles.setdefault("a contact would pull", pplot.overlay_patch("contact_lost"))
        handles[r"$c = 0$: $\omega^2 = a\,\sin\varphi + b\,\cos\varphi$"] = Line2D([], [], **c_zero)
        order = ["start", "rest", "contact lost", r"lying flat ($\varphi = \pi/2$)",
                 "indeterminate", "two"]
        keys = sorted(handles, key=lambda s: order.index(s) if s in order else len(order))
        pplot.figure_legend(fig, [handles[k] for k in keys], keys, ncols=_half(keys, size),
                            title=r"$\omega > 0$ (sliding down), $l$ = 1 m, "
                                  r"$g$ = 9.81 m s$^{-2}$, $m$ = 1 kg")
        pplot.define_symbols(fig, INTEGRAL_KEY)
    return fig


def _squared_map(ax, reg: xr.Dataset) -> None:
    """n_solutions of ``reg`` over (phi, omega^2), contact_lost hatched."""
    u = reg.omega.values ** 2
    ds = reg[["n_solutions", "contact_lost"]].assign_coords(omega=u).rename(
        omega="omega_squared")
    ds["omega_squared"].attrs = {"units": "rad2 s-2", "long_name": "square of the angular "
                                 "velocity", "phasemap_symbol": r"\omega^2"}
    pplot.map_figure(ds, "n_solutions", x="phi", ax=ax)


#: The symbols of the first integral, for the key under a figure.
INTEGRAL_KEY = [
            r"first integral of (8): $\omega^2 = c\,e^{\lambda\varphi} + a\,\sin\varphi"
            r" + b\,\cos\varphi$",
            r"$\lambda = 6f/(2 - f^2)$",
            r"$a = -6fg(5 - 4f^2)/(lq)$",
            r"$b = -3g(2 - 15f^2 + f^4)/(lq)$",
            r"$q = 4 + 32f^2 + f^4$",
            r"$c$: the constant fixed by the start"]


def _pull_region(ax, f: float, u_top: float, colour: str, check: xr.Dataset) -> None:
    """Hatch where a contact would pull (N_floor or N_wall < 0, omega > 0) over (phi, omega^2).

    The boundary is the zero contour of min(N_floor, N_wall) from the unreduced
    Newton-Euler solve on a fine grid, so it is drawn as the smooth curve it is;
    on the atlas's own grid that sign is where phasemap's kept slide (omega > 0) is not
    admissible, cell by cell: there the bar leaves a contact, or no motion is consistent.
    """
    phi, w = check.phi.values[:, None], check.omega.values[None, :]
    _, n1, n2 = _unreduced(phi, w, np.full(np.broadcast_shapes(phi.shape, w.shape), f), 1.0, 1.0)
    lost = np.isnan(check.phi_ddot_slide_pos.transpose("phi", "omega").values)
    # the row where the bar lies flat (phi = pi/2) is decided by the edge's own modes
    # (the foot's slip factor vanishes there), not by the slide's closed form
    inner = np.broadcast_to(phi < np.pi / 2, lost.shape)
    if not np.array_equal((np.minimum(n1, n2) < 0)[inner], lost[inner]):
        raise AssertionError("the closed-form contact region differs from contact_lost")
    pp = np.linspace(0.0, math.pi / 2, 600)
    uu = np.linspace(1e-6, u_top, 600)
    P, U = np.meshgrid(pp, uu, indexing="xy")
    _, n1, n2 = _unreduced(P, np.sqrt(U), np.full_like(P, f), 1.0, 1.0)
    low = np.minimum(n1, n2)
    if not (low < 0).any():
        return
    look = pplot.OVERLAYS["contact_lost"]
    ax.contourf(pp, uu, low, levels=[low.min() - 1.0, 0.0], colors="none",
                hatches=[look.hatch]).set_hatchcolor(look.colour)
    ax.contour(pp, uu, low, levels=[0.0], colors=[look.colour], linewidths=0.6,
               linestyles=look.linestyle)


# --------------------------------------------------------------------------- errata


def _unreduced(phi, omega, f, l, m, g=G):
    """phi'', N_floor, N_wall (omega > 0) from momentum and angular momentum, unreduced.

    Unknowns z = (phi'', N1, N2); the bottom end slides away from the wall, so
    friction is -f N1 (x) at the floor and +f N2 (y) at the wall:
      m (l cos phi phi'' - l sin phi omega^2) = N2 - f N1
      m (-l sin phi phi'' - l cos phi omega^2) = -m g + N1 + f N2
      (m l^2 / 3) phi'' = (N1 - f N2) l sin phi - (N2 + f N1) l cos phi
    """
    phi, f = np.broadcast_arrays(np.asarray(phi, float), np.asarray(f, float))
    s, c = np.sin(phi), np.cos(phi)
    A = np.zeros(phi.shape + (3, 3))
    rhs = np.zeros(phi.shape + (3,))
    A[..., 0, :] = np.stack([m * l * c, f, -np.ones_like(f)], -1)
    rhs[..., 0] = m * l * s * omega ** 2
    A[..., 1, :] = np.stack([-m * l * s, -np.ones_like(f), -f], -1)
    rhs[..., 1] = -m * g + m * l * c * omega ** 2
    A[..., 2, :] = np.stack([np.full_like(f, m * l * l / 3.0), -l * s + f * l * c,
                             f * l * s + l * c], -1)
    z = np.linalg.solve(A, rhs[..., None])[..., 0]
    return z[..., 0], z[..., 1], z[..., 2]


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.max(np.abs(a[ok] - b[ok])) / np.max(np.abs(b[ok])))


def equation8_claims(ds: xr.Dataset) -> list[Claim]:
    """(8) and the reactions after (7), printed and corrected, against the unreduced solve."""
    l, m, w = (float(ds.attrs[f"phasemap_fixed_{k}"]) for k in ("l", "m", "omega"))
    phi = ds.phi.values[:, None]
    f = ds.f.values[None, :]
    acc, n1, n2 = _unreduced(phi, w, f, l, m)
    rhs = 3.0 * (2.0 * f * w * w - 2.0 * f * G * np.cos(phi) + (1.0 - f * f) * G * np.sin(phi))
    printed = rhs / (2.0 * (2.0 - f * f))
    rhs_l = 3.0 * (2.0 * f * l * w * w - 2.0 * f * G * np.cos(phi)
                   + (1.0 - f * f) * G * np.sin(phi))
    corrected = rhs_l / (2.0 * l * (2.0 - f * f))
    mine = ds.phi_ddot_slide_pos.transpose("phi", "f").values
    e_printed, e_fixed, e_mine = _rel(printed, acc), _rel(corrected, acc), _rel(mine, acc)
    claims = [Claim(
        f"ladder (8) at l = {l:g}: 2(2 - f^2) phi'' = 3[2f phi'^2 - ...]",
        "printed without l",
        f"vs Newton-Euler: printed {e_printed:.0%} off; with l {e_fixed:.0e}; "
        f"phasemap {e_mine:.0e}",
        verdict(e_printed > 1e-2 and e_fixed < 1e-9 and e_mine < 1e-9, "erratum"))]

    # the reactions after (7): N1 = (-f x'' + g + y'')/(1 + f^2), N2 = (x'' + f (g + y''))/(1 + f^2)
    xdd = l * np.cos(phi) * acc - l * np.sin(phi) * w * w
    ydd = -l * np.sin(phi) * acc - l * np.cos(phi) * w * w
    p1 = (-f * xdd + G + ydd) / (1 + f * f)
    p2 = (xdd + f * (G + ydd)) / (1 + f * f)
    mine1 = ds.N_floor_slide_pos.transpose("phi", "f").values
    mine2 = ds.N_wall_slide_pos.transpose("phi", "f").values
    e_printed = max(_rel(p1, n1), _rel(p2, n2))
    e_fixed = max(_rel(m * p1, n1), _rel(m * p2, n2))
    e_mine = max(_rel(mine1, n1), _rel(mine2, n2))
    claims.append(Claim(
        f"ladder N1, N2 after (7) at m = {m:g}", "printed without m",
        f"vs Newton-Euler: printed {e_printed:.0%} off; times m {e_fixed:.0e}; "
        f"phasemap {e_mine:.0e}",
        verdict(e_printed > 1e-2 and e_fixed < 1e-9 and e_mine < 1e-9, "erratum")))
    return claims


def _coefficients(f: float, l: float, corrected: bool, with_l: bool = True,
                  g: float = G) -> tuple[float, float, float]:
    """(lam, a, b) of omega^2 = c e^{lam phi} + a sin phi + b cos phi for omega > 0.

    ``corrected=False``: b as printed (-7 f^2); ``with_l=False``: no 1/l (as printed).
    """
    q = 4.0 + 32.0 * f * f + f ** 4
    lam = 6.0 * f / (2.0 - f * f)
    scale = l if with_l else 1.0
    a = -6.0 * f * g * (5.0 - 4.0 * f * f) / (scale * q)
    b = -3.0 * g * (2.0 - (15.0 if corrected else 7.0) * f * f + f ** 4) / (scale * q)
    return lam, a, b


def _integral(phi, phi0, omega0, lam, a, b):
    c0 = omega0 ** 2 - a * math.sin(phi0) - b * math.cos(phi0)
    return c0 * np.exp(lam * (phi - phi0)) + a * np.sin(phi) + b * np.cos(phi)


#: First-integral runs: (l, f, phi0, omega0), one stage from (phi0, omega0) to contact loss.
INTEGRAL_RUNS = ((1.0, 0.3, 0.7, 0.5), (0.5, 0.3, 0.7, 0.5 * math.sqrt(2.0)))


def first_integral_runs() -> list[dict]:
    """A tight time integration of (8) (simulate) and phase_curve, per run."""
    runs = []
    for l, f, phi0, omega0 in INTEGRAL_RUNS:
        tr = phasemap.simulate("ladder", t_end=5.0, rtol=1e-11, phi=phi0, omega=omega0, f=f,
                               l=l, g=G, through_contacts=False)
        # the integrator's own steps; the event states after the start come from its
        # dense output and are checked separately
        step = ~np.isin(tr.t.values, tr.event_t.values[1:])
        pc = phasemap.phase_curve("ladder", phi=phi0, omega=omega0, f=f, l=l, g=G)
        runs.append({"l": l, "f": f, "phi0": phi0, "omega0": omega0,
                     "phi": tr.phi.values[step], "u": tr.omega.values[step] ** 2,
                     "event_phi": tr.event_phi.values[1:],
                     "event_u": tr.event_omega.values[1:] ** 2,
                     "end": tr.attrs["end_reason"], "curve": pc})
    return runs


def first_integral_claims(runs) -> list[Claim]:
    claims = []
    r1, r2 = runs
    # b: -7 f^2 (printed) vs -15 f^2 at l = 1
    err = {}
    for name, corrected in (("printed", False), ("fixed", True)):
        lam, a, b = _coefficients(r1["f"], r1["l"], corrected)
        err[name] = _rel(_integral(r1["phi"], r1["phi0"], r1["omega0"], lam, a, b), r1["u"])
    claims.append(Claim(
        f"ladder first integral, b (l = 1, f = {r1['f']:g})", "b = -3g(2 - 7f^2 + f^4)/(...)",
        f"vs time integration: printed {err['printed']:.0%} off; -15f^2 {err['fixed']:.0e}",
        verdict(err["printed"] > 1e-2 and err["fixed"] < 1e-7, "erratum")))
    # 1/l in a and b at l = 0.5 (b already corrected)
    for name, with_l in (("printed", False), ("fixed", True)):
        lam, a, b = _coefficients(r2["f"], r2["l"], True, with_l=with_l)
        err[name] = _rel(_integral(r2["phi"], r2["phi0"], r2["omega0"], lam, a, b), r2["u"])
    claims.append(Claim(
        f"ladder first integral, a and b (l = {r2['l']:g})", "a, b without 1/l",
        f"vs time integration: printed {err['printed']:.0%} off; with 1/l {err['fixed']:.0e}",
        verdict(err["printed"] > 1e-2 and err["fixed"] < 1e-7, "erratum")))
    # the corrected integral along the integration: its steps and its event state
    lam, a, b = _coefficients(r1["f"], r1["l"], True)
    scale = np.max(r1["u"])
    e_steps = _rel(_integral(r1["phi"], r1["phi0"], r1["omega0"], lam, a, b), r1["u"])
    e_event = float(np.max(np.abs(_integral(r1["event_phi"], r1["phi0"], r1["omega0"], lam, a, b)
                                  - r1["event_u"]))) / scale
    pc = r1["curve"]
    e_pc = abs(float(pc.stage_end_phi[-1]) - float(r1["event_phi"][-1]))
    claims.append(Claim(
        "ladder: (8) has a first integral for f != sqrt 2",
        "omega^2 = c e^{lam phi} + a sin phi + b cos phi",
        f"time integration: steps {e_steps:.0e}, {r1['end'].replace('_', ' ')} event state "
        f"{e_event:.0e}; phase_curve ends {e_pc:.0e} rad from it",
        verdict(e_steps < 1e-7 and e_event < 1e-7 and e_pc < 1e-7)))
    return claims


def first_integral_figure(runs, size="two_column"):
    """The first integral as printed and corrected against a time integration of (8), to
    where the motion ends (a contact is lost: the curves end there)."""
    from matplotlib.lines import Line2D

    printed = {"color": "black", "lw": 1.0, "ls": pplot.DASHES[1], "path_effects": pplot.HALO}
    corrected = {"color": "black", "lw": 1.0, "ls": pplot.DASHES[0]}
    steps = {"ls": "none", "marker": "o", "ms": 3.0, "mfc": "none", "mec": pplot.GREY,
             "mew": 0.8}
    with pplot.style():
        fig, axes = pplot.panels(2, size, height=3.0, panel_height=2.0, extra=1.6)
        for k, (ax, run) in enumerate(zip(axes, runs)):
            pp = np.linspace(run["phi0"], run["phi"].max(), 300)
            if k == 0:
                lam, a, b = _coefficients(run["f"], run["l"], False)
                wrong = r"printed $b$ has $-7f^2$"
            else:
                lam, a, b = _coefficients(run["f"], run["l"], True, with_l=False)
                wrong = r"printed $a$, $b$ lack $1/l$"
            ax.plot(pp, _integral(pp, run["phi0"], run["omega0"], lam, a, b), **printed)
            lam, a, b = _coefficients(run["f"], run["l"], True)
            ax.plot(pp, _integral(pp, run["phi0"], run["omega0"], lam, a, b), **corrected)
            every = max(1, run["phi"].size // 25)
            ax.plot(run["phi"][::every], run["u"][::every], **steps)
            pplot.mark_event(ax, run["end"], run["event_phi"][-1], run["event_u"][-1])
            ax.set_xlabel(r"$\varphi$ (rad)")
            ax.set_ylabel(r"$\omega^2$ (rad$^{2}$ s$^{-2}$)")
            ax.set_title(rf"({'ab'[k]}) $l$ = {run['l']:g} m, $\omega_0$ = {run['omega0']:.3g} "
                         rf"rad s$^{{-1}}$:" + "\n" + wrong, loc="left")
        end = runs[0]["end"].replace("_", " ")
        pplot.figure_legend(fig, [Line2D([], [], **printed), Line2D([], [], **corrected),
                                  Line2D([], [], **steps), pplot.event_handle(runs[0]["end"])],
                            ["first integral as printed",
                             r"corrected: $b$ with $-15f^2$, $a$ and $b$ over $l$",
                             "time integration of (8)",
                             f"{end}: the motion ends, the curves too"],
                            ncols=2 if pplot.width_of(size) >= pplot.WIDE else 1,
                            title=pplot.wrap([r"$\omega > 0$", *(
                                rf"${k}$ = {v}" for k, v in (
                                    ("f", f"{runs[0]['f']:g}"),
                                    (r"\varphi_0", f"{runs[0]['phi0']:g} rad"),
                                    ("g", r"9.81 m s$^{-2}$"), ("m", "1 kg")))],
                                0.95 * fig.get_figwidth()))
        ends = " and ".join(f"{r['event_phi'][-1]:.2f} rad ({'ab'[i]})"
                            for i, r in enumerate(runs))
        pplot.define_symbols(fig, INTEGRAL_KEY + [
            "(8) holds while both contacts push",
            rf"a contact is lost at $\varphi$ = {ends}"])
    return fig


if __name__ == "__main__":
    main()
