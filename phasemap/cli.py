"""The ``phasemap`` command line."""

from __future__ import annotations

import argparse
import math
import re
import shutil
import sys
import textwrap

from phasemap.core import args as _args
from phasemap._version import __version__
from phasemap.bifurcation import command as _bif
from phasemap.motion.periodic import command as _orbits

#: Examples per subcommand; ``phasemap --help`` shows them all, each
#: subcommand's help only its own.
EXAMPLES = {
    "tour": [
        ("phasemap tour", "every study, quick, into ./phasemap-out"),
        ("phasemap tour --full --out results", "full resolution (minutes)"),
        ("phasemap tour --size both", "every figure at two-column and one-column width"),
    ],
    "atlas": [
        ("phasemap atlas elliptic_pendulum --set xdot=1 -o elliptic.nc", ""),
        ("phasemap atlas ladder --axis phi=0:pi/2:1024 --axis f=0:3:1024 --set omega=0 "
         "-o ladder.nc", ""),
        ("phasemap atlas wheel --axis phi=-pi:pi:400 --axis delta=0:1:400 \\\n"
         "        --layers n_solutions,stagnation,phi_ddot_roll_pos -o wheel.nc", ""),
        ("phasemap atlas hinge_pendulum --axis phi=-3:3:200 --axis omega=-6:6:200 \\\n"
         "        --layers fate,phi_rest,n_reversals --option t_end=30 -o fates.nc", ""),
        ("phasemap atlas den_hartog --axis f=0.1:0.7:61 --layers section_x,multiple \\\n"
         "        --option periods=50 -o diagram.nc",
         "the orbit diagram as an atlas (the plot command draws it as one)"),
    ],
    "simulate": [
        ("phasemap simulate hinge_pendulum phi=2.5 omega=0 --t-end 20 -o swing.nc", ""),
        ("phasemap simulate elliptic_pendulum phi=1 xdot=1 f=0.3 --t-end 5", ""),
        ("phasemap simulate ladder phi=0.5236 omega=0 f=0 l=0.5 --t-end 1",
         "leaves the wall, falls on"),
        ("phasemap simulate den_hartog x=2 xdot=1 --t0 1.3 --t-end 13.3",
         "starts where the forcing is at t = 1.3 s"),
    ],
    "info": [("phasemap info elliptic.nc", "axes, fixed values, cells per class")],
    "plot": [("phasemap plot elliptic.nc -o elliptic --size two", "elliptic.pdf and .png")],
    "cfcheck": [("phasemap cfcheck elliptic.nc", "CF compliance, offline")],
    "table": [("phasemap table", "the paper's key states, classified")],
    "models": [("phasemap models", "models, variables, units and defaults"),
               ("phasemap models ladder", "one model, with every layer it can map")],
    "classify": [
        ("phasemap classify elliptic_pendulum phi=0.8 xdot=-1 f=4", ""),
        ("phasemap classify hinge_pendulum phi=0.05 omega=0 delta=0.1", ""),
    ],
    "cache": [
        ("phasemap cache info", "where compiled kernels are kept, and how much"),
        ("phasemap cache clear", "delete them all (they compile again on use)"),
    ],
    "warm": [
        ("phasemap warm", "compile every built-in model's kernels, before a long job"),
        ("phasemap warm ladder my_system.py --jobs 2", "two models, two calls at once"),
    ],
}
EXAMPLES |= _bif.EXAMPLES  # phasemap boundaries, phasemap threshold
EXAMPLES |= _orbits.EXAMPLES  # phasemap orbit, phasemap diagram


def examples(*commands: str) -> str:
    """The examples block of ``commands`` (all when none), aligned."""
    rows = [r for c in (commands or EXAMPLES) for r in EXAMPLES[c]]
    lines = ["examples:"]
    for cmd, note in rows:
        if note:
            lines.append(f"  {cmd:<48}  {note}" if len(cmd) <= 48 else f"  {cmd}\n      {note}")
        else:
            lines.append(f"  {cmd}")
    return "\n".join(lines) + "\n"


EPILOG = examples()

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


