"""The grid evaluator: one parallel numba kernel per model over any N-D grid.

``make_grid_kernel(model)`` binds the model's jitted ``point`` function and
the shared ``summarize`` into one ``@njit(parallel=True, cache=True)`` kernel,
cached per model in memory and on disk.  Parameter values, axes and the choice of layers are runtime
arguments, so the kernel compiles once per model, never per value.

Layout
------
Cells are taken in C order.  ``prange`` runs over blocks of ``BLOCK`` cells;
each block allocates its scratch (the input vector ``v`` and the branch rows
``out``) once, unravels its first cell and then steps a multi-index counter.
Per-axis work (the model's derived inputs such as sin(phi)) is computed once
per axis value, outside the kernel, and only copied in the inner loop.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from . import _numerics as nx
from ._compile import specialize
from .layers import SUMMARY, Layer
from .model import Model

BLOCK = 2048

# Compile-time structure of the model being compiled: the template below reads
# these as globals, and :func:`phasemap._compile.specialize` gives each model a
# copy of the template with its own.
POINT = None
STICK = -1
N_BRANCHES = 0
N_FIELDS = 0


def make_grid_kernel(model: Model):
    """The parallel grid kernel of ``model``: compiled once, cached in memory and on disk."""
    return specialize(_kernel_template, model, "grid_kernel", parallel=True,
                      POINT=model.point, STICK=model.stick_branch,
                      N_BRANCHES=len(model.branches), N_FIELDS=model.n_fields)


@njit(cache=True)
def _set_axis(v, d, i, axis_slot, axis_values, deriv_slot, deriv_values):
    """Put value ``i`` of axis ``d`` and its precomputed derived inputs into ``v``."""
    v[axis_slot[d]] = axis_values[d, i]
    for k in range(deriv_slot.shape[1]):
        if deriv_slot[d, k] >= 0:
            v[deriv_slot[d, k]] = deriv_values[d, k, i]


def _kernel_template(base, shape, axis_slot, axis_values, deriv_slot, deriv_values,
                     summary_row, req_branch, req_col, req_adm, summary, fields):
    """Classify every cell of the grid; write the wanted summaries and branch fields.

    ``summary`` is int8 (nsummary, ncells): n_solutions, stagnation,
    contact_lost and singular go to row ``summary_row[k]`` (k in that order),
    or nowhere where it is -1.  ``fields`` is float64 (nreq, ncells)
    with column ``req_col[q]`` of branch ``req_branch[q]`` (NaN unless the branch
    is admissible, or unless it applies when ``req_adm[q]`` is False).
    """
    ndim = shape.shape[0]
    ncells = 1
    for d in range(ndim):
        ncells *= shape[d]
    nblocks = (ncells + BLOCK - 1) // BLOCK
    nreq = req_branch.shape[0]
    for blk in prange(nblocks):
        v = base.copy()
        out = np.empty((N_BRANCHES, N_FIELDS))
        idx = np.empty(ndim, dtype=np.int64)
        start = blk * BLOCK
        stop = min(start + BLOCK, ncells)
        rem = start
        for d in range(ndim - 1, -1, -1):
            idx[d] = rem % shape[d]
            rem //= shape[d]
        for d in range(ndim):
            _set_axis(v, d, idx[d], axis_slot, axis_values, deriv_slot, deriv_values)
        for cell in range(start, stop):
            POINT(v, out)
            n, stag, lost, sing = nx.summarize(out, STICK)
            if summary_row[0] >= 0:
                summary[summary_row[0], cell] = n
            if summary_row[1] >= 0:
                summary[summary_row[1], cell] = stag
            if summary_row[2] >= 0:
                summary[summary_row[2], cell] = lost
            if summary_row[3] >= 0:
                summary[summary_row[3], cell] = sing
            for q in range(nreq):
                b = req_branch[q]
                st = out[b, nx.STATUS]
                if st == nx.ADMISSIBLE or (not req_adm[q] and st != nx.ABSENT):
                    fields[q, cell] = out[b, req_col[q]]
                else:
                    fields[q, cell] = np.nan
            # step the multi-index; refresh only the axes that changed
            d = ndim - 1
            while d >= 0:
                idx[d] += 1
                if idx[d] < shape[d]:
                    _set_axis(v, d, idx[d], axis_slot, axis_values, deriv_slot, deriv_values)
                    break
                idx[d] = 0
                _set_axis(v, d, 0, axis_slot, axis_values, deriv_slot, deriv_values)
                d -= 1


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


def evaluate(model: Model, axes: dict[str, np.ndarray], fixed: dict[str, float],
             layers: list[Layer]) -> dict[str, np.ndarray]:
    """Evaluate ``layers`` over the grid spanned by ``axes`` (validated values).

    ``axes`` maps names to 1-D float arrays (in dimension order), ``fixed`` the
    remaining names to floats.  Returns one array of shape ``grid`` per layer.
    """
    packed = pack_axes(model, axes, fixed)
    shape = packed[1]
    ncells = int(np.prod(shape))
    summary_layers = [l.name for l in layers if l.is_summary]
    summary_row = np.array([summary_layers.index(k) if k in summary_layers else -1
                            for k in SUMMARY], dtype=np.int64)
    summary = np.empty((len(summary_layers), ncells), dtype=np.int8)
    field_layers = [l for l in layers if not l.is_summary]
    fields = np.empty((len(field_layers), ncells))
    make_grid_kernel(model)(
        *packed, summary_row,
        np.array([l.branch for l in field_layers], dtype=np.int64),
        np.array([l.column for l in field_layers], dtype=np.int64),
        np.array([l.admissible_only for l in field_layers]), summary, fields)
    grid = tuple(int(s) for s in shape)
    return {l.name: (summary[summary_layers.index(l.name)] if l.is_summary
                     else fields[field_layers.index(l)]).reshape(grid) for l in layers}
