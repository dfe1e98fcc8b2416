"""The derivations of the built-in declarations, written into the package.

A built-in declared model (``phasemap.systems.DECLARED``: the ladder, the wheel, the
Painlevé rod, the rod on a step) is derived with sympy the first time a machine uses it:
about a second to import sympy and up to five to derive.  The package ships each
derivation instead (``phasemap/systems/derived/<module>.json``: the generated module's
text; that text as the kernel cache writes it, rewritten by :mod:`phasemap.core.selects`,
used while the rewriter is the one that made it; the manifest
:func:`phasemap.declare.loader.build` reads; and the full-coordinate modules of
:mod:`phasemap.declare.full`), so that a first ``classify``, and a first
motion through contact changes, answer at once.  :func:`phasemap.declare.loader.load`
uses a shipped file only while its key (:func:`phasemap.declare.loader.key_of` with ``versions=False``: the
declaration file, the phasemap modules it imports and the sources that derive it) is
that of the tree; otherwise it derives the model as before.

After a change to :mod:`phasemap.declare`, the shared numerics or a built-in declaration,
``tests/test_shipped.py`` fails until the files are written again::

    python -m phasemap.systems.ship            # all of them
    python -m phasemap.systems.ship --check    # exit 1, naming the stale ones
"""

from __future__ import annotations

import argparse
import hashlib
import json
import pathlib
import sys

from phasemap.declare import full, loader
from phasemap.systems import DECLARED


#: the generated modules of :mod:`phasemap.declare.full` a record carries beside the model's
KINDS = ("mechanics", "closure")


def record(source: str) -> dict:
    """The shipped record of the built-in declaration module ``source``, derived now with
    sympy (in a process whose kernel cache may hold it already)."""
    from phasemap.core.cache import module_text

    S = loader.system(source)
    model = S.model
    data = loader.described(S, model)
    if data is None:
        raise ValueError(f"{source}: its model cannot be rebuilt without its declaration "
                         "(an expression as a bound, or a check of its own module)")
    module = sys.modules[model.velocity_scale.py_func.__module__]  # (as manifest() finds it)
    import sympy

    key = loader.shipped_key(source)
    if key is None:
        raise ValueError(f"{source}: the declaration file cannot be keyed (it reads what its "
                         "key does not hold: see phasemap.declare.loader), so it cannot ship")
    from phasemap.core.cache import rewriter
    from phasemap.core.selects import selects
    from phasemap.declare.emit import module_source

    # the generated text, as the derivation gave it to the kernel cache (the cache's file
    # holds it rewritten)
    text = module_source(S)
    ready = selects(text)
    if ready != module_text(module):
        raise AssertionError(f"{source}: the kernel cache holds another derivation")
    out = {"format": loader.FORMAT, "key": key,
           "sympy": sympy.__version__, "model": data, "source": text,
           # what the kernel cache writes of it, made here so that a first use does not
           # rewrite it (a third of a second for the ladder and the rod on a step)
           "rewritten": rewritten(text, ready, rewriter())}
    for kind in KINDS:      # the full coordinates of the motion through contact changes
        out[kind] = {"key": full.shipped_key(S, kind), "text": full.text(S, kind)}
    return out


def rewritten(source: str, text: str, by: str) -> dict:
    """A record's ``rewritten`` field: the rewrite ``text`` of ``source`` by the rewriter
    ``by``, which :func:`phasemap.declare.loader.load` uses while both match."""
    return {"by": by, "of": hashlib.sha256(source.encode()).hexdigest(), "text": text}


def stale(sources=None) -> list[str]:
    """The built-in declarations whose shipped derivation is missing or not the tree's (its
    rewrite made by another version of the rewriter, or of another text, included)."""
    out = []
    for source in sources or DECLARED.values():
        data = loader.shipped_record(source) or {}
        key = loader.shipped_key(source)
        ok = key is not None and data.get("key") == key and "model" in data
        ok = ok and loader.shipped_rewrite(data) is not None
        if ok:      # the same declaration: its full-coordinate modules' keys, from its hash
            declaration = loader.Declaration(source, data["model"]["declaration_sha256"])
            ok = all((data.get(kind) or {}).get("key") == full.shipped_key(declaration, kind)
                     for kind in KINDS)
        if not ok:
            out.append(source)
    return out


def write(sources=None) -> list[pathlib.Path]:
    """Derive and write the shipped record of each built-in declaration (all by default)."""
    loader.SHIPPED.mkdir(parents=True, exist_ok=True)
    written = []
    for source in sources or DECLARED.values():
        file = loader.shipped_file(source)
        file.write_text(json.dumps(record(source), indent=1, sort_keys=True) + "\n")
        written.append(file)
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m phasemap.systems.ship",
                                 description="write the shipped derivations of the built-in "
                                 "declarations (phasemap/systems/derived/)")
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 naming the stale ones")
    args = ap.parse_args(argv)
    if args.check:
        old = stale()
        for source in old:
            print(f"stale: {source} (python -m phasemap.systems.ship)")
        return 1 if old else 0
    for file in write():
        print(f"wrote {file}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