def _sub(sub, name: str, help: str, description: str):
    """A subcommand whose help shows its own description and examples."""
    width = min(100, shutil.get_terminal_size().columns) - 2
    return sub.add_parser(name, help=help, description=textwrap.fill(description, width),
                          epilog=examples(name),
                          formatter_class=argparse.RawDescriptionHelpFormatter)


def _model_names() -> str:
    """What MODEL may be, for the commands' help."""
    from phasemap.systems import MODELS, OSCILLATORS

    return (f"a built-in model ({', '.join(MODELS)}), a friction oscillator "
            f"({', '.join(OSCILLATORS)}) or a declaration file (path/to/system.py, "
            "defining SYSTEM)")


def build_parser() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    """The command-line parser and its subcommand parsers by name."""
    parser = argparse.ArgumentParser(
        prog="phasemap",
        description="Solvability and stagnation maps of mechanical systems with dry friction.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"phasemap {__version__}")
    parser.add_argument("--timing", action="store_true", help="say on stderr, at the end, "
                        "how long the command took and how much of it numba spent compiling "
                        "kernels (the first run of each kind of work; later runs load them)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    models = _model_names()
    subs = {}
    subs["table"] = _sub(sub, "table", "classify the seed paper's key states (the default)",
                         "Classifies the states the seed paper discusses, one per line, "
                         "beside what the paper says happens there.")
    p = subs["tour"] = _sub(
        sub, "tour", "run every study (quick) and list the atlases and figures it wrote",
        "Runs the scripts in studies/ (found next to the installed package or in ./studies) "
        "in quick mode (the default), prints each study's claims table, then where every "
        "figure is.  Existing files in the output folder are replaced.")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="coarse grids, about a minute "
                      "(the default)")
    mode.add_argument("--full", action="store_true", help="full resolution (minutes, not "
                      "seconds)")
    p.add_argument("--out", default="phasemap-out", metavar="DIR",
                   help="folder for atlases and figures (default %(default)s)")
    p.add_argument("--studies", metavar="DIR", help="folder of the study scripts "
                   "(default: the repository's studies/)")
    p.add_argument("--only", metavar="A,B", help="run only these studies")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="studies run at once, one process each (default: one per core; 1 "
                   "runs them in turn in this process)")
    p.add_argument("--size", choices=["two_column", "one_column", "both"], default="two_column",
                   help="lay the figures out for a journal's two columns (7.2 in, the "
                   "default), one column (3.5 in, files *_one_column) or both")
    p = subs["models"] = _sub(sub, "models", "list the models with their variables, units "
                              "and defaults", "Lists every model: its state variables and "
                              "parameters with units, defaults and domains, and its branches; "
                              "given a MODEL, that model with the layers an atlas can hold.")
    p.add_argument("model", nargs="?", metavar="MODEL", help=models)
    p = subs["atlas"] = _sub(
        sub, "atlas", "map solvability and stagnation over a grid into a netCDF atlas",
        "Computes the layers over a grid of states and parameters, block by block, into a "
        "CF netCDF atlas.  Without --axis, the model's default map is drawn (see phasemap "
        "models).  Before any work it prints the cells, output size, memory and time, and "
        "refuses what cannot be written or would not fit on the disk; above 10^9 cells or "
        "an hour it asks for --yes.")
    p.add_argument("model", metavar="MODEL", help=models)
    p.add_argument("--axis", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                   help="an axis of COUNT values from START up to STOP (every range on "
                   "the command line is written low end first); START and STOP may be "
                   "arithmetic with pi (pi/2, -2*pi/3); repeat for more axes")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="fix a state variable or parameter; VALUE may be arithmetic with pi "
                   "(repeatable)")
    p.add_argument("--layers", metavar="A,B", help="layers to compute (default: n_solutions, "
                   "plus stagnation where the relative velocity is zero; the models "
                   "command lists them)")
    p.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                   help="integrator setting of the fate layers: t_end, rtol, atol, max_step, "
                   "max_steps, max_events, method (DOPRI5 or DOP853); through_contacts=true "
                   "follows a declared system's motions through lift-off and impacts (with "
                   "impact_law, restitution, painleve, zeno_speed; slower); a friction "
                   "oscillator's orbit layers (multiple, section_x...) take periods, settle, "
                   "phase and section (repeatable)")
    p.add_argument("--chunk-cells", type=int, default=None, metavar="N",
                   help="cells per block (default: each block about a quarter second of "
                   "work, sized as the work goes)")
    p.add_argument("--overwrite", action="store_true", help="replace OUT.nc if it exists")
    p.add_argument("--yes", action="store_true", help="go ahead with a large atlas (above "
                   "10^9 cells or an hour)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.nc")
    p = subs["simulate"] = _sub(
        sub, "simulate", "integrate a motion in time: phasemap simulate MODEL name=value ...",
        "Integrates the motion from an initial state with exact stick and slip, and prints "
        "its events.")
    p.add_argument("model", metavar="MODEL", help=models)
    p.add_argument("values", nargs="*", metavar="NAME=VALUE",
                   help="initial state and parameters (defaults: phasemap models)")
    p.add_argument("--t-end", type=float, default=10.0, metavar="T", help="horizon in s "
                   "(default %(default)s)")
    p.add_argument("--t0", type=float, default=0.0, metavar="T0", help="start time in s of "
                   "a system forced in time (default 0)")
    p.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance "
                   "(default %(default)s)")
    p.add_argument("--method", default="DOPRI5", help="DOPRI5 (Dormand-Prince 5(4), the "
                   "default) or DOP853 (order 8, for tight tolerances)")
    p.add_argument("--impact-law", default="stronge", metavar="LAW",
                   help="stronge (the default), poisson or newton: the restitution law of "
                   "impacts, once a declared system's motion leaves its contacts")
    p.add_argument("--restitution", type=float, default=0.0, metavar="E",
                   help="coefficient of restitution (default 0: plastic)")
    p.add_argument("--painleve", default="liftoff", metavar="POLICY",
                   help="liftoff (the default), iwc or stop: what follows where the "
                   "accelerations have two solutions")
    p.add_argument("--zeno-speed", type=float, default=1e-6, metavar="V",
                   help="rebound speed below which impacts accumulate (default %(default)s)")
    p.add_argument("--reduced", action="store_true",
                   help="end where the model with every contact closed ends (contact_lost), "
                   "as phase curves and fate maps do, instead of going on in full coordinates")
    p.add_argument("-o", "--output", metavar="OUT.nc", help="write the trajectory as netCDF")
    p.add_argument("--overwrite", action="store_true", help="replace OUT.nc if it exists")
    p = subs["info"] = _sub(sub, "info", "summarise an atlas, trajectory or phase curve",
                            "Describes a file phasemap wrote: for an atlas its axes, fixed "
                            "values and the cells in each class; for a trajectory its "
                            "times and events; for a phase curve its stages.")
    p.add_argument("path")
    p = subs["plot"] = _sub(sub, "plot", "draw an atlas, trajectory or phase curve as PDF and "
                            "PNG", "Draws the figure ds.phasemap.plot() draws (a 3-D atlas: "
                            "one map per value of its shortest axis) into STEM.pdf and STEM.png.")
    p.add_argument("path", metavar="FILE.nc")
    p.add_argument("-o", "--output", metavar="STEM", help="default: FILE without .nc")
    p.add_argument("--size", choices=["one", "two"], default="one", help="a journal's one "
                   "column (3.5 in, the default) or two columns (7.2 in)")
    p = subs["cfcheck"] = _sub(sub, "cfcheck", "check a file against the CF conventions, "
                               "offline", "Runs cfchecks (pip install 'phasemap[cf]') on FILE with "
                               "local stand-ins for the tables it would download; a "
                               "phasemap file uses no standard names, areas or regions.")
    p.add_argument("path")
    p = subs["classify"] = _sub(sub, "classify", "classify one state: phasemap classify "
                                "MODEL name=value ...", "Counts the solutions of the motion "
                                "equations for the senior derivatives at one state.  Where "
                                "the model's point function is not compiled yet, its "
                                "interpreted twin answers, with the same bits, while numba "
                                "compiles it in the background (PHASEMAP_JIT=background, "
                                "eager or off).")
    # MODEL optional to argparse, required by _run: argparse would name NAME=VALUE as
    # required too when nothing is given
    p.add_argument("model", nargs="?", metavar="MODEL", help=models)
    p.add_argument("values", nargs="*", metavar="NAME=VALUE",
                   help="state and parameters (optional: the others take the defaults)")
    p = subs["cache"] = _sub(sub, "cache", "show or clear the kernel cache: phasemap cache "
                             "info|clear", "The kernel cache holds the code phasemap generates "
                             "and what numba compiles from it and from phasemap's own "
                             "integrators, under one least-recently-used size bound "
                             "(PHASEMAP_CACHE_MAX_MB).  info lists its folders, entries and "
                             "size; clear deletes every entry.")
    p.add_argument("action", choices=["info", "clear"])
    p = subs["warm"] = _sub(sub, "warm", "compile what a model's work needs, before the work",
                            "Makes one small call of each kind of work each MODEL supports "
                            "(classify, its default map, simulate, a fate map, a phase curve, "
                            "its default slice's boundaries), several at once, so that numba "
                            "compiles their kernels into the cache now and later calls load "
                            "them.  For a script or a cluster job, before the job.")
    p.add_argument("models", nargs="*", metavar="MODEL", help=models + " (default: every "
                   "built-in model)")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="calls at once, one process each (default: one per core)")
    subs |= _bif.add_parsers(sub, _sub, models)
    subs |= _orbits.add_parsers(sub, _sub)
    return parser, subs


