"""The bifurcation set of a map as exact curves: :func:`boundaries` (every boundary
piece of a slice with its special points) and :func:`threshold` (the least or
greatest parameter at which a class exists, optionally as a curve in a further
parameter).

The modules load on first use (sympy and the tracer), so that the command line
can register its subcommands (:mod:`phasemap.bifurcation.command`) cheaply.
"""

_EXPORTS = {"boundaries": "tracing", "Condition": "conditions", "Threshold": "thresholds",
            "threshold": "search"}


def __getattr__(name: str):
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["Condition", "Threshold", "boundaries", "threshold"]
