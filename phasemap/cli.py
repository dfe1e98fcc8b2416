"""The ``phasemap`` command line."""

from __future__ import annotations

import argparse
import math
import sys

from ._version import __version__

EPILOG = """\
examples:
  phasemap tour                                     every study, quick, into ./phasemap-out
  phasemap tour --full --out results                full resolution (minutes)
  phasemap atlas elliptic_pendulum --set xdot=1 -o elliptic.nc
  phasemap atlas ladder --axis phi=0:1.5708:1024 --axis f=0:3:1024 --set omega=0 -o ladder.nc
  phasemap atlas wheel --axis phi=-3.1416:3.1416:400 --axis delta=0:1:400 \\
                       --layers n_solutions,stagnation,phi_ddot_roll_pos -o wheel.nc
  phasemap atlas hinge_pendulum --axis phi=-3:3:200 --axis omega=-6:6:200 \
                       --layers fate,phi_rest,n_reversals --option t_end=30 -o fates.nc
  phasemap simulate hinge_pendulum phi=2.5 omega=0 --t-end 20 -o swing.nc
  phasemap simulate elliptic_pendulum phi=1 xdot=1 f=0.3 --t-end 5
  phasemap info elliptic.nc                         axes, fixed values, cells per class
  phasemap table                                    the paper's key states, classified
  phasemap models                                   models, variables, units and defaults
  phasemap classify elliptic_pendulum phi=0.8 xdot=-1 f=4
  phasemap classify hinge_pendulum phi=0.05 omega=0 delta=0.1
"""

