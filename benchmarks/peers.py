"""The frictionless ladder against MuJoCo and pymunk: error against CPU time, in one run.

The ladder (a uniform rod, 2l = 1 m, m = 1 kg) is released at rest 60 degrees from the
floor against a smooth wall and floor.  Exactly, it leaves the wall where
sin theta = (2/3) sin 60 degrees (theta_s = 35.264390 degrees) and then falls on with its
foot on the floor; theta(0.45 s) comes from phasemap at rtol 1e-13 (the release and the
flight integrated with its events rooted; it agrees with the closed-form release to
2e-12 rad).  Each tool runs at several settings:

* phasemap: ``simulate`` at rtol 1e-6 ... 1e-12 (the reduced model to the release, then
  the full coordinates);
* MuJoCo (``mujoco``): a planar rod (slide x, slide z, hinge y) with a small sphere at
  each end, frictionless contacts (``condim=1``) with the planes x = 0 and z = 0, default
  soft constraints, time steps 1e-2 ... 1e-4 s;
* pymunk: a segment body on static segments, friction 0, elasticity 0, collision slop
  1e-6 m, time steps 1e-2 ... 1e-4 s.

For the peers the release is the last step at which the wall's contact went away
(MuJoCo's contact list; pymunk's shape query): soft contacts chatter, opening and
closing before the final release.

CPU time (``time.process_time``) of the whole run from the start to 0.45 s.  Writes the
section "Peers" of ../BENCHMARKS.md and benchmarks/peers.png.  Needs the ``peers``
extra (``pip install ".[peers]"``), which the tests do not.

    python benchmarks/peers.py [--no-write]
"""

from __future__ import annotations

import math
import time

import numpy as np

import _report
import phasemap

G, L2, M = 9.81, 1.0, 1.0                 # gravity, the rod's length, its mass
THETA0 = math.radians(60.0)
THETA_S = math.asin(2.0 / 3.0 * math.sin(THETA0))
T_CHECK = 0.45
R = 1e-3                                  # radius of the peers' end spheres


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


# ----------------------------------------------------------------------------- phasemap

def run_phasemap(rtol: float):
    ds = phasemap.simulate("ladder", t_end=T_CHECK, rtol=rtol, phi=math.pi / 2 - THETA0,
                           omega=0.0, f=0.0, l=L2 / 2, t_eval=[T_CHECK])
    at = [int(k) for k in ds.event_kind.values].index(phasemap.Event.LIFTOFF)
    return math.pi / 2 - float(ds.event_phi[at]), math.pi / 2 - float(ds.phi[-1])


# ------------------------------------------------------------------------------- MuJoCo

MJCF = f"""
<mujoco>
  <option gravity="0 0 -{G}" timestep="{{dt}}"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" pos="0 0 0" condim="1"/>
    <geom name="wall" type="plane" size="5 5 0.1" pos="0 0 0" zaxis="1 0 0" condim="1"/>
    <body name="rod" pos="{L2 / 2 * math.cos(THETA0) + R} 0 {L2 / 2 * math.sin(THETA0) + R}">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <joint name="th" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 0" mass="{M}" diaginertia="{M * L2**2 / 12} {M * L2**2 / 12} 1e-6"/>
      <geom name="foot" type="sphere" size="{R}" mass="0" condim="1"
            pos="{L2 / 2 * math.cos(THETA0)} 0 {-L2 / 2 * math.sin(THETA0)}"/>
      <geom name="top" type="sphere" size="{R}" mass="0" condim="1"
            pos="{-L2 / 2 * math.cos(THETA0)} 0 {L2 / 2 * math.sin(THETA0)}"/>
    </body>
  </worldbody>
</mujoco>
"""


def run_mujoco(dt: float):
    import mujoco

    model = mujoco.MjModel.from_xml_string(MJCF.format(dt=dt))
    data = mujoco.MjData(model)
    foot = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "foot")
    top = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "top")

    def angle():
        (xf, _, zf), (xt, _, zt) = data.geom_xpos[foot], data.geom_xpos[top]
        return math.atan2(zt - zf, xf - xt)

    wall = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "wall")
    release, seen, was = None, False, False
    for _ in range(int(round(T_CHECK / dt))):
        mujoco.mj_step(model, data)
        touching = any(wall in (data.contact[i].geom1, data.contact[i].geom2)
                       for i in range(data.ncon))
        seen |= touching
        if seen and not touching and was:
            release = angle()            # the wall's contact is gone (for now)
        was = touching
    return release, angle()


