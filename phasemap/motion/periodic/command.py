"""``phasemap orbit`` and ``phasemap diagram``: the command-line side of periodic orbits
and orbit diagrams.

:func:`add_parsers` registers the subcommands on the ``phasemap`` parser and :func:`run`
and :func:`run_diagram` run them; :mod:`phasemap.cli` calls them.
"""

from __future__ import annotations

import numpy as np

EXAMPLES = {
    "orbit": [
        ("phasemap orbit belt x=0 xdot=0.2 -o belt_orbit.nc",
         "the stick-slip orbit: a stick segment of 5, T = 8.9026"),
        ("phasemap orbit den_hartog f=0.78 --continue f=0.78:0.83 --steps 2 -o dh.nc",
         "its reversals turn into stops at f = 0.8174064"),
    ],
    "diagram": [
        ("phasemap diagram duffing F0=7.8:8.3:21 k=0 beta=1 c=0.05 f=0.01 x=2.4 xdot=-0.32 "
         "--follow --down --settle 80 --periods 30 -o ueda.nc --png ueda.png",
         "Ueda's oscillator swept down in F0: period one, then chaos below F0 = 8.0115"),
    ],
}


def add_parsers(sub, make) -> dict:
    """Register ``orbit`` on the subparsers ``sub`` (``make``: the CLI's own helper)."""
    p = make(sub, "orbit", "find a periodic orbit (and follow it in a parameter)",
             "Lets the motion from the start settle on a cycle, reads its mode sequence from "
             "its events, solves the orbit by multiple shooting on the exact hybrid flow and "
             "prints its segments, period and Floquet multipliers (phasemap.periodic_orbit); "
             "with --continue, follows it in a parameter through the changes of its mode "
             "sequence (phasemap.continue_orbit).")
    p.add_argument("model", metavar="MODEL", help="a friction oscillator (belt, "
                   "stribeck_belt, den_hartog, duffing), a declared built-in model or a "
                   "declaration file (path/to/system.py)")
    p.add_argument("values", nargs="*", metavar="NAME=VALUE",
                   help="the start and the parameters (the defaults elsewhere)")
    p.add_argument("--period", type=float, default=None, metavar="T",
                   help="a guess of the period: the start is taken to be on the orbit")
    p.add_argument("--settle", type=float, default=None, metavar="T",
                   help="how long the motion settles first (default: 100 forcing periods, "
                   "or 500 time scales)")
    p.add_argument("--rtol", type=float, default=1e-12, help="integration tolerance "
                   "(default %(default)s)")
    p.add_argument("--continue", dest="follow", metavar="PARAM=LO:HI", default=None,
                   help="follow the orbit in PARAM across LO:HI")
    p.add_argument("--steps", type=int, default=20, metavar="N",
                   help="continuation steps across the span (default %(default)s)")
    p.add_argument("--overwrite", action="store_true", help="replace OUT.nc if it exists")
    p.add_argument("-o", "--output", metavar="OUT.nc", help="write the orbit (with "
                   "--continue, the branch) as netCDF")
    d = make(sub, "diagram", "sweep a parameter by simulation: the orbit diagram",
             "Runs the motion of a forced oscillator at each value of a parameter, lets it "
             "settle, and keeps its state once per forcing period (the stroboscopic points: "
             "one per value on a period-one orbit, a cloud where the motion is chaotic; of "
             "an autonomous oscillator, its state at each maximum of a coordinate); "
             "prints the period of the settled motion at each value "
             "(phasemap.orbit_diagram).")
    d.add_argument("model", metavar="MODEL", help="a friction oscillator (den_hartog, "
                   "duffing; belt, stribeck_belt, autonomous) or a declaration file")
    d.add_argument("sweep", metavar="PARAM=LO:HI:N", help="the parameter and its N values "
                   "from LO up to HI")
    d.add_argument("values", nargs="*", metavar="NAME=VALUE",
                   help="the start and the other parameters (the defaults elsewhere)")
    d.add_argument("--periods", type=int, default=200, metavar="N",
                   help="forcing periods kept (default %(default)s)")
    d.add_argument("--settle", type=int, default=100, metavar="N",
                   help="forcing periods run first and discarded (default %(default)s)")
    d.add_argument("--phase", type=float, default=0.0, help="where in the forcing period "
                   "the points are taken, a fraction in [0, 1) (default %(default)s)")
    d.add_argument("--section", metavar="NAME", default=None, help="an autonomous "
                   "system's coordinate whose maxima are kept (default its first)")
    d.add_argument("--rtol", type=float, default=1e-8, help="integration tolerance "
                   "(default %(default)s)")
    d.add_argument("--follow", action="store_true", help="start each value where the "
                   "previous one ended (a sweep that stays on its attractor)")
    d.add_argument("--down", action="store_true", help="sweep from HI down to LO (with "
                   "--follow, the other branch of a hysteresis)")
    d.add_argument("--overwrite", action="store_true", help="replace the outputs if they exist")
    d.add_argument("-o", "--output", metavar="OUT.nc", help="write the diagram as netCDF")
    d.add_argument("--png", metavar="FIG.png", help="draw the diagram into FIG.png "
                   "(and FIG.pdf)")
    return {"orbit": p, "diagram": d}


