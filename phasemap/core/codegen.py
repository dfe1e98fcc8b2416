"""Generated kernels: a model's branch functions, unrolled into real Python files.

A model declares its candidate branches as pure scalar functions that return
their rows (:class:`phasemap.core.model.Candidate`).  This module writes, as source
text, the code that calls them at a state, and imports it:

* the **contract** of a model: ``point(v, out)``, ``branch(v, b, row)`` and
  ``derive(v)``, what :func:`phasemap.classify`, the phase curves and the
  integrator call;
* one **grid kernel** per scene shape: the requested layers and the innermost
  axis are compile-time, so a map of ``n_solutions`` never computes a
  reaction, and the innermost loop reads every other input from a scalar
  local that LLVM keeps in a register.

Why files
---------
numba caches a compiled function on disk next to its source file, keyed by
the file's path and timestamp.  Code built with ``exec`` has no file and
recompiles in every process.  So each generated module is written once to
the kernel cache (:mod:`phasemap.core.cache`: verified, atomic, one LRU bound
over the whole cache), under a name that hashes the generated text with the
sources it calls (the model's module and the shared numerics) and the numba
version: a change to any of them makes a new file, and a stale one is never
loaded.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import pathlib
import sys
from typing import TYPE_CHECKING

import numba
import numba.extending
import numpy as np
from numba import prange

from phasemap.core import calls
from phasemap.core.memo import Memo
from phasemap.core import numerics as nx
from phasemap._version import __version__
from phasemap.core.cache import load_module
from phasemap.core.types import F1, F2, F3, I1, I2, S2

if TYPE_CHECKING:  # the contract imports this module
    from phasemap.core.model import Model


# -- what a model's code looks like as text -----------------------------------

def import_line(obj, alias: str) -> str:
    """A line that binds ``obj`` (a jitted function or a numpy ufunc) to ``alias``."""
    if isinstance(obj, np.ufunc):
        if getattr(np, obj.__name__, None) is not obj:
            raise ValueError(f"cannot generate code for the ufunc {obj!r}")
        return f"{alias} = np.{obj.__name__}"
    py = getattr(obj, "py_func", None)
    if py is None:
        raise ValueError(f"{obj!r} must be a numba.njit function or a numpy ufunc")
    module, name = py.__module__, py.__name__
    target = getattr(sys.modules.get(module), name, None)
    # a model unpickled in another process (a dask worker) holds copies of the
    # dispatchers: the same function if it has the same code
    if target is not obj and getattr(getattr(target, "py_func", None), "__code__", None) \
            != py.__code__:
        raise ValueError(f"{module}.{name} must be importable by that name (a module-level "
                         "function) to be compiled into a kernel")
    return f"from {module} import {name} as {alias}"


def input_names(func, n_const: int, inputs: tuple[str, ...], what: str) -> list[str]:
    """The input names (or ``rest``) a branch function takes after its constants."""
    names = list(inspect.signature(func.py_func).parameters)[n_const:]
    for n in names:
        if n != "rest" and n not in inputs:
            raise ValueError(f"{what}: parameter {n!r} is neither 'rest' nor an input "
                             f"({', '.join(inputs)})")
    return names


class _Source:
    """The model's branch calls as code lines, shared by every generated module."""

    def __init__(self, model):
        self.model = model
        self.inputs = model.inputs
        self.nfields = model.n_fields
        self.imports = ["import math", "import numpy as np", "from numba import njit, prange"]
        self.calls = []
        for b, spec in enumerate(model.candidates):
            self.imports.append(import_line(spec.func, f"BR{b}"))
            consts = [repr(float(a)) for a in spec.args]
            names = input_names(spec.func, len(consts), self.inputs, f"{model.name}: branch "
                            f"{spec.name!r}")
            self.calls.append((consts, names))
        # an edge row's own test (Candidate.edge): {branch: (alias, its parameters)}
        self.edges, aliases = {}, {}
        for b, spec in enumerate(model.candidates):
            if spec.edge is not None:
                if spec.edge not in aliases:
                    aliases[spec.edge] = f"EDGE{len(aliases)}"
                    self.imports.append(import_line(spec.edge, aliases[spec.edge]))
                self.edges[b] = (aliases[spec.edge], input_names(
                    spec.edge, 0, self.inputs, f"{model.name}: edge of branch {spec.name!r}"))
        self.imports.append(import_line(model.velocity_scale, "VSCALE"))
        self.scale_names = input_names(model.velocity_scale, 0, self.inputs,
                                   f"{model.name}: velocity_scale")
        for j, d in enumerate(model.derived):
            self.imports.append(import_line(d.func, f"DER{j}"))
        self.inside_names = []
        if model.inside is not None:
            self.imports.append(import_line(model.inside, "INSIDE_FN"))
            self.inside_names = input_names(model.inside, 0, self.inputs, f"{model.name}: inside")

    def call(self, b: int, rest: str, velocity: str) -> str:
        """The call of branch ``b`` with ``rest`` and the velocity local ``velocity``.

        A constant ``rest`` is passed as ``bool(True)``/``bool(False)``: numba types
        a bare constant as a literal and compiles the branch function once more for it
        (the integrator's rows and ``point``'s runtime flag would each compile every
        branch); the branch functions are inlined by LLVM, which folds the constant."""
        consts, names = self.calls[b]
        if rest in ("True", "False"):
            rest = f"bool({rest})"
        args = consts + [rest if n == "rest" else (velocity if n == self.model.velocity
                                                   else f"i_{n}") for n in names]
        return f"BR{b}({', '.join(args)})"

    def velocity_tolerance(self) -> str:
        """The magnitude below which the relative velocity counts as zero."""
        return f"{nx.TOL!r} * VSCALE({', '.join(f'i_{n}' for n in self.scale_names)})"

    def head(self, ind: str, tolerance: str | None = None) -> list[str]:
        """Lines that define ``rest`` (the velocity is zero) and ``vb`` (the velocity
        the branches see: exactly 0 at rest); ``tolerance`` names a local that holds
        :meth:`velocity_tolerance` already."""
        vel = f"i_{self.model.velocity}"
        return [f"{ind}rest = abs({vel}) <= {tolerance or self.velocity_tolerance()}",
                f"{ind}vb = 0.0 if rest else {vel}"]

    def applies(self, b: int) -> str:
        """Where branch ``b`` is a candidate: at rest, or moving in its direction."""
        vel = f"i_{self.model.velocity}"
        d = self.model.candidates[b].direction
        if d > 0:
            return f"rest | ({vel} > 0.0)"
        if d < 0:
            return f"rest | ({vel} < 0.0)"
        return "rest"

    def rows(self, ind: str, regime: str | None = None, tolerance: str | None = None,
             absent=frozenset()) -> list[str]:
        """Lines that compute the candidate rows, without control flow (for SIMD).

        Defines ``s{b}`` (status as an integer, 0 where absent), ``z{b}``
        (singular flag) and ``r{b}`` (the row tuple, meaningful where ``a{b}``:
        the branch applies).  A branch function returns its status as an
        integer, so that the summary compares integers and LLVM folds each
        status test into the branch's own conditions (a float status works, at
        the cost of selecting and comparing doubles).  With ``regime``
        ("rest", "pos" or "neg": the velocity is zero, positive or negative
        for the whole loop, and ``vb`` is set before it) only the branches that
        apply are computed, with ``rest`` a constant; the others get
        ``s{b} = 0`` and no ``r{b}``.  ``tolerance``: see :meth:`head`.  The
        branches in ``absent`` are known to be absent for the whole loop (edge rows
        off their edge: see :meth:`edge_flags`) and are left out in the same way.
        """
        out = []
        for b in self.active(regime, absent):
            rest = "rest" if regime is None else repr(regime == "rest")
            out += [f"r{b} = {self.call(b, rest, 'vb')}"]
            if regime is None:
                out += [f"a{b} = {self.applies(b)}",
                        f"s{b} = r{b}[0] if a{b} else 0",
                        f"z{b} = r{b}[1] if a{b} else 0.0"]
            else:
                out += [f"s{b} = r{b}[0]", f"z{b} = r{b}[1]"]
        for b in sorted(set(range(len(self.model.candidates)))
                        - set(self.active(regime, absent))):
            out += [f"s{b} = 0", f"z{b} = 0.0"]
        return ((self.head(ind, tolerance) if regime is None else [])
                + [ind + line for line in out])

    def active(self, regime: str | None, absent=frozenset()) -> list[int]:
        """The branches that can apply in ``regime`` (all of them for None and rest),
        but those in ``absent``."""
        if regime in (None, "rest"):
            return [b for b in range(len(self.model.candidates)) if b not in absent]
        sign = 1.0 if regime == "pos" else -1.0
        return [b for b, c in enumerate(self.model.candidates)
                if c.direction == sign and b not in absent]

    def edge_flags(self, ind: str, varying) -> tuple[list[str], dict]:
        """Lines that call, once, each edge test that reads none of the names in
        ``varying`` (the inner axis and what is derived from it), and ``{branch: local}``:
        the local that holds its row's test.  Where every such test is false, those rows
        are absent in every cell of the loop, and the loop leaves them out: it gives
        what they would give (status 0, no singular flag, no fields), bit for bit, as
        their own call of the same test would decide."""
        lines, local = [], {}
        for b, (alias, names) in self.edges.items():
            if set(names).isdisjoint(varying):
                if alias.lower() not in local.values():  # one call per edge function
                    lines.append(f"{ind}{alias.lower()} = {alias}("
                                 f"{', '.join(f'i_{n}' for n in names)})")
                local[b] = alias.lower()
        return lines, local

    def load(self, ind: str, skip=()) -> list[str]:
        """Lines that read every input but ``skip`` from ``v`` into ``i_*`` locals."""
        return [f"{ind}i_{n} = v[{k}]" for k, n in enumerate(self.inputs) if n not in skip]

    def summary(self, ind: str, names) -> list[str]:
        """Lines that reduce the rows to the requested summaries (integer locals
        ``q_<name>``, one per summary layer of :data:`phasemap.maps.layers.SUMMARY_LAYERS`).

        They stay 64-bit integers, as wide as the lanes of the double-precision
        rows, until one narrowing at the store: each early narrowing of a vector
        mask to bytes costs shuffles.
        """
        out = []
        for name in names:
            *pre, value = getattr(self, "_" + name)()
            out += [*pre, f"q_{name} = {value}"]
        return [ind + line for line in out]

    def _any(self, statuses) -> str:
        return " | ".join(f"(s{b} == {st})" for b in range(len(self.model.candidates))
                          for st in statuses)

    def _n_solutions(self) -> list[str]:
        nb = len(self.model.candidates)
        n = " + ".join(f"((s{b} == {nx.ADMISSIBLE}) | (s{b} == {nx.SEPARATION}))"
                       for b in range(nb))
        return [f"nadm = {n}",
                f"{nx.N_CONTINUUM} if ({self._any([nx.CONTINUUM])}) else "
                f"({nx.N_THREE_OR_MORE} if nadm >= 3 else nadm)"]

    def _stagnation(self) -> list[str]:
        stick = self.model.stick_branch
        return [f"int(s{stick} == {nx.ADMISSIBLE})" if stick >= 0 else "0"]

    def _contact_lost(self) -> list[str]:
        return [f"int({self._any([nx.CONTACT_LOST, nx.SEPARATION])})"]

    def _singular(self) -> list[str]:
        nb = len(self.model.candidates)
        return ["int(" + " | ".join(f"(z{b} != 0.0)" for b in range(nb)) + ")"]