# (model, values, what the paper says happens there)
PAPER_CASES = (
    ("ladder", dict(phi=0.5, omega=0.0, f=0.3), "rest: phi <= 2 arctan f (static zone)"),
    ("ladder", dict(phi=1.2, omega=0.0, f=0.3), "slides down from rest"),
    ("ladder", dict(phi=0.8, omega=1.0, f=math.sqrt(2)), "f = sqrt 2: no acceleration (8)"),
    ("wheel", dict(phi=0.05, omega=0.0), "rest: |sin phi| <= delta/l (15)"),
    ("wheel", dict(phi=1.0, omega=0.0), "rolls from rest outside (15)"),
    ("wheel", dict(phi=2.0, omega=0.0, delta=0.6), "delta >= l: rest at every angle"),
    ("elliptic_pendulum", dict(phi=0.8, omega=0.0, xdot=1.0, f=4.0),
     "f > 2 sqrt 2, xdot > 0: no solution"),
    ("elliptic_pendulum", dict(phi=0.8, omega=0.0, xdot=-1.0, f=4.0),
     "f > 2 sqrt 2, xdot < 0: two solutions"),
    ("elliptic_pendulum", dict(phi=0.8, omega=0.0, xdot=1.0, f=2.0), "f <= 2: unique (27)"),
    ("hinge_pendulum", dict(phi=0.05, omega=0.0), "rest: |tan phi| <= delta/sqrt(l^2-delta^2) (35)"),
    ("hinge_pendulum", dict(phi=1.0, omega=1.0, delta=1.5), "delta > l: no solution (33)"),
    ("hinge_pendulum", dict(phi=1.0, omega=1.0), "delta < l: unique (34)"),
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="phasemap",
        description="Solvability and stagnation maps of mechanical systems with dry friction.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"phasemap {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("table", help="classify the seed paper's key states (the default)")
    p = sub.add_parser(
        "tour", help="run every study (quick) and list the atlases and figures it wrote",
        description="Runs the scripts in studies/ (found next to the installed package or in "
        "./studies) in quick mode, prints each study's claims table, then where every figure "
        "is.")
    p.add_argument("--out", default="phasemap-out", metavar="DIR",
                   help="folder for atlases and figures (default %(default)s)")
    p.add_argument("--full", action="store_true", help="full resolution (minutes, not seconds)")
    p.add_argument("--studies", metavar="DIR", help="folder of the study scripts "
                   "(default: the repository's studies/)")
    p.add_argument("--only", metavar="A,B", help="run only these studies")
    sub.add_parser("models", help="list the models with their variables, units and defaults")
    p = sub.add_parser(
        "atlas", help="map solvability and stagnation over a grid into a netCDF atlas",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Without --axis, the model's default map is drawn (see phasemap models).")
    p.add_argument("model")
    p.add_argument("--axis", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                   help="an axis of COUNT values from START to STOP (repeat for more axes)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="fix a state variable or parameter (repeatable)")
    p.add_argument("--layers", metavar="A,B", help="layers to compute (default: n_solutions, "
                   "plus stagnation where the relative velocity is zero)")
    p.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="integrator setting of the fate layers: t_end, rtol, atol, max_step, "
                   "max_steps, max_events, method (DOPRI5 or DOP853) (repeatable)")
    p.add_argument("--chunk-cells", type=int, default=1 << 24, metavar="N",
                   help="above N cells, compute and write block by block with bounded memory "
                   "(default %(default)s)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.nc")
    p = sub.add_parser(
        "simulate", help="integrate a motion in time: phasemap simulate MODEL name=value ...",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model")
    p.add_argument("values", nargs="*", metavar="NAME=VALUE",
                   help="initial state and parameters (defaults: phasemap models)")
    p.add_argument("--t-end", type=float, default=10.0, metavar="T", help="horizon in s "
                   "(default %(default)s)")
    p.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance "
                   "(default %(default)s)")
    p.add_argument("--method", default="DOPRI5", help="DOPRI5 (Dormand-Prince 5(4), the "
                   "default) or DOP853 (order 8, for tight tolerances)")
    p.add_argument("-o", "--output", metavar="OUT.nc", help="write the trajectory as netCDF")
    p = sub.add_parser("info", help="summarise an atlas: axes, fixed values, cells per class")
    p.add_argument("path")
    p = sub.add_parser("classify", help="classify one state: phasemap classify MODEL name=value ...",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model")
    p.add_argument("values", nargs="*", metavar="NAME=VALUE")
    args = parser.parse_args(argv)
    try:
        if args.command in (None, "table"):
            print(_table())
        elif args.command == "tour":
            from .tour import tour

            return tour(args.out, full=args.full, studies=args.studies,
                        only=args.only.split(",") if args.only else None)
        elif args.command == "models":
            print(_models())
        elif args.command == "atlas":
            print(_atlas(args))
        elif args.command == "simulate":
            print(_simulate(args))
        elif args.command == "info":
            from .atlas import describe_atlas

            print(describe_atlas(args.path))
        elif args.command == "classify":
            from .classify import classify

            print(classify(args.model, **_parse_values(args.values)))
    except ValueError as err:
        print(f"phasemap: error: {err}", file=sys.stderr)
        return 2
    return 0


def _parse_values(items: list[str], words: tuple[str, ...] = ()) -> dict[str, float]:
    """NAME=VALUE items as numbers (the names in ``words`` keep their text)."""
    values = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise ValueError(f"expected NAME=VALUE, got {item!r}")
        if name in words:
            values[name] = text
            continue
        try:
            values[name] = float(text)
        except ValueError:
            raise ValueError(f"{name}: {text!r} is not a number") from None
    return values


def _parse_axis(item: str) -> tuple[str, object]:
    import numpy as np

    name, sep, text = item.partition("=")
    parts = text.split(":")
    if not sep or not name or len(parts) != 3:
        raise ValueError(f"--axis expects NAME=START:STOP:COUNT, got {item!r}")
    try:
        start, stop = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"--axis {name}: START and STOP must be numbers, got {text!r}") from None
    try:
        count = int(parts[2])
    except ValueError:
        raise ValueError(f"--axis {name}: COUNT must be a whole number, got {parts[2]!r}") from None
    if count < 1:
        raise ValueError(f"--axis {name}: COUNT must be at least 1, got {count}")
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise ValueError(f"--axis {name}: START and STOP must be finite, got {text!r}")
    return name, np.linspace(start, stop, count)


def _atlas(args) -> str:
    from .atlas import destination, write_atlas
    from .models import get_model
    from .scene import Scene

    model = get_model(args.model)
    out = destination(args.output)  # before any work: the folder exists, out is no folder
    axes = dict(_parse_axis(a) for a in args.axis)
    if len(axes) != len(args.axis):
        raise ValueError("each --axis name may be given once")
    fixed = _parse_values(args.set)
    if not axes:  # the model's default map, less the names the user fixed
        import numpy as np

        axes = {n: np.linspace(*spec) for n, spec in model.default_axes.items() if n not in fixed}
        if not axes:
            raise ValueError(f"{model.name}: every default axis is fixed; give an --axis")
    if args.chunk_cells < 1:
        raise ValueError(f"--chunk-cells must be at least 1, got {args.chunk_cells}")
    layers = [x.strip() for x in args.layers.split(",") if x.strip()] if args.layers else None
    options = _parse_values(args.option, words=("method",))
    for name in ("max_steps", "max_events"):
        if name in options:
            if options[name] != int(options[name]):
                raise ValueError(f"--option {name} must be a whole number")
            options[name] = int(options[name])
    scene = Scene(model, axes=axes, fixed=fixed, layers=layers, options=options)
    if scene.size > args.chunk_cells:
        from dask.diagnostics import ProgressBar

        first = next(iter(scene.axes))
        rows = max(1, args.chunk_cells // (scene.size // scene.axes[first].size))
        ds = scene.compute(chunks={first: rows})
        with ProgressBar(minimum=1.0):
            write_atlas(ds, out)
    else:
        write_atlas(scene.compute(progress=True), out)
    return f"wrote {out} ({scene.size} cells, layers {', '.join(scene.layers)})"


def _simulate(args) -> str:
    from .atlas import destination, write_atlas
    from .events import Event
    from .simulate import integrated_variables, simulate
    from .models import get_model

    model = get_model(args.model)
    out = destination(args.output) if args.output else None
    ds = simulate(model, args.t_end, rtol=args.rtol, method=args.method,
                  **_parse_values(args.values))
    names = [v.name for v in integrated_variables(model)]
    rows = [("t (s)", "event", "branch after", *names)]
    meanings = ["none", *model.branches]
    for i in range(ds.sizes["event"]):
        e = ds.isel(event=i)
        rows.append((f"{float(e.event_t):.6g}", Event(int(e.event_kind)).name.lower(),
                     meanings[int(e.event_branch) + 1],
                     *(f"{float(e[f'event_{n}']):.6g}" for n in names)))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.append(f"{ds.attrs['end_reason']}: {ds.attrs['end_message']} "
                 f"({int(ds.attrs['n_steps'])} steps, {ds.sizes['t']} saved points)")
    if out is not None:
        write_atlas(ds, out)
        lines.append(f"wrote {out}")
    return "\n".join(lines)


def _table() -> str:
    from .classify import classify

    rows = [("model", "state and parameters", "solutions", "stag.", "lost", "sing.", "the paper")]
    for model, values, claim in PAPER_CASES:
        c = classify(model, **values)
        rows.append((
            model,
            " ".join(f"{k}={v:.4g}" for k, v in values.items()),
            f"{c.n_solutions} {c.solvability.name.lower()}",
            "yes" if c.stagnation else "-",
            "yes" if c.contact_lost else "-",
            "yes" if c.singular else "-",
            claim,
        ))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _models() -> str:
    from .models import MODELS

    lines = []
    for m in MODELS.values():
        lines.append(f"{m.name}: {m.title}")
        for kind, group in (("state", m.state), ("param", m.params)):
            for v in group:
                lines.append(f"  {kind}  {v.name:<6} {v.units:<8} default {v.default:<8.4g} "
                             f"domain {v.domain_text():<14} {v.long_name}")
        lines.append(f"  branches: {', '.join(m.branches)}")
        lines.append("")
    return "\n".join(lines).rstrip()


if __name__ == "__main__":
    sys.exit(main())
