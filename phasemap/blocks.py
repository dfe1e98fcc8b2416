"""Large atlases: estimate before any work, then compute and write block by block.

A scene of any size is computed in *blocks*: hyperslabs of the grid that each
take well under a second, so that a progress bar moves, Ctrl-C takes effect
between two blocks, and memory stays bounded.  :func:`write_scene` writes
each block into the netCDF file as soon as it is computed (no dask graph is
built, whatever the size), into a temporary file that is renamed over the
destination only when complete.

Before any work, :func:`estimate` says what a scene will cost: cells, output
size (uncompressed and typical), memory and, from a timed sample of the
grid's own cells, time.  :func:`check_output` refuses, in one line, what
cannot be written: an existing file (without ``overwrite``), a folder that is
not writable, a disk without room for the typical size.  The command line
also asks for ``--yes`` above :data:`YES_CELLS` cells or :data:`YES_SECONDS`.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import pathlib
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from . import progress
from .atlas import _default_chunks, _prepare, _size, cf_encoding, destination, no_partial_file
from .layers import layers_for

#: Above this many cells the command line asks for ``--yes``.
YES_CELLS = 10 ** 9
#: Above this estimated time (s) the command line asks for ``--yes``.
YES_SECONDS = 3600.0
#: Wall time a block should take (s): the progress bar moves and Ctrl-C works
#: between blocks.
BLOCK_SECONDS = 0.25
#: Bounds on the cells of a block: maps, and fate maps (a trajectory per cell).
MAP_BLOCK_CELLS = (1 << 12, 1 << 22)
FATE_BLOCK_CELLS = (1 << 6, 1 << 16)
#: Cells timed to estimate the time of a scene.
SAMPLE_CELLS = {"map": 1 << 16, "fate": 1 << 8}
#: Typical netCDF size over the uncompressed size, by layer dtype (zlib level 4
#: with shuffle on smooth maps: categorical layers are long runs; float layers
#: are NaN wherever a branch is not admissible).  A rough guide: the disk check
#: uses it, and warns when the uncompressed size would not fit.
TYPICAL_RATIO = {"int8": 0.05, "int32": 0.15, "float64": 0.5}


@dataclass(frozen=True)
class Estimate:
    """What a scene will cost before it runs."""

    cells: int
    bytes: int           # uncompressed output
    typical_bytes: int   # typical compressed output
    memory: int          # peak memory of the block-by-block computation, about
    block_cells: int
    seconds: float | None = None  # from a timed sample; None until measured

    def text(self, scene) -> str:
        """Two lines for a person: size, output, memory and time."""
        dims = " x ".join(f"{a.size} {n}" for n, a in scene.axes.items())
        t = "" if self.seconds is None else f"; time about {_duration(self.seconds)}"
        return (f"{scene.model.name} atlas: {self.cells:,} cells ({dims}), layers "
                f"{', '.join(scene.layers)}\n  output {_size(self.bytes)} uncompressed, about "
                f"{_size(self.typical_bytes)} typical; memory about {_size(self.memory)}{t}")


def estimate(scene, block_cells: int | None = None, timed: bool = False) -> Estimate:
    """Cells, output size, memory and (with ``timed``) time of ``scene``.

    The time comes from computing a strided sample of the scene's own cells
    (:data:`SAMPLE_CELLS`) after the kernel is compiled, scaled to the whole
    grid.  ``block_cells`` defaults to about :data:`BLOCK_SECONDS` of work.
    """
    reg = layers_for(scene.model)
    itemsizes = {n: np.dtype(reg[n].dtype).itemsize for n in scene.layers}
    cells = scene.size
    out_bytes = cells * sum(itemsizes.values())
    typical = int(sum(cells * s * TYPICAL_RATIO.get(reg[n].dtype, 1.0)
                      for n, s in itemsizes.items()))
    seconds = per_cell = None
    if timed:
        per_cell = _seconds_per_cell(scene)
        seconds = per_cell * cells
    block = block_cells or _block_cells(scene, per_cell)
    per_cell_bytes = sum(itemsizes.values()) + 8 * len(scene.layers)  # result and scratch
    memory = 3 * block * per_cell_bytes + 8 * sum(a.size for a in scene.axes.values()) \
        + (256 << 20)  # the interpreter with numpy, numba, xarray and netCDF loaded
    return Estimate(cells, out_bytes, typical, memory, block, seconds)


def _block_cells(scene, per_cell: float | None) -> int:
    lo, hi = FATE_BLOCK_CELLS if scene._fate else MAP_BLOCK_CELLS
    if per_cell is None or per_cell <= 0:
        want = hi if not scene._fate else 1 << 12
    else:
        want = BLOCK_SECONDS / per_cell
    return int(min(hi, max(lo, 1 << max(0, int(math.log2(max(want, 1)))))))


def _seconds_per_cell(scene) -> float:
    """Seconds per cell of ``scene``, from a strided sample of its cells (compiled first)."""
    kind = "fate" if scene._fate else "map"
    target = min(SAMPLE_CELLS[kind], scene.size)
    per_axis = max(1, int(round(target ** (1.0 / len(scene.axes)))))
    sample = {}
    for name, a in scene.axes.items():
        k = min(a.size, per_axis)
        sample[name] = a[np.unique(np.linspace(0, a.size - 1, k).round().astype(int))]
    wanted = [layers_for(scene.model)[n] for n in scene.layers]
    with progress.activity(f"{scene.model.name}: compiling or loading the kernels"):
        scene._evaluate({n: a[:1] for n, a in sample.items()}, wanted)
    n = math.prod(a.size for a in sample.values())
    with progress.activity(f"{scene.model.name}: timing {n} sample cells"):
        start = time.perf_counter()
        scene._evaluate(sample, wanted)
        return (time.perf_counter() - start) / n


# --------------------------------------------------------------------------- checks


def check_output(path, need_bytes: int = 0, typical_bytes: int = 0, *,
                 overwrite: bool = False) -> pathlib.Path:
    """Check before any work that ``path`` can be written; return it as a Path.

    Raises ValueError in one line when the folder is missing or not writable,
    when ``path`` exists and ``overwrite`` is false, or when the typical size
    does not fit on the folder's free disk.  Warns on stderr when the
    uncompressed size would not fit.
    """
    path = destination(path)
    if path.exists() and not overwrite:
        raise ValueError(f"{path} exists; pass --overwrite to replace it")
    folder = path.parent
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.", suffix=".probe")
    except OSError as err:
        raise ValueError(f"cannot write {path}: {err.strerror or err} ({folder})") from None
    os.close(fd)
    os.unlink(probe)
    free = shutil.disk_usage(folder).free
    if typical_bytes > free:
        raise ValueError(f"cannot write {path}: it needs about {_size(typical_bytes)} "
                         f"(typical; {_size(need_bytes)} uncompressed) and {folder} has "
                         f"{_size(free)} free")
    if need_bytes > free:
        print(f"phasemap: warning: {path} may need up to {_size(need_bytes)} uncompressed "
              f"and {folder} has {_size(free)} free", file=sys.stderr)
    return path


# --------------------------------------------------------------------------- blocks


def plan(shape: tuple[int, ...], block_cells: int) -> tuple[int, int]:
    """``(k, length)``: blocks take one index of each axis before ``k``, ``length``
    values of axis ``k`` (a power of two, or the whole axis) and all of the rest."""
    block_cells = max(1, int(block_cells))
    for k in range(len(shape)):
        rest = math.prod(shape[k + 1:])
        if rest <= block_cells:
            length = block_cells // rest
            if length >= shape[k]:
                return k, shape[k]
            return k, 1 << int(math.log2(length))
    return len(shape) - 1, 1


def blocks(shape: tuple[int, ...], k: int, length: int) -> Iterator[tuple[slice, ...]]:
    """The blocks of :func:`plan` in C order, as index tuples."""
    tail = (slice(None),) * (len(shape) - k - 1)
    for lead in itertools.product(*(range(n) for n in shape[:k])):
        head = tuple(slice(i, i + 1) for i in lead)
        for a in range(0, shape[k], length):
            yield head + (slice(a, min(a + length, shape[k])),) + tail


def compute_blocks(scene, block_cells: int, desc: str) -> Iterator[tuple[tuple[slice, ...],
                                                                           dict]]:
    """Yield ``(index, {layer: array})`` block by block, with a progress bar."""
    reg = layers_for(scene.model)
    wanted = [reg[n] for n in scene.layers]
    names = list(scene.axes)
    k, length = plan(scene.shape, block_cells)
    with progress.bar(scene.size, desc) as pbar:
        for index in blocks(scene.shape, k, length):
            part = {n: scene.axes[n][s] for n, s in zip(names, index)}
            arrays = scene._evaluate(part, wanted)
            yield index, arrays
            pbar.update(math.prod(a.size for a in part.values()))


def write_scene(scene, path, *, block_cells: int | None = None, complevel: int = 4,
                overwrite: bool = True) -> pathlib.Path:
    """Compute ``scene`` block by block straight into a netCDF atlas at ``path``.

    The file is the one :func:`phasemap.write_atlas` writes for
    ``scene.compute()`` (same variables, attributes and encoding, netCDF
    chunks that tile the blocks), but memory holds one block at a time and no
    dask graph is built.  The atlas appears at ``path`` only when complete:
    an interrupt or an error (a full disk) leaves no partial file, and a
    :class:`WriteError` says what happened in one line.
    """
    import netCDF4

    path = check_output(path, overwrite=overwrite)
    reg = layers_for(scene.model)
    if block_cells is None:
        block_cells = _block_cells(scene, None)
    shape = scene.shape
    k, length = plan(shape, block_cells)
    empty = {n: np.broadcast_to(np.zeros((), dtype=reg[n].dtype), shape) for n in scene.layers}
    ds = _prepare(scene._dataset(empty))
    dims = list(scene.axes)
    encoding = cf_encoding(ds, {d: 1 for d in dims[:k]}, complevel=complevel)
    block_shape = tuple([1] * k + [length] + list(shape[k + 1:]))
    with no_partial_file(path) as tmp:
        nc = netCDF4.Dataset(tmp, "w", format="NETCDF4")
        try:  # a failure or an interrupt: close (quietly) and let atomic_path remove tmp
            for d, n in zip(dims, shape):
                nc.createDimension(d, n)
            for d in dims:
                var = nc.createVariable(d, "f8", (d,), fill_value=False)
                var.setncatts(ds[d].attrs)
                var[:] = ds[d].values
            for name in scene.layers:
                enc = encoding[name]
                itemsize = np.dtype(reg[name].dtype).itemsize
                chunks = _default_chunks(block_shape, itemsize, fixed=set(range(k)))
                fill = enc["_FillValue"]
                var = nc.createVariable(name, reg[name].dtype, tuple(dims), zlib=True,
                                        complevel=enc["complevel"], shuffle=True,
                                        chunksizes=chunks,
                                        fill_value=fill if fill is not None else None)
                var.setncatts(ds[name].attrs)
            nc.setncatts(ds.attrs)
            for index, arrays in compute_blocks(scene, block_cells,
                                                f"{scene.model.name} -> {path.name}"):
                for name, a in arrays.items():
                    nc.variables[name][index] = a
        except BaseException:
            with contextlib.suppress(Exception):
                nc.close()
            raise
        nc.close()  # a full disk may only show here
    return path


def _duration(s: float) -> str:
    if s < 60:
        return f"{s:.2g} s"
    if s < 3600:
        return f"{s / 60:.2g} min"
    if s < 86400 * 2:
        return f"{s / 3600:.2g} h"
    return f"{s / 86400:.3g} days"