def _deps(model) -> list[pathlib.Path]:
    """Source files compiled into a model's generated code."""
    mods = {spec.func.py_func.__module__ for spec in model.candidates}
    mods.add(model.velocity_scale.py_func.__module__)
    if model.inside is not None:
        mods.add(model.inside.py_func.__module__)
    mods |= {d.func.py_func.__module__ for d in model.derived if hasattr(d.func, "py_func")}
    files = sorted(pathlib.Path(sys.modules[m].__file__) for m in mods)
    return files + [pathlib.Path(nx.__file__), pathlib.Path(__file__)]


def _load(model, kind: str, text: str):
    """Write ``text`` under a content-hashed name (once) and import it."""
    h = hashlib.sha256(text.encode())
    for f in _deps(model):
        h.update(f.read_bytes())
    h.update(_versions())
    return load_module(f"{model.name}_{kind}_{h.hexdigest()[:16]}", lambda: text)


def _versions() -> bytes:
    return f"{numba.__version__} {np.__version__} {__version__}".encode()


def content_hash(model) -> str:
    """A hash of everything that decides a model's values.

    The source of every module its functions come from (for a declared model,
    the module generated from its declaration's canonical form; for a hand
    model, its own module), how the model calls them (branch constants,
    inputs, derived inputs) and the versions.  Two models with one name but
    different physics (the same system declared in two files) differ; the
    task names of a dask graph are built from it.
    """
    h = hashlib.sha256()
    for f in _deps(model):
        h.update(file_digest(f))
    layout = (model.name, model.inputs, model.velocity,
              [(c.name, tuple(c.args), c.direction, c.func.py_func.__qualname__)
               for c in model.candidates],
              [(d.name, d.source, getattr(d.func, "__name__", repr(d.func)))
               for d in model.derived],
              model.velocity_scale.py_func.__qualname__,
              getattr(getattr(model.inside, "py_func", None), "__qualname__", None))
    h.update(repr(layout).encode())
    h.update(_versions())
    return h.hexdigest()[:32]


