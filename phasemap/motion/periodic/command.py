"""``phasemap orbit``: the command-line side of periodic orbits.

:func:`add_parsers` registers the subcommand on the ``phasemap`` parser and :func:`run`
runs it; :mod:`phasemap.cli` calls the two.
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
    return {"orbit": p}


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