def main(argv: list[str] | None = None) -> int:
    parser, subs = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # the subcommand's own usage, not the top level's
        (subs.get(args.command) or parser).error(f"unrecognized arguments: {' '.join(extra)}")
    from phasemap.core import progress
    from phasemap.atlas.atomic import Terminated, removed_on_signals

    if args.timing:
        import time

        from phasemap.core import compiletime

        start, compiled = time.perf_counter(), compiletime.seconds()
    try:
        with progress.enable(), removed_on_signals():
            code = _run(args)
            sys.stdout.flush()  # a closed pipe shows here, not at exit
            if args.timing:
                took = time.perf_counter() - start
                spent = compiletime.seconds() - compiled
                print(f"phasemap: {took:.1f} s in all, {spent:.1f} s of it compiling numba "
                      "kernels in this process" + (" (the tour's own summary counts its "
                                                   "workers' too)" if args.command == "tour"
                                                   else ""), file=sys.stderr)
            return code
    except BrokenPipeError:  # the reader left (phasemap ... | head): end quietly
        return _stdout_closed()
    except ValueError as err:
        if args.command == "tour":
            print(subs["tour"].format_usage().rstrip(), file=sys.stderr)
        print(f"phasemap: error: {err}", file=sys.stderr)
        return 2
    except OSError as err:  # the file system refused (a full disk, a name too long)
        where = f" ({err.filename})" if getattr(err, "filename", None) else ""
        print(f"phasemap: error: {err.strerror or err}{where}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("\nphasemap: interrupted; no partial file was left", file=sys.stderr)
        return 130
    except Terminated as stop:
        print(f"\nphasemap: {stop}; no partial file was left", file=sys.stderr)
        return stop.code


def _stdout_closed() -> int:
    """After a broken pipe on stdout: point it at the null device, so that the flush at
    exit cannot fail again, and return 141 (128 + SIGPIPE), as a tool killed by SIGPIPE
    would end (the recipe of Python's signal documentation)."""
    import os

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 141


def _run(args) -> int:
    if args.command in (None, "table"):
        print(_table())
    elif args.command == "tour":
        from phasemap.tour import tour

        return tour(args.out, full=args.full, studies=args.studies,
                    only=args.only.split(",") if args.only is not None else None,
                    size=args.size,
                    jobs=args.jobs)
    elif args.command == "models":
        print(_models(args.model))
    elif args.command == "atlas":
        print(_atlas(args))
    elif args.command == "simulate":
        print(_simulate(args))
    elif args.command == "info":
        from phasemap.atlas.read import describe_atlas

        print(describe_atlas(args.path))
    elif args.command == "plot":
        from phasemap.plot.command import plot_file

        print("wrote " + ", ".join(map(str, plot_file(args.path, args.output, args.size))))
    elif args.command == "cfcheck":
        from phasemap.atlas.cfcheck import cfcheck

        report, ok = cfcheck(args.path)
        print(report)
        if not ok:
            print(f"phasemap: {args.path} does not pass the CF checker (its report is above)",
                  file=sys.stderr)
        return 0 if ok else 1
    elif args.command == "classify":
        from phasemap.maps.classify import classify

        from phasemap.maps.full import map_model

        if args.model is None:
            raise ValueError(f"classify needs MODEL, {_model_names()}; NAME=VALUE pairs "
                             "are optional (phasemap classify ladder phi=0.5)")
        model = map_model(args.model)
        print(classify(model, **_parse_values(args.values, model=model)))
    elif args.command == "cache":
        print(_cache(args.action))
    elif args.command == "warm":
        print(_warm(args.models, args.jobs))
    elif args.command in ("boundaries", "threshold"):
        print(_bif.run(args, _parse_values))
    elif args.command == "orbit":
        from phasemap.maps.blocks import check_output

        print(_orbits.run(args, _parse_values, check_output))
    elif args.command == "diagram":
        from phasemap.maps.blocks import check_output

        print(_orbits.run_diagram(args, _parse_values, check_output, _draw))
    return 0


def _draw(ds, stem: str):
    """``ds.phasemap.plot()`` saved as ``stem.png`` and ``stem.pdf``: their paths."""
    import matplotlib.pyplot as plt

    from phasemap.plot import save_figure

    fig = ds.phasemap.plot()
    try:
        return save_figure(fig, stem)
    finally:
        plt.close(fig)


def _warm(models: list[str], jobs: int | None) -> str:
    """``phasemap warm``'s table: per model and kind of work, the time and the compiling."""
    from phasemap.warm import warm

    done = warm(models or None, jobs=jobs)
    width = max(len(w.model) for w in done)
    rows = [f"{'model':<{width}}  {'work':<11}  {'time':>7}  {'compiling':>9}"]
    rows += [f"{w.model:<{width}}  {w.kind:<11}  {w.seconds:6.1f}s  {w.compiling:8.1f}s"
             for w in done]
    total, compiling = sum(w.seconds for w in done), sum(w.compiling for w in done)
    rows.append(f"warm: {len(done)} calls, {total:.0f} s of work, {compiling:.0f} s of it "
                "compiling (summed over the processes); later calls load these kernels from "
                "the cache")
    return "\n".join(rows)


def _cache(action: str) -> str:
    from phasemap.core import cache
    from phasemap.core.progress import human_bytes

    if action == "clear":
        files, freed = cache.clear()
        return f"removed {files} files ({human_bytes(freed)}) from the kernel cache"
    return cache.info().text()


def _parse_values(items: list[str], words: tuple[str, ...] = (), model=None) -> dict[str, float]:
    """NAME=VALUE items as numbers (the names in ``words`` keep their text); a VALUE
    may be arithmetic with pi (:func:`phasemap.core.args.parse_real`)."""
    values = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise ValueError(f"expected NAME=VALUE, got {item!r}")
        if name in values:  # as atlas refuses a repeated --axis
            raise ValueError(f"{name} is given twice ({name}={text} after "
                             f"{name}={values[name]}); give each name once")
        values[name] = text if name in words else _number(name, text, model)
    return values


def _switch(name: str, text: str) -> bool:
    """``true``/``false`` (or yes/no, 1/0) as a bool; ValueError naming ``name``."""
    word = text.strip().lower()
    if word in ("true", "yes", "1"):
        return True
    if word in ("false", "no", "0"):
        return False
    raise ValueError(f"{name} must be true or false, got {text!r}")


def _number(name: str, text: str, model=None) -> float:
    """``text`` as a number for the variable ``name`` of ``model``.

    A decimal of at least four significant digits that lies just outside a
    closed end of the variable's domain, and equals that end rounded to the
    decimals typed (``1.5708`` or ``1.571`` for the ladder's pi/2, not ``1.6``),
    is read as the end itself, with a note on stderr: it is what the user
    meant, and the exact end is the only value there that the model takes.
    """
    x = _args.parse_real(text, name, model.name if model is not None else "")
    var = model.variables.get(name) if model is not None else None
    typed = re.fullmatch(r"\s*[-+]?(\d*)\.(\d+)\s*", text)
    if var is None or typed is None or len((typed.group(1) + typed.group(2)).lstrip("0")) < 4:
        return x
    for end, outside, side in ((var.lower, x < var.lower and not var.lower_open, "lower"),
                               (var.upper, x > var.upper and not var.upper_open, "upper")):
        if outside and round(end, len(typed.group(2))) == x:
            print(f"phasemap: read {name}={text.strip()} as {_args.bound(end)}, the {side} "
                  f"end of its domain {var.domain_text()}", file=sys.stderr)
            return end
    return x


def _parse_axis(item: str, model=None) -> tuple[str, object]:
    import numpy as np

    name, sep, text = item.partition("=")
    parts = text.split(":")
    if not sep or not name or len(parts) != 3:
        raise ValueError(f"--axis expects NAME=START:STOP:COUNT, got {item!r}")
    start, stop = (_number(name, part, model) for part in parts[:2])
    try:
        count = int(parts[2])
    except ValueError:
        raise ValueError(f"--axis {name}: COUNT must be a whole number, got {parts[2]!r}") from None
    if count < 1:
        raise ValueError(f"--axis {name}: COUNT must be at least 1, got {count}")
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise ValueError(f"--axis {name}: START and STOP must be finite, got {text!r}")
    if count > 1 and start == stop:
        raise ValueError(f"--axis {name}: START = STOP = {start:g} with COUNT {count} would "
                         "repeat one value; give COUNT 1, or --set the value")
    if start > stop:
        # one rule for every command: a range is written low end first (threshold's --over
        # and --along, boundaries' --axis refuse the other order too); an atlas's values
        # still increase along its axis, which a plot may turn round
        raise ValueError(f"--axis {name}: START {start:g} is above STOP {stop:g}; every range "
                         f"on the command line is written low end first: "
                         f"{name}={parts[1]}:{parts[0]}:{parts[2]}")
    return name, np.linspace(start, stop, count)


def _atlas(args) -> str:
    from phasemap.maps import blocks
    from phasemap.atlas.atomic import destination
    from phasemap.maps.full import map_model
    from phasemap.core.progress import human_duration
    from phasemap.maps.scene import Scene

    model = map_model(args.model)
    destination(args.output)  # the folder exists, the output is no folder
    axes = dict(_parse_axis(a, model) for a in args.axis)
    if len(axes) != len(args.axis):
        raise ValueError("each --axis name may be given once")
    fixed = _parse_values(args.set, model=model)
    if not axes:  # the model's default map, less the names the user fixed
        import numpy as np

        axes = {n: np.linspace(*spec) for n, spec in model.default_axes.items() if n not in fixed}
        if not axes:
            raise ValueError(f"{model.name}: every default axis is fixed; give an --axis")
    if args.chunk_cells is not None:
        _args.count("--chunk-cells", args.chunk_cells)
    layers = [x.strip() for x in args.layers.split(",") if x.strip()] if args.layers else None
    options = _parse_values(args.option, words=("method", "impact_law", "painleve",
                                                "through_contacts", "section"))
    if "through_contacts" in options:
        options["through_contacts"] = _switch("through_contacts", options["through_contacts"])
    scene = Scene(model, axes=axes, fixed=fixed, layers=layers, options=options)
    # before any work: the destination, the disk, the size
    est = blocks.estimate(scene, args.chunk_cells)
    out = blocks.check_output(args.output, est.bytes, est.typical_bytes,
                              overwrite=args.overwrite)
    if est.cells > blocks.YES_CELLS and not args.yes:
        raise ValueError(f"{est.cells:,} cells is above {blocks.YES_CELLS:,} "
                         f"({est.text(scene).splitlines()[1].strip()}); pass --yes to go ahead")
    est = blocks.estimate(scene, args.chunk_cells, timed=True)
    print(est.text(scene), file=sys.stderr)
    if est.seconds > blocks.YES_SECONDS and not args.yes:
        raise ValueError(f"this atlas would take about {human_duration(est.seconds)}; "
                         "pass --yes to go ahead")
    blocks.write_scene(scene, out, block_cells=args.chunk_cells, overwrite=args.overwrite)
    return f"wrote {out} ({scene.size} cells, layers {', '.join(scene.layers)})"


def _simulate(args) -> str:
    from phasemap.core import progress
    from phasemap.atlas.atomic import destination
    from phasemap.atlas.write import write_atlas
    from phasemap.maps.blocks import check_output
    from phasemap.core.events import Event
    from phasemap.motion.simulate import integrated_variables, simulate
    from phasemap.systems import OSCILLATORS, get_model

    if args.model in OSCILLATORS:       # declared, without maps: full coordinates only
        from phasemap.systems.oscillators import OSCILLATORS as systems

        model = systems[args.model]
        values = _parse_values(args.values)
    else:
        model = get_model(args.model)
        values = _parse_values(args.values, model=model)
    if args.output:
        destination(args.output)
    out = check_output(args.output, overwrite=args.overwrite) if args.output else None
    with progress.activity(f"{model.name}: integrating to t = {args.t_end:g} s"):
        ds = simulate(model, args.t_end, rtol=args.rtol, method=args.method,
                      impact_law=args.impact_law, restitution=args.restitution,
                      painleve=args.painleve, zeno_speed=args.zeno_speed,
                      through_contacts=not args.reduced, t0=args.t0, **values)
    full = ds.attrs.get("phasemap_coordinates") == "full"
    if full:   # the motion went on through contact changes, in full coordinates
        names = [str(v)[len("event_"):] for v in ds.data_vars if str(v).startswith("event_")
                 and ds[v].dims == ("event",) and str(v)[len("event_"):] in ds.data_vars
                 and ds[str(v)[len("event_"):]].dims == ("t",)
                 and not str(v).startswith("event_mode_")]
        rows = [("t (s)", "event", "contact", "P_n (N s)", *names)]
        meanings = ["none", *str(ds.event_contact.attrs["flag_meanings"]).split()[1:]]
    else:
        names = [v.name for v in integrated_variables(model)]
        rows = [("t (s)", "event", "branch after", *names)]
        meanings = ["none", *model.branches]
    for i in range(ds.sizes["event"]):
        e = ds.isel(event=i)
        which = (int(e.event_contact) if full else int(e.event_branch)) + 1
        extra = ((f"{float(e.event_impulse_n):.6g}" if math.isfinite(float(e.event_impulse_n))
                  else "",) if full else ())
        rows.append((f"{float(e.event_t):.6g}", Event(int(e.event_kind)).name.lower(),
                     meanings[which], *extra,
                     *(f"{float(e[f'event_{n}']):.6g}" for n in names)))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.append(f"{ds.attrs['end_reason']}: {ds.attrs['end_message']} "
                 f"({int(ds.attrs['n_steps'])} steps, {ds.sizes['t']} saved points)")
    if out is not None:
        write_atlas(ds, out, overwrite=args.overwrite)
        lines.append(f"wrote {out}")
    return "\n".join(lines)


def _table() -> str:
    from phasemap.maps.classify import classify

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


def _models(name: str | None = None) -> str:
    from phasemap.maps.full import FullModel, map_model
    from phasemap.systems import MODELS, OSCILLATORS

    lines = []
    listed = [*MODELS.values(), *map(map_model, OSCILLATORS)] if name is None \
        else [map_model(name)]
    for m in listed:
        full = isinstance(m, FullModel)
        lines.append(f"{m.name}: {m.title}" + (" (in full coordinates)" if full else ""))
        width = max(14, *(len(v.domain_text()) for v in (*m.state, *m.params)))
        for kind, group in (("state", m.state), ("param", m.params)):
            for v in group:
                lines.append(f"  {kind}  {v.name:<6} {v.units:<8} default {v.default:<8.4g} "
                             f"domain {v.domain_text():<{width}} {v.long_name}")
        if full:
            lines.append("  phases: each contact open, stuck or slipping relative to its "
                         "surface (phasemap.maps.full)")
        else:
            lines.append(f"  branches: {', '.join(m.branches)}")
        if name is not None:
            from phasemap.maps.layers import layers_for

            layers = layers_for(m)
            lines.append(f"  layers ({len(layers)}):")
            width = max(len(n) for n in layers)
            lines += [f"    {n:<{width}}  {layer.attrs.get('long_name', '')}"
                      for n, layer in layers.items()]
        lines.append("")
    return "\n".join(lines).rstrip()


if __name__ == "__main__":
    sys.exit(main())