def file_digest(path) -> bytes:
    """SHA-256 of a source file, read once per version of it (its time and size)."""
    path = os.fspath(path)
    st = os.stat(path)
    return _digest(path, st.st_mtime_ns, st.st_size)


@functools.lru_cache(maxsize=256)
def _digest(path: str, mtime_ns: int, size: int) -> bytes:
    with open(path, "rb") as fh:
        return hashlib.sha256(fh.read()).digest()


def _header(src: _Source, what: str) -> list[str]:
    return [f'"""{what} of {src.model.name}: generated by phasemap.core.codegen, do not edit."""',
            *src.imports, "", "NAN = np.nan", ""]


# -- the contract: point, branch, derive --------------------------------------

def contract(model):
    """The module holding ``point(v, out)``, ``branch(v, b, row)``, ``derive(v)``,
    ``domain(v)`` and ``rest_speed(v)`` (the velocity tolerance of ``point``'s rest test)."""
    src = _Source(model)
    nb, nf = len(model.candidates), src.nfields
    bodies = {}
    # One state at a time (classify, the integrator's events): plain control
    # flow, so that only the branches that apply are computed.  The grid
    # kernels compute the same rows with selects instead (see grid_kernel).
    body = ['    """Every candidate row at the state v; NaN where a branch does not apply."""']
    body += src.load("    ")
    body += src.head("    ")
    for b in range(nb):
        body += [f"    if {src.applies(b)}:",
                 f"        r{b} = {src.call(b, 'rest', 'vb')}"]
        body += [f"        out[{b}, {j}] = r{b}[{j}]" for j in range(nf)]
        body += ["    else:", f"        out[{b}, 0] = 0.0", f"        out[{b}, 1] = 0.0"]
        body += [f"        out[{b}, {j}] = NAN" for j in range(2, nf)]
    bodies["point(v, out)"] = body
    # The integrator indexes the row with runtime columns: a tuple of floats,
    # the status (an integer in a branch function's row) included.
    body = ['    """Branch b along its stage, as its row tuple of floats (for the integrator)."""']
    body += src.load("    ")
    for b, spec in enumerate(model.candidates):
        rest = "True" if spec.direction == 0 else "False"
        call = src.call(b, rest, "i_" + model.velocity)
        body.append("    else:" if b == nb - 1 else f"    {'if' if b == 0 else 'elif'} b == {b}:")
        body.append(f"        r{b} = {call}")
        rest_of_row = ", ".join(f"r{b}[{j}]" for j in range(1, nf))
        body.append(f"        r = (float(r{b}[0]), {rest_of_row})")
    body.append("    return r")
    bodies["branch_row(v, b)"] = body
    bodies["branch(v, b, row)"] = [
        '    """Branch b along its stage: its own slip direction, whatever the velocity."""',
        "    r = branch_row_inline(v, b)",
        *(f"    row[{j}] = r[{j}]" for j in range(nf))]
    body = ['    """Fill the derived inputs of v (sin phi ...) from their sources."""']
    slot = {n: k for k, n in enumerate(model.inputs)}
    for j, d in enumerate(model.derived):
        body.append(f"    v[{slot[d.name]}] = DER{j}(v[{slot[d.source]}])")
    if not model.derived:
        body.append("    pass")
    bodies["derive(v)"] = body
    body = ['    """The state v (derived inputs filled) lies in the domain of the model."""']
    if model.inside is not None:
        body += [f"    return INSIDE_FN({', '.join(f'v[{slot[n]}]' for n in src.inside_names)})"]
    else:
        body += ["    return True"]
    bodies["domain(v)"] = body
    body = ['    """The speed at or below which the relative velocity counts as zero (rest)."""']
    body += src.load("    ", skip=set(model.inputs) - set(src.scale_names))
    body += [f"    return {src.velocity_tolerance()}"]
    bodies["rest_speed(v)"] = body
    lines = _header(src, "The per-point contract")
    for signature, body in bodies.items():
        lines += ['@njit(cache=True, error_model="numpy")', f"def {signature}:", *body, "", ""]
    # Inlined into the integrator's right-hand side: a step evaluates it six
    # times, and an out-of-line call that passes arrays costs more than the physics.
    for signature in ("branch_row(v, b)", "derive(v)", "domain(v)", "rest_speed(v)"):
        name, args = signature.split("(", 1)
        lines += ['@njit(cache=True, forceinline=True, error_model="numpy")',
                  f"def {name}_inline({args}:",
                  *bodies[signature], "", ""]
    return _load(model, "contract", "\n".join(lines) + "\n")