# ------------------------------------------------------------------------------- pymunk

def run_pymunk(dt: float):
    import pymunk

    space = pymunk.Space()
    space.gravity = (0.0, -G)
    space.collision_slop = 1e-6          # (the default, 0.1, is a tenth of the ladder)
    for a, b in (((-5.0, 0.0), (5.0, 0.0)), ((0.0, 0.0), (0.0, 5.0))):
        seg = pymunk.Segment(space.static_body, a, b, 0.0)
        seg.friction, seg.elasticity = 0.0, 0.0
        space.add(seg)
    wall = seg
    half = L2 / 2
    body = pymunk.Body(M, M * L2**2 / 12)
    body.position = (half * math.cos(THETA0) + R, half * math.sin(THETA0) + R)
    body.angle = math.pi - THETA0            # the segment from the foot to the top
    rod = pymunk.Segment(body, (-half, 0.0), (half, 0.0), R)
    rod.friction, rod.elasticity = 0.0, 0.0
    space.add(body, rod)
    release, seen, was = None, False, False
    for _ in range(int(round(T_CHECK / dt))):
        space.step(dt)
        touching = any(info.shape is wall for info in space.shape_query(rod))
        seen |= touching
        if seen and not touching and was:
            release = math.pi - body.angle   # the wall's contact is gone (for now)
        was = touching
    return release, math.pi - body.angle


def main() -> None:
    ap = _report.parser(__doc__)
    args = ap.parse_args()
    run_phasemap(1e-8)                                        # compile
    _, theta_ref = run_phasemap(1e-13)          # the reference, tighter than every run
    runs = []
    for rtol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12):
        sec, (rel, th) = cpu(lambda: run_phasemap(rtol))
        runs.append(("phasemap", f"rtol {rtol:g}", sec, rel, th))
    for name, fn in (("MuJoCo", run_mujoco), ("pymunk", run_pymunk)):
        try:
            fn(1e-2)
        except ImportError:
            runs.append((name, "not installed", math.nan, math.nan, math.nan))
            continue
        for dt in (1e-2, 2e-3, 5e-4, 1e-4):
            sec, (rel, th) = cpu(lambda: fn(dt))
            runs.append((name, f"dt {dt:g} s", sec, math.nan if rel is None else rel, th))
    rows = ["| tool | setting | CPU time | release angle (deg) | its error (rad) | "
            "theta(0.45 s) error (rad) |", "|---|---|---|---|---|---|"]
    for name, setting, sec, rel, th in runs:
        rows.append(f"| {name} | {setting} | {sec * 1e3:.1f} ms | {math.degrees(rel):.6f} | "
                    f"{abs(rel - THETA_S):.1e} | {abs(th - theta_ref):.1e} |")
    _figure(runs, theta_ref)
    lines = ["## Peers (`benchmarks/peers.py`)", "",
             f"Machine: {_report.machine()}; load {_report.load()}. The frictionless ladder "
             f"released at 60°; exact release at {math.degrees(THETA_S):.6f}°. CPU time of "
             "one run to 0.45 s (`benchmarks/peers.png`: error against CPU time).", "",
             *rows]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        _report.write_section(text, "## Peers")


def _figure(runs, theta_ref) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from phasemap.plot.style import MARKERS, OKABE_ITO, style

    with style():
        fig, axes = plt.subplots(1, 2, figsize=(7.2, 3.0), constrained_layout=True)
        colours = {"phasemap": OKABE_ITO["black"], "MuJoCo": OKABE_ITO["vermillion"],
                   "pymunk": OKABE_ITO["blue"]}
        for k, tool in enumerate(colours):
            pts = [(s, abs(r - THETA_S), abs(t - theta_ref)) for n, _, s, r, t in runs
                   if n == tool and np.isfinite(s)]
            if not pts:
                continue
            s, er, et = (np.array(c) for c in zip(*pts))
            for ax, e in zip(axes, (er, et)):
                e = np.maximum(e, 1e-16)
                ax.loglog(s, e, marker=MARKERS[k], color=colours[tool], label=tool, lw=1.0)
        axes[0].set_title("release angle")
        axes[1].set_title(r"$\theta$(0.45 s)")
        for ax in axes:
            ax.set_xlabel("CPU time per run (s)")
            ax.set_ylabel("error (rad)")
        axes[0].legend(frameon=False)
        fig.savefig(_report.ROOT / "benchmarks" / "peers.png", dpi=200)
        plt.close(fig)


if __name__ == "__main__":
    main()
