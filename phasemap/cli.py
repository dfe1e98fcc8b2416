"""The ``phasemap`` command line."""

from __future__ import annotations

import argparse
import math
import sys

from ._version import __version__

EPILOG = """\
examples:
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
    sub.add_parser("models", help="list the models with their variables, units and defaults")
    p = sub.add_parser("classify", help="classify one state: phasemap classify MODEL name=value ...",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model")
    p.add_argument("values", nargs="*", metavar="NAME=VALUE")
    args = parser.parse_args(argv)
    try:
        if args.command in (None, "table"):
            print(_table())
        elif args.command == "models":
            print(_models())
        elif args.command == "classify":
            from .classify import classify

            print(classify(args.model, **_parse_values(args.values)))
    except ValueError as err:
        print(f"phasemap: error: {err}", file=sys.stderr)
        return 2
    return 0


def _parse_values(items: list[str]) -> dict[str, float]:
    values = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise ValueError(f"expected NAME=VALUE, got {item!r}")
        try:
            values[name] = float(text)
        except ValueError:
            raise ValueError(f"{name}: {text!r} is not a number") from None
    return values


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