def moving_test(model):
    """The module holding ``moving(v, branch)``, the integrator's test after a step where the
    velocity is outside its rest tolerance (:func:`phasemap.motion.integrate.templates._goes_on_template`).

    ``moving(v, branch)`` returns ``(sole, coef)``: the row of ``branch`` is the one
    solution (admissible, or a separation; no other row a solution or a continuum) and
    its coefficient (NaN where the branch does not apply).  Moving, ``point`` computes the
    rows of the velocity's direction only, with these arguments; here they are straight
    code with no stores, so that LLVM keeps what the statuses and the coefficient read.
    """
    src = _Source(model)
    nb = len(model.candidates)
    vel = f"i_{model.velocity}"
    body = ['    """(the row of branch is the one solution, its coefficient) at a moving '
            'state v."""']
    body += src.load("    ")
    body += [f"    s{b} = 0" for b in range(nb)] + [f"    c{b} = NAN" for b in range(nb)]
    # an edge row is computed only on its edge: elsewhere it is absent (status 0, no
    # coefficient), as its own call of the same test decides (the ladder: 8 of 12 rows)
    flags, edge_of = src.edge_flags("    ", ())
    body += flags
    for k, sign in enumerate((1.0, -1.0)):
        rows = [b for b, c in enumerate(model.candidates) if c.direction == sign]
        body.append(f"    {'if' if k == 0 else 'elif'} {vel} {'>' if sign > 0 else '<'} 0.0:")
        for b in rows:
            ind = "        "
            if b in edge_of:
                body.append(f"{ind}if {edge_of[b]}:")
                ind += "    "
            body += [f"{ind}r{b} = {src.call(b, 'False', vel)}",
                     f"{ind}s{b} = r{b}[0]", f"{ind}c{b} = r{b}[{nx.COEF}]"]
        if not rows:
            body.append("        pass")
    sm, cm = f"s{nb - 1}", f"c{nb - 1}"
    for b in range(nb - 2, -1, -1):
        sm, cm = f"(s{b} if branch == {b} else {sm})", f"(c{b} if branch == {b} else {cm})"
    solution = "(({s} == %d) | ({s} == %d))" % (nx.ADMISSIBLE, nx.SEPARATION)
    other = " | ".join(f"((branch != {b}) & ({solution.format(s=f's{b}')} | (s{b} == "
                       f"{nx.CONTINUUM})))" for b in range(nb))
    body += [f"    sm = {sm}", f"    other = {other}",
             f"    return {solution.format(s='sm')} & (not other), {cm}"]
    lines = _header(src, "The integrator's test after a step")
    lines += ['@njit(cache=True, forceinline=True, error_model="numpy")', "def moving(v, branch):",
              *body, "", ""]
    return _load(model, "moving", "\n".join(lines) + "\n")