def run(args, parse_values, check_output) -> str:
    """Run ``phasemap orbit``; ``parse_values`` reads NAME=VALUE items, ``check_output``
    checks before any work that OUT.nc can be written (the CLI's own).  Returns what to
    print."""
    from phasemap.atlas.atomic import destination
    from phasemap.atlas.read import branch_lines, orbit_lines
    from phasemap.core import progress
    from phasemap.motion.periodic import continue_orbit, periodic_orbit

    model = _model(args.model)
    values = parse_values(args.values)
    if args.output:
        destination(args.output)
    out = check_output(args.output, overwrite=args.overwrite) if args.output else None
    follow = _span(args.follow) if args.follow else None
    with progress.activity(f"{args.model}: settling on a cycle and solving it"):
        orbit = periodic_orbit(model, start=values, period=args.period, settle=args.settle,
                               rtol=args.rtol)
    lines = orbit_lines(orbit)
    result = orbit
    if follow is not None:
        param, lo, hi = follow
        with progress.activity(f"{args.model}: following the orbit in {param}"):
            result = continue_orbit(orbit, param, (lo, hi), steps=args.steps,
                                    model=model if not isinstance(model, str) else None)
        lines += branch_lines(result)
    if out is not None:
        from phasemap.atlas.write import write_atlas

        write_atlas(writable(result), out, overwrite=args.overwrite)
        lines.append(f"wrote {out}")
    return "\n".join(lines)


def run_diagram(args, parse_values, check_output, draw) -> str:
    """Run ``phasemap diagram`` (the arguments as for :func:`run`; ``draw(ds, stem)``
    saves the figure as ``stem.png`` and ``stem.pdf`` and returns their paths: the
    figures are the command line's, a part above this one)."""
    from phasemap.atlas.atomic import destination
    from phasemap.atlas.read import diagram_lines
    from phasemap.core import args as _args
    from phasemap.motion.periodic import orbit_diagram

    model = _model(args.model)
    name, sep, rng = args.sweep.partition("=")
    parts = rng.split(":")
    if not sep or not name or len(parts) != 3:
        raise ValueError(f"the sweep takes PARAM=LO:HI:N, got {args.sweep!r}")
    lo, hi = (_args.parse_real(x, name, "") for x in parts[:2])
    count = _args.count("N", _args.parse_real(parts[2], "N", ""), "the sweep", least=2)
    if lo >= hi:     # the command line's one rule: a range is written low end first
        raise ValueError(f"the sweep {name}: LO {lo:g} is not below HI {hi:g}; every range "
                         f"on the command line is written low end first: "
                         f"{name}={parts[1]}:{parts[0]}:{parts[2]} (--down sweeps from HI)")
    values = parse_values(args.values)
    out = stem = None
    if args.output:
        destination(args.output)
        out = check_output(args.output, overwrite=args.overwrite)
    if args.png:        # the figure's two files, checked before any work as OUT.nc is
        stem = str(args.png)[:-4] if str(args.png).endswith(".png") else str(args.png)
        for path in (f"{stem}.png", f"{stem}.pdf"):
            destination(path)
            check_output(path, overwrite=args.overwrite)
    sweep = np.linspace(lo, hi, count)
    ds = orbit_diagram(model, name, sweep[::-1] if args.down else sweep, start=values,
                       periods=args.periods, settle=args.settle, phase=args.phase,
                       rtol=args.rtol, follow=args.follow, section=args.section)
    lines = diagram_lines(ds)
    if out is not None:
        from phasemap.atlas.write import write_atlas

        write_atlas(ds, out, overwrite=args.overwrite)
        lines.append(f"wrote {out}")
    if stem is not None:
        png, pdf = draw(ds, stem)
        lines.append(f"wrote {png} and {pdf}")
    return "\n".join(lines)


def _model(name):
    """A name, or a declaration file's SYSTEM."""
    if isinstance(name, str) and name.endswith(".py"):
        from phasemap.declare.loader import system

        return system(name)
    return name


def _span(text: str):
    from phasemap.core import args as _args

    name, sep, rng = text.partition("=")
    lo, sep2, hi = rng.partition(":")
    if not sep or not sep2 or not name:
        raise ValueError(f"--continue takes PARAM=LO:HI, got {text!r}")
    return name, _args.parse_real(lo, name, ""), _args.parse_real(hi, name, "")


def writable(ds):
    """The Dataset as netCDF4 takes it: a complex variable as its real and imaginary
    parts (``<name>_real``, ``<name>_imag``), text as fixed strings."""
    out = ds.copy()
    for name in list(out.data_vars):
        v = out[name]
        if np.iscomplexobj(v.values):
            attrs = dict(v.attrs)
            out = out.drop_vars(name)
            out[f"{name}_real"] = (v.dims, v.values.real, {
                **attrs, "long_name": f"{attrs.get('long_name', name)} (real part)"})
            out[f"{name}_imag"] = (v.dims, v.values.imag, {
                **attrs, "long_name": f"{attrs.get('long_name', name)} (imaginary part)"})
        elif v.dtype == object:
            out[name] = v.astype(str)
    for k, x in list(out.attrs.items()):
        if isinstance(x, (bool, np.bool_)):
            out.attrs[k] = int(x)
    return out
