"""``phasemap boundaries`` and ``phasemap threshold``: the command-line side.

:func:`add_parsers` registers both subcommands on the ``phasemap`` parser and
:func:`run` runs one; :mod:`phasemap.cli` calls the two.
"""

from __future__ import annotations

EXAMPLES = {
    "boundaries": [
        ("phasemap boundaries painleve_rod --axis theta=0.2:1.5 --axis f=0:3 \\\n"
         "        --set xdot=-1 --set omega=0 -o rod_boundaries.nc",
         "the first paradox as an exact curve"),
    ],
    "threshold": [
        ("phasemap threshold painleve_rod f --over theta=0.1:1.5 --set xdot=-1 --set omega=0",
         "f = 4/3 at theta = arctan 2"),
        ("phasemap threshold ladder phi --layer stagnation --value 1 --side max \\\n"
         "        --over phi=0:1.5708 --set omega=0 --set f=0.5", "phi = 2 arctan f"),
    ],
}

_LAYERS = ("n_solutions", "stagnation", "contact_lost", "singular")


def add_parsers(sub, make, models: str) -> dict:
    """Register ``boundaries`` and ``threshold`` on the subparsers ``sub``; ``make(sub,
    name, help, description)`` makes one (the CLI's own helper).  Returns them by name."""
    subs = {}
    p = subs["boundaries"] = _parser(
        sub, make, models, "boundaries",
        "trace a slice's class boundaries as exact curves into netCDF",
        "Traces every boundary piece of a layer over a 2-D slice by continuation of the "
        "condition that vanishes on it, with its crossings, folds and ends on the edges to "
        "--tol, and writes them as a CF netCDF file (phasemap.boundaries).")
    p.add_argument("--axis", action="append", default=[], metavar="NAME=LO:HI",
                   help="one of the slice's two axes with its range (give two)")
    p.add_argument("--overwrite", action="store_true", help="replace OUT.nc if it exists")
    p.add_argument("-o", "--output", required=True, metavar="OUT.nc")
    p = subs["threshold"] = _parser(
        sub, make, models, "threshold",
        "the least (greatest) parameter at which a class exists, to 1e-10",
        "Finds the infimum (or supremum) of PARAM over the region where the layer takes "
        "--value, with the ranges of --over (at most two names besides PARAM), and prints "
        "the value, the point and the condition that vanishes there (phasemap.threshold).")
    p.add_argument("param", metavar="PARAM", help="the parameter whose threshold is sought")
    p.add_argument("--over", action="append", default=[], metavar="NAME=LO:HI",
                   help="a range searched (repeatable; PARAM's own range may be given too)")
    p.add_argument("--value", type=int, default=0, help="the layer's value that defines the "
                   "region (default %(default)s: no solution)")
    p.add_argument("--side", choices=["min", "max"], default="min",
                   help="infimum (the default) or supremum")
    return subs


def _parser(sub, make, models: str, *texts: str):
    """One subcommand (``texts``: name, help, description) with the ``MODEL`` argument
    and the options both share."""
    p = make(sub, *texts)
    p.add_argument("model", metavar="MODEL", help=models)
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="fix a state variable or parameter (repeatable)")
    p.add_argument("--layer", choices=_LAYERS, default="n_solutions",
                   help="the layer whose classes are bounded (default %(default)s)")
    p.add_argument("--tol", type=float, default=1e-10, help="accuracy of the special points "
                   "in each coordinate (default %(default)g)")
    return p


def _ranges(items: list[str], option: str) -> dict[str, tuple[float, float]]:
    """NAME=LO:HI items as ranges."""
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        parts = text.split(":")
        if not sep or not name or len(parts) != 2:
            raise ValueError(f"{option} expects NAME=LO:HI, got {item!r}")
        try:
            out[name] = (float(parts[0]), float(parts[1]))
        except ValueError:
            raise ValueError(f"{option} {name}: LO and HI must be numbers, got {text!r}") \
                from None
    return out


def _two_axes(model, axes: dict) -> str:
    """What to say where --axis was not given twice: with the model's default axes as an
    example, where it has two."""
    from phasemap.systems import get_model

    m = get_model(model)
    got = f"got {len(axes)}" + (f" ({', '.join(axes)})" if axes else "")
    example = ""
    if len(m.default_axes) >= 2:
        example = ", e.g. " + " ".join(f"--axis {k}={v[0]:.6g}:{v[1]:.6g}" for k, v in
                                       list(m.default_axes.items())[:2]) + \
            f" ({m.name}'s default axes)"
    return f"{m.name}: the slice needs two axes, --axis NAME=LO:HI twice; {got}{example}"


def run(args, parse_values) -> str:
    """Run ``args.command`` (``boundaries`` or ``threshold``); ``parse_values`` reads the
    NAME=VALUE items of --set.  Returns what to print."""
    fixed = parse_values(args.set)
    if args.command == "boundaries":
        from phasemap.atlas.write import write_atlas
        from phasemap.maps.blocks import check_output
        from phasemap.bifurcation.tracing import boundaries

        axes = _ranges(args.axis, "--axis")
        if len(axes) != 2:
            raise ValueError(_two_axes(args.model, axes))
        out = check_output(args.output, overwrite=args.overwrite)
        ds = boundaries(args.model, axes, fixed=fixed, layer=args.layer, tol=args.tol)
        write_atlas(ds, out)
        names = list(axes)
        lines = [f"wrote {out}: {ds.sizes['piece']} piece(s), {ds.sizes['vertex']} vertices, "
                 f"{ds.sizes['point']} point(s)"]
        for i in range(ds.sizes["point"]):
            p = ds.isel(point=i)
            lines.append(f"  {str(p.point_kind.values):<12} " + ", ".join(
                f"{n} = {float(p[f'point_{n}']):.12g}" for n in names)
                + f"  ({p.point_condition.values}; residual {float(p.point_residual):.1e})")
        return "\n".join(lines)
    from phasemap.bifurcation.search import threshold

    t = threshold(args.model, args.param, layer=args.layer, value=args.value,
                  over=_ranges(args.over, "--over"), fixed=fixed, side=args.side, tol=args.tol)
    if t is None:
        return (f"{args.layer} = {args.value} nowhere in the ranges given: no threshold of "
                f"{args.param}")
    at = ", ".join(f"{k} = {v:.15g}" for k, v in t.at.items())
    return (f"{args.param} {'>=' if args.side == 'min' else '<='} {t.value:.15g}\n"
            f"  at {at}\n  {t.kind} of {t.condition or '-'} (residual {t.residual:.1e})")