# -- the grid kernels -----------------------------------------------------------

#: Inner-axis cells per parallel task (an inner axis longer than this is split).
CHUNK = 4096

#: Every generated ``cells`` function has this signature:
#: ``cells(v, first, lo, hi, inner_values, inner_deriv, flags, fields)``.
CELLS_SIGNATURE = numba.void(F1, numba.int64, numba.int64, numba.int64, F1, F2, S2, F2)


@numba.extending.intrinsic
def call_cells(typingctx, at, v, first, lo, hi, inner_values, inner_deriv, flags, fields):
    """A generated ``cells`` (:data:`CELLS_SIGNATURE`) at its compiled address ``at``
    (:func:`phasemap.core.calls.address`): cells lo..hi of the inner axis at the outer
    state v."""
    return calls.typer(CELLS_SIGNATURE, at,
                       (v, first, lo, hi, inner_values, inner_deriv, flags, fields))


@numba.njit(inline="always")
def set_cell(v, cell, shape, axis_slot, axis_values, deriv_slot, deriv_values):
    """Put the axis values of grid cell ``cell`` (C order) and their derived inputs into ``v``."""
    rem = cell
    for d in range(shape.shape[0] - 1, -1, -1):
        i = rem % shape[d]
        rem //= shape[d]
        v[axis_slot[d]] = axis_values[d, i]
        for k in range(deriv_slot.shape[1]):
            if deriv_slot[d, k] >= 0:
                v[deriv_slot[d, k]] = deriv_values[d, k, i]


