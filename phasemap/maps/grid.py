"""The grid evaluator: one generated parallel numba kernel per scene shape.

:func:`evaluate` asks :func:`phasemap.core.codegen.grid_kernel` for the kernel
of the requested layers with the scene's last axis innermost; both are
compile-time, everything else (parameter values, axes, the outer axes'
names) is a runtime argument, so a kernel compiles once per (model, layer
set, inner axis) and is cached on disk.

Layout
------
Cells are taken in C order.  The items of work are the outer cells (every
axis but the last) times chunks of the inner axis; ``prange`` runs a few
tasks per thread over contiguous runs of them, each copying the fixed inputs
once.  For each item the kernel sets its outer axes, reads every input into a
scalar local, and runs one loop per velocity regime over the inner axis: it
only loads the inner axis value (and its derived inputs such as sin(phi),
computed once per axis value here) and evaluates the inlined branch
functions, with statuses compared as integers and indices from zero: no
calls, no heap scratch, and nothing that the requested layers do not need.
The result arrays are the Dataset's (no copy).
"""

from __future__ import annotations

import numpy as np

from phasemap.core.codegen import grid_kernel, pack_axes, run_grid
from phasemap.maps.layers import Layer, layers_for
from phasemap.core.model import Model


def evaluate(model: Model, axes: dict[str, np.ndarray], fixed: dict[str, float],
             layers: list[Layer]) -> dict[str, np.ndarray]:
    """Evaluate ``layers`` over the grid spanned by ``axes`` (validated values).

    ``axes`` maps names to 1-D float arrays (in dimension order), ``fixed`` the
    remaining names to floats.  Returns one array of shape ``grid`` per layer.
    """
    if not layers:
        return {}
    names = list(axes)
    grid = tuple(len(axes[n]) for n in names)
    if names:
        inner = names[-1]
        inner_values = np.array(axes[inner], dtype=float)  # a writable C copy (dask's are not)
    else:  # a single point: one cell along the first state variable
        inner = model.state[0].name
        inner_values = np.array([float(fixed[inner])])
    outer = {n: axes[n] for n in names[:-1]}
    base, shape, axis_slot, axis_values, deriv_slot, deriv_values = pack_axes(
        model, outer, {n: x for n, x in fixed.items() if n != inner})
    inner_deriv = np.array([d.func(inner_values) for d in model.derived if d.source == inner],
                           dtype=float).reshape(-1, inner_values.size)
    order = list(layers_for(model))
    wanted = sorted({l.name: l for l in layers}.values(), key=lambda l: order.index(l.name))
    ncells = int(np.prod(grid, dtype=np.int64))
    flag_layers = [l for l in wanted if l.is_summary]
    field_layers = [l for l in wanted if not l.is_summary]
    flags = np.empty((len(flag_layers), ncells), dtype=np.int8)
    fields = np.empty((len(field_layers), ncells))
    cells = grid_kernel(model, tuple(flag_layers + field_layers), inner)
    run_grid(cells, base, shape, axis_slot, axis_values, deriv_slot, deriv_values, inner_values,
             inner_deriv, flags, fields)
    out = {l.name: flags[k].reshape(grid) for k, l in enumerate(flag_layers)}
    out.update({l.name: fields[k].reshape(grid) for k, l in enumerate(field_layers)})
    return {l.name: out[l.name] for l in wanted}