#: Parallel tasks per thread (see :func:`driver`): each takes a contiguous run of
#: (outer cell, inner chunk) items and copies the fixed inputs once for all of them.
TASKS_PER_THREAD = 4


def _drive(cells_at, ntasks, base, outer_shape, outer_slot, outer_values, outer_dslot,
           outer_dvalues, inner_values, inner_deriv, flags, fields):
    """Run the ``cells`` at the address ``cells_at`` over every outer cell (and chunk of
    the inner axis), in parallel as ``ntasks`` tasks (fewer if there are fewer items)."""
    nod = outer_shape.shape[0]
    nouter = 1
    for d in range(nod):
        nouter *= outer_shape[d]
    ninner = inner_values.shape[0]
    nchunks = (ninner + CHUNK - 1) // CHUNK
    nitems = nouter * nchunks
    ntasks = max(1, min(nitems, ntasks))
    for task in prange(ntasks):
        v = base.copy()
        for item in range(task * nitems // ntasks, (task + 1) * nitems // ntasks):
            o = item // nchunks
            lo = (item % nchunks) * CHUNK
            set_cell(v, o, outer_shape, outer_slot, outer_values, outer_dslot, outer_dvalues)
            call_cells(cells_at, v, o * ninner, lo, min(lo + CHUNK, ninner), inner_values,
                       inner_deriv, flags, fields)


_DRIVER = []


def driver():
    """The one parallel driver of every grid kernel (compiled once, cached on disk).

    It takes the scene's generated ``cells`` by the address of its machine code
    (:mod:`phasemap.core.calls`), so numba's parfor machinery (a few seconds of compile
    time, mostly spent re-optimising the loop body it inlines) runs once, not once per
    scene shape.  It releases the GIL, so that a map in a thread of its own does not
    wait for the caller's.
    """
    if not _DRIVER:
        sig = numba.void(numba.intp, numba.int64, F1, I1, I1, F2, I2, F3, F1, F2, S2, F2)
        _DRIVER.append(numba.njit(sig, parallel=True, nogil=True, cache=True,
                                  error_model="numpy")(_drive))
    return _DRIVER[0]


def run_grid(cells, base, outer_shape, outer_slot, outer_values, outer_dslot, outer_dvalues,
             inner_values, inner_deriv, flags, fields) -> None:
    """Run the generated ``cells`` (:func:`grid_kernel`) over a grid with :func:`driver`.

    The driver gets ``cells`` as its compiled address: passed as the jitted
    function, numba would type it again at every call (0.1 to 0.3 ms, more
    than a small map's cells).
    """
    driver()(calls.address(cells, CELLS_SIGNATURE.args), TASKS_PER_THREAD * numba.get_num_threads(), base, outer_shape,
             outer_slot, outer_values, outer_dslot, outer_dvalues, inner_values, inner_deriv,
             flags, fields)


_KERNELS = Memo("codegen.grid_kernels")


def grid_kernel(model, layers, inner: str):
    """The ``cells`` function for the requested ``layers`` with ``inner`` innermost.

    ``cells(v, first, lo, hi, inner_values, inner_deriv, flags, fields)``
    computes cells ``lo..hi`` of the inner axis at the outer state ``v`` and
    writes them from column ``first`` on: the int8 summary layers to the rows
    of ``flags`` and the float layers to the rows of ``fields``, each in the
    order of ``layers``.  :func:`driver` runs it over a grid.  Remembered per
    process, so that a scene computed block by block generates and hashes its
    source once, not once per block.
    """
    return _KERNELS.get((model,), (tuple(l.name for l in layers), inner),
                        lambda: _generate_grid_kernel(model, layers, inner))


def _generate_grid_kernel(model, layers, inner: str):
    """Write (once) and load the ``cells`` function of :func:`grid_kernel`."""
    src = _Source(model)
    inner_derived = [d for d in model.derived if d.source == inner]
    skip = {inner} | {d.name for d in inner_derived}
    flag_layers = [l for l in layers if l.is_summary]
    field_layers = [l for l in layers if not l.is_summary]
    lines = _header(src, f"Grid kernel ({', '.join(l.name for l in layers)}; inner {inner})")
    lines += ["from phasemap.core.codegen import CELLS_SIGNATURE", "",
              '@njit(CELLS_SIGNATURE, cache=True, error_model="numpy")',
              "def cells(v, first, lo, hi, inner_values, inner_deriv, flags, fields):",
              '    """Cells lo..hi of the inner axis at the outer state v; outputs from first."""']
    lines += src.load("    ", skip)
    # The loops index slices from 0 with an unsigned index (``for j in range(n)``,
    # n a uint64): an index such as ``first + j`` may be negative for all LLVM
    # knows, and numba's wraparound for it turns vector loads into gathers and
    # vector stores into bytes.  A signed ``j`` from 0 is not always enough: in
    # the ladder's rest loop (27 rows) LLVM kept the wraparound of ``flags_0[j]``
    # and stored four bytes one at a time; numba emits none for an unsigned index.
    lines += ["    n = np.uint64(max(hi - lo, 0))", f"    x_{inner} = inner_values[lo:hi]"]
    lines += [f"    x_{d.name} = inner_deriv[{k}, lo:hi]" for k, d in enumerate(inner_derived)]
    out = "first + lo:first + hi"
    lines += [f"    flags_{k} = flags[{k}, {out}]" for k in range(len(flag_layers))]
    lines += [f"    fields_{k} = fields[{k}, {out}]" for k in range(len(field_layers))]
    # One store stream per loop vectorises; several (rows of one array, which
    # LLVM cannot prove disjoint) do not.  So several summary layers are packed
    # into one byte per cell, at the bit positions of the layer registry, in
    # the first layer's row, and unpacked by one short loop per layer.
    packed = len(flag_layers) > 1
    tolerance = None  # or the local holding the zero-velocity tolerance of every cell

    def loop(ind: str, regime: str | None, absent=frozenset()) -> list[str]:
        body = [f"{ind}for j in range(n):", f"{ind}    i_{inner} = x_{inner}[j]"]
        body += [f"{ind}    i_{d.name} = x_{d.name}[j]" for d in inner_derived]
        body += src.rows(ind + "    ", regime, tolerance, absent)
        body += src.summary(ind + "    ", [l.name for l in flag_layers])
        if packed:
            bits = " | ".join(f"(q_{l.name} << {l.shift})" if l.shift else f"q_{l.name}"
                              for l in flag_layers)
            body.append(f"{ind}    flags_0[j] = np.int8({bits})")
        elif flag_layers:
            body.append(f"{ind}    flags_0[j] = np.int8(q_{flag_layers[0].name})")
        active = src.active(regime, absent)
        for k, layer in enumerate(field_layers):
            b, col = layer.branch, layer.column
            keep = f"((s{b} == {nx.ADMISSIBLE}) | (s{b} == {nx.SEPARATION}))"
            if not layer.admissible_only:
                keep = f"(s{b} != {nx.ABSENT})"
            value = f"r{b}[{col}] if {keep} else NAN" if b in active else "NAN"
            body.append(f"{ind}    fields_{k}[j] = {value}")
        return body

    # An edge row whose test the inner axis does not enter is absent along the whole
    # loop off its edge (every cell but those of a grid's bounding lines): a second
    # loop leaves such rows out (8 of the ladder's 12 rows moving, 16 of 27 at rest).
    flag_lines, edge_of = src.edge_flags("    ", skip)
    lines += flag_lines

    def versions(ind: str, regime: str | None) -> list[str]:
        off = sorted(set(edge_of) & set(src.active(regime)))
        if not off:
            return loop(ind, regime)
        on = " | ".join(sorted({edge_of[b] for b in off}))
        return [f"{ind}if {on}:", *loop(ind + "    ", regime),
                f"{ind}else:", *loop(ind + "    ", regime, frozenset(off))]

    if inner != model.velocity and inner not in src.scale_names:
        # The velocity is the same along the whole loop: one loop per regime,
        # each computing only the branches that can apply (a moving state
        # needs one slip direction of the candidates, not all).
        lines += src.head("    ")
        lines += ["    if rest:", *versions("        ", "rest"),
                  f"    elif i_{model.velocity} > 0.0:", *versions("        ", "pos"),
                  "    else:", *versions("        ", "neg")]
    else:
        if inner not in src.scale_names:  # the same zero-velocity tolerance in every cell
            lines.append(f"    vtol = {src.velocity_tolerance()}")
            tolerance = "vtol"
        lines += versions("    ", None)
    if packed:  # the first layer's row last: the others read the packed byte from it
        for k, layer in reversed(list(enumerate(flag_layers))):
            bits = f"(flags_0[j] >> {layer.shift})" if layer.shift else "flags_0[j]"
            lines += ["    for j in range(n):", f"        flags_{k}[j] = {bits} & {layer.mask}"]
    key = "_".join(l.name for l in layers)
    tag = hashlib.sha256(f"{key}|{inner}".encode()).hexdigest()[:8]
    return _load(model, f"grid_{inner}_{tag}", "\n".join(lines) + "\n").cells


def pack_axes(model: Model, axes: dict[str, np.ndarray], fixed: dict[str, float]):
    """The runtime layout of a grid, shared by every grid-shaped kernel.

    Returns ``(base, shape, axis_slot, axis_values, deriv_slot, deriv_values)``:
    the input vector with the fixed values and their derived inputs, the grid
    shape, the input slot of each axis, the axis values (padded to one length),
    and per axis the slots and precomputed values of its derived inputs.
    """
    names = list(axes)
    shape = np.array([len(axes[n]) for n in names], dtype=np.int64)
    slot = {n: i for i, n in enumerate(model.inputs)}
    base = np.zeros(len(model.inputs))
    for n, x in fixed.items():
        base[slot[n]] = x
    by_source: dict[str, list] = {}
    for d in model.derived:
        by_source.setdefault(d.source, []).append(d)
        if d.source in fixed:
            base[slot[d.name]] = d.func(float(fixed[d.source]))
    length = int(shape.max()) if len(shape) else 1
    nd = max((len(v) for v in by_source.values()), default=0)
    axis_values = np.zeros((len(names), length))
    deriv_slot = np.full((len(names), max(nd, 1)), -1, dtype=np.int64)
    deriv_values = np.zeros((len(names), max(nd, 1), length))
    for i, n in enumerate(names):
        axis_values[i, :shape[i]] = axes[n]
        for k, d in enumerate(by_source.get(n, [])):
            deriv_slot[i, k] = slot[d.name]
            deriv_values[i, k, :shape[i]] = d.func(np.asarray(axes[n], dtype=float))
    axis_slot = np.array([slot[n] for n in names], dtype=np.int64)
    return base, shape, axis_slot, axis_values, deriv_slot, deriv_values
