"""Long work: estimate before any work, then compute (and write) in blocks of under a second.

A scene is computed in *blocks*: runs of cells in C order, each split into
hyperslabs of the grid (:func:`slabs`), so that a progress bar moves, Ctrl-C
(or any signal) takes effect between two blocks, and memory stays bounded.
Block sizes adapt as the work goes: the first block is one cell per thread
(a fate map's cell can be a long trajectory), and each next one is sized
from the measured rate to take about :data:`BLOCK_SECONDS`.  This serves
``Scene.compute()`` for fate maps and :func:`write_scene`, which writes each
block into the netCDF file as soon as it is computed (no dask graph is
built, whatever the size), into a temporary file that is renamed onto the
destination only when complete.

Before any work, :func:`estimate` says what a scene will cost: cells, output
size (uncompressed and typical), peak memory and, from a timed sample of the
grid's own cells, time.  :func:`check_memory` refuses, in one line, what
will not fit in memory; :func:`check_output` what cannot be written: an
existing file (without ``overwrite``), a folder that is not writable, a disk
without room for the typical size.  The command line also asks for ``--yes``
above :data:`YES_CELLS` cells or :data:`YES_SECONDS`.
"""

from __future__ import annotations

import contextlib
import math
import os
import pathlib
import sys
import tempfile
import time
from dataclasses import dataclass
from typing import Callable, Iterator, Mapping

import numpy as np

from phasemap.core import progress
from phasemap.atlas.atomic import PART_PREFIX, destination, exists_message, no_partial_file
from phasemap.atlas.write import cf_encoding, default_chunks, prepare
from phasemap.maps.layers import layers_for
from phasemap.core.progress import human_bytes, human_duration
from phasemap.core.resources import available_memory, resident as _resident

#: Above this many cells the command line asks for ``--yes``.
YES_CELLS = 10 ** 9
#: Above this estimated time (s) the command line asks for ``--yes``.
YES_SECONDS = 3600.0
#: Wall time a block should take (s): the progress bar moves and Ctrl-C works
#: between blocks.
BLOCK_SECONDS = 0.25
#: A block grows at most this many times over the previous one.
GROWTH = 4
#: Largest block: maps, and fate maps (a trajectory per cell): bounds the memory of a block.
MAP_BLOCK_CELLS = 1 << 22
FATE_BLOCK_CELLS = 1 << 16
#: First block of a map (a fate map's first block is one cell per thread).
MAP_FIRST_CELLS = 1 << 12
#: Cells per netCDF chunk of a layer written block by block (a run of cells in C order).
CHUNK_CELLS = {"map": 1 << 16, "fate": 1 << 12}
#: Cells in the timed sample, and the time it may take at most (s).
SAMPLE_CELLS = {"map": 1 << 16, "fate": 1 << 10}
SAMPLE_SECONDS = 2.0
MAP_SAMPLE_REPEATS = 3
#: Typical netCDF size over the uncompressed size, by layer dtype (zlib level 4
#: with shuffle on smooth maps: categorical layers are long runs; float layers
#: are NaN wherever a branch is not admissible).  A rough guide: the disk check
#: uses it, and warns when the uncompressed size would not fit.
TYPICAL_RATIO = {"int8": 0.05, "int32": 0.15, "float64": 0.5}
#: Resident memory that loading a scene's compiled kernels adds to a process
#: (numba and LLVM; measured 105-125 MB), counted when the estimate is not timed.
KERNEL_BYTES = 125_000_000
#: Resident memory that the netCDF writer adds (the library, HDF5's chunk caches and
#: its chunk index).  Measured with ``phasemap atlas ladder`` (one int8 layer, kernels
#: loaded): the peak above the rest of the estimate was 31, 57, 71 and 54 MB for 10^8,
#: 10^9, 4 * 10^9 and 2 * 10^10 cells; at 25 MB the 4 * 10^9-cell estimate was 24 % below
#: its peak (issue 44).
WRITER_BYTES = 65_000_000
#: Resident memory that importing xarray (with pandas) adds, counted while it is not
#: imported yet: ``import phasemap`` leaves it to the first Dataset (phasemap.core.lazy).
#: Measured 41 MB (``import phasemap`` 103 MB, then ``import xarray`` 144 MB).
XARRAY_BYTES = 45_000_000
#: Copies of a block that writing it holds at once (the result, HDF5's conversion
#: and compression buffers; 1.45 measured for 4 * 10^6 cells of int8 + float64).
WRITER_COPIES = 2


@dataclass(frozen=True)
class Estimate:
    """What a scene will cost before it runs.

    ``memory`` is the peak resident memory of the process, for the whole
    result in memory (``Scene.compute()``) or for writing block by block
    (``phasemap atlas``), as :func:`estimate` was asked; ``available`` the
    memory the system has free for it now (None where it cannot tell).
    """

    cells: int
    bytes: int           # uncompressed output
    typical_bytes: int   # typical compressed output
    memory: int          # peak resident memory of the process, about
    block_cells: int     # largest block
    seconds: float | None = None  # from a timed sample; None until measured
    resident: int = 0    # resident memory of the process when estimated
    available: int | None = None

    def text(self, scene) -> str:
        """Two lines for a person: size, output, memory and time."""
        dims = " x ".join(f"{a.size} {n}" for n, a in scene.axes.items())
        t = "" if self.seconds is None else f"; time about {human_duration(self.seconds)}"
        return (f"{scene.model.name} atlas: {self.cells:,} cells ({dims}), layers "
                f"{', '.join(scene.layers)}\n  output {human_bytes(self.bytes)} uncompressed, "
                f"about {human_bytes(self.typical_bytes)} typical; memory about "
                f"{human_bytes(self.memory)}{t}")


def estimate(scene, block_cells: int | None = None, timed: bool = False,
             eager: bool = False) -> Estimate:
    """Cells, output size, peak memory and (with ``timed``) time of ``scene``.

    The time comes from computing a strided sample of the scene's own cells
    (:data:`SAMPLE_CELLS`, at most :data:`SAMPLE_SECONDS`) after the kernels
    are compiled, scaled to the whole grid.  The memory is this process's
    resident memory now (plus :data:`KERNEL_BYTES` when not timed: the
    kernels may not be loaded yet; plus :data:`XARRAY_BYTES` while xarray is
    not imported) and what the computation allocates: with
    ``eager`` every layer of the whole grid (``Scene.compute()``), otherwise
    the blocks of :func:`write_scene` (at most ``block_cells`` cells).
    """
    itemsizes = cell_bytes(scene)
    reg = layers_for(scene.model)
    cells = scene.size
    per_cell = sum(itemsizes.values())
    typical = int(sum(cells * s * TYPICAL_RATIO.get(reg[n].dtype, 1.0)
                      for n, s in itemsizes.items()))
    seconds = None
    if timed:
        seconds = seconds_per_cell(scene) * cells
    block = min(cells, block_cells or largest_block(scene))
    scratch = block * _fate_scratch(scene)  # the integrator's arrays of one block
    axes = 8 * sum(a.size for a in scene.axes.values())
    resident = _resident()
    base = (resident + (0 if timed else KERNEL_BYTES)
            + (0 if "xarray" in sys.modules else XARRAY_BYTES))
    if eager:
        memory = base + eager_bytes(scene, block_cells) + axes
    else:
        memory = base + WRITER_BYTES + WRITER_COPIES * block * per_cell + scratch + axes
    return Estimate(cells, cells * per_cell, typical, int(memory), block, seconds, resident,
                    available_memory())


#: ``Scene.compute()`` that allocates less than this is not checked against the memory
#: free: reading /proc costs more than such a map takes to compute, and no machine that
#: has just imported phasemap lacks a MiB.
UNCHECKED_BYTES = 1 << 20


def eager_bytes(scene, block_cells: int | None = None) -> int:
    """What ``scene.compute()`` allocates: every layer of the grid and the integrator's
    arrays of one block (of at most ``block_cells`` cells; default the largest)."""
    per_cell = sum(cell_bytes(scene).values())
    block = min(scene.size, block_cells or largest_block(scene))
    return scene.size * per_cell + block * _fate_scratch(scene)


def cell_bytes(scene) -> dict[str, int]:
    """Bytes a cell of each layer of ``scene`` takes (an orbit layer's section points:
    one value per kept period)."""
    reg = layers_for(scene.model)
    return {n: np.dtype(reg[n].dtype).itemsize * math.prod(scene.layer_shape(n)[len(scene.shape):])
            for n in scene.layers}


def largest_block(scene) -> int:
    """The most cells a block of ``scene`` takes."""
    return FATE_BLOCK_CELLS if scene.slow_cells else MAP_BLOCK_CELLS


def _fate_scratch(scene) -> int:
    """Bytes per cell that the integrator allocates besides the layers (fate, reversals,
    final time, one position per coordinate); of a map in full coordinates, what its
    cells' kernel takes (:func:`phasemap.maps.full.scratch_bytes`)."""
    if scene.full:
        from phasemap.maps.full import scratch_bytes

        return scratch_bytes(scene.model)
    if not scene.has_fates:
        return 0
    return 1 + 4 + 8 + 8 * len(scene.model.dynamics.coordinates)


def check_memory(scene, est: Estimate) -> None:
    """ValueError, in one line, if ``scene.compute()`` will not fit in memory."""
    need = est.memory - est.resident
    if est.available is not None and need > est.available:
        raise ValueError(
            f"{scene.model.name}: {est.cells:,} cells with layers {', '.join(scene.layers)} "
            f"need about {human_bytes(need)} more memory and {human_bytes(est.available)} "
            "is available; compute it in blocks with scene.compute(chunks=...) (dask), or "
            "write it block by block with `phasemap atlas ... -o OUT.nc` "
            "(phasemap.maps.blocks.write_scene)")


def seconds_per_cell(scene) -> float:
    """Seconds per cell of ``scene``, from a strided sample of its cells (compiled first).

    The sample takes up to :data:`SAMPLE_CELLS` cells spread over the grid (cells
    whose section points run many forcing periods run a few, and their time is scaled:
    :func:`phasemap.maps.motions.timed_parts`).  A
    map's sample (milliseconds of work) is timed in one call, the best of
    :data:`MAP_SAMPLE_REPEATS`.  A fate map's, whose cells can be long
    trajectories, goes in a shuffled order in growing blocks and stops after
    :data:`SAMPLE_SECONDS`, so that a slow scene is timed (and interruptible)
    in seconds, not minutes; its time per cell is the slope of a block's time
    against its cells, since a parallel kernel call also costs a fixed time
    (waking the threads, tens of milliseconds on a busy machine) that the
    large blocks of the real work pay rarely.
    """
    if getattr(scene, "orbit", None):    # section points: timed over a few periods
        from phasemap.maps.motions import timed_parts

        parts = timed_parts(scene)
        if parts is not None:
            return sum(seconds_per_cell(part) * factor for part, factor in parts)
    kind = "fate" if scene.slow_cells else "map"
    target = min(SAMPLE_CELLS[kind], scene.size)
    per_axis = max(1, int(round(target ** (1.0 / len(scene.axes)))))
    rng = np.random.default_rng(0)
    sample = {}
    for name, a in scene.axes.items():
        k = min(a.size, per_axis)
        sample[name] = rng.permutation(a[np.unique(np.linspace(0, a.size - 1, k).round()
                                                     .astype(int))])
    with progress.activity(f"{scene.model.name}: compiling or loading the kernels"):
        scene.evaluate({n: a[:1] for n, a in sample.items()})
    n = math.prod(a.size for a in sample.values())
    if not scene.slow_cells:
        with progress.activity(f"{scene.model.name}: timing {n} sample cells"):
            best = math.inf
            for _ in range(MAP_SAMPLE_REPEATS):
                start = time.perf_counter()
                scene.evaluate(sample)
                best = min(best, time.perf_counter() - start)
        return best / n
    cells, seconds = [], []
    with progress.activity(f"{scene.model.name}: timing up to {n} sample cells"):
        start = last = time.perf_counter()
        for index, _ in run_blocks(sample, scene.evaluate, first_block(scene),
                                   largest_block(scene)):
            now = time.perf_counter()
            cells.append(math.prod(s.stop - s.start for s in index))
            seconds.append(now - last)
            last = now
            if now - start > SAMPLE_SECONDS:
                break
    return _slope(np.array(cells, dtype=float), np.array(seconds))


def _slope(cells: np.ndarray, seconds: np.ndarray) -> float:
    """Seconds per cell: the slope of ``seconds = fixed + slope * cells`` (least squares,
    with a fixed time that cannot be negative), or the mean where the blocks cannot
    tell the two apart."""
    mean = float(seconds.sum() / max(cells.sum(), 1.0))
    if np.unique(cells).size < 2:
        return mean
    slope, fixed = np.polyfit(cells, seconds, 1)
    return float(slope) if fixed >= 0 and slope > 0 else mean


# --------------------------------------------------------------------------- checks


def check_output(path, need_bytes: int = 0, typical_bytes: int = 0, *,
                 overwrite: bool = False) -> pathlib.Path:
    """Check before any work that ``path`` can be written; return it as a Path.

    Raises ValueError in one line when the folder is missing or not writable,
    when ``path`` exists and ``overwrite`` is false, or when the typical size
    does not fit on the folder's free disk.  Warns on stderr when the
    uncompressed size would not fit.
    """
    import shutil

    path = destination(path)
    if path.exists() and not overwrite:
        raise ValueError(exists_message(path))
    folder = path.parent
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=PART_PREFIX, suffix=".probe")
    except OSError as err:
        raise ValueError(f"cannot write {path}: {err.strerror or err} ({folder})") from None
    os.close(fd)
    os.unlink(probe)
    free = shutil.disk_usage(folder).free
    if typical_bytes > free:
        raise ValueError(f"cannot write {path}: it needs about {human_bytes(typical_bytes)} "
                         f"(typical; {human_bytes(need_bytes)} uncompressed) and {folder} has "
                         f"{human_bytes(free)} free")
    if need_bytes > free:
        print(f"phasemap: warning: {path} may need up to {human_bytes(need_bytes)} "
              f"uncompressed and {folder} has {human_bytes(free)} free", file=sys.stderr)
    return path


# --------------------------------------------------------------------------- blocks


def plan(shape: tuple[int, ...], block_cells: int) -> tuple[int, int]:
    """``(k, length)``: blocks take one index of each axis before ``k``, ``length``
    values of axis ``k`` (a power of two, or the whole axis) and all of the rest.

    Such a block is a run of cells in C order; :func:`write_scene` uses it as
    the netCDF chunk of every layer.

    >>> plan((100, 50), 1000)    # 16 rows of 50 cells
    (0, 16)
    """
    block_cells = max(1, int(block_cells))
    for k in range(len(shape)):
        rest = math.prod(shape[k + 1:])
        if rest <= block_cells:
            length = block_cells // rest
            if length >= shape[k]:
                return k, shape[k]
            return k, 1 << int(math.log2(length))
    return len(shape) - 1, 1


def slabs(shape: tuple[int, ...], start: int, stop: int) -> Iterator[tuple[slice, ...]]:
    """The hyperslabs that cover cells ``start .. stop - 1`` of ``shape`` in C order
    (at most ``2 * len(shape) - 1`` of them), in order.

    >>> [tuple((s.start, s.stop) for s in sl) for sl in slabs((3, 4), 2, 11)]
    [((0, 1), (2, 4)), ((1, 2), (0, 4)), ((2, 3), (0, 3))]
    """
    if start >= stop:
        return
    if len(shape) == 1:
        yield (slice(start, stop),)
        return
    inner = math.prod(shape[1:])
    i, a = divmod(start, inner)
    j, b = divmod(stop, inner)
    if i == j:
        for s in slabs(shape[1:], a, b):
            yield (slice(i, i + 1),) + s
        return
    if a:
        for s in slabs(shape[1:], a, inner):
            yield (slice(i, i + 1),) + s
        i += 1
    if j > i:
        yield (slice(i, j),) + tuple(slice(0, n) for n in shape[1:])
    if b:
        for s in slabs(shape[1:], 0, b):
            yield (slice(j, j + 1),) + s


def first_block(scene) -> int:
    """Cells of the first block: one per thread for a fate map, else :data:`MAP_FIRST_CELLS`."""
    if scene.slow_cells:
        import numba

        return max(1, numba.get_num_threads())
    return MAP_FIRST_CELLS


def run_blocks(axes: Mapping[str, np.ndarray], evaluate: Callable, first: int, largest: int,
               fixed: int | None = None) -> Iterator[tuple[tuple[slice, ...], dict]]:
    """Yield ``(index, {layer: array})`` over the grid of ``axes``, block by block in C
    order; ``evaluate(sub_axes)`` computes a hyperslab.

    With ``fixed``, every block has that many cells; otherwise the first has
    ``first`` and each next one is sized from the rate measured so far to
    take about :data:`BLOCK_SECONDS`, growing at most :data:`GROWTH` times
    and never above ``largest``.
    """
    names = list(axes)
    shape = tuple(len(a) for a in axes.values())
    total = math.prod(shape)
    size = fixed or max(1, min(first, largest))
    pos = 0
    while pos < total:
        stop = min(total, pos + size)
        start = time.perf_counter()
        for index in slabs(shape, pos, stop):
            part = {n: axes[n][s] for n, s in zip(names, index)}
            yield index, evaluate(part)
        if not fixed:
            rate = (stop - pos) / max(time.perf_counter() - start, 1e-9)
            size = int(max(1, min(largest, GROWTH * size, rate * BLOCK_SECONDS)))
        pos = stop


def compute_blocks(scene, desc: str, block_cells: int | None = None, show: bool | None = None,
                   layers=None) -> Iterator[tuple[tuple[slice, ...], dict]]:
    """Yield ``(index, {layer: array})`` of ``scene`` block by block (:func:`run_blocks`),
    with a progress bar (shown as :func:`phasemap.core.progress.wanted` decides).

    ``block_cells`` fixes the cells of every block; by default they adapt.
    ``layers`` are some of the scene's layers (default all).
    """
    def evaluate(axes):
        return scene.evaluate(axes, layers)

    with progress.enable(progress.wanted(show), force=show is True), \
            progress.bar(scene.size, desc) as pbar:
        for index, arrays in run_blocks(scene.axes, evaluate, first_block(scene),
                                        largest_block(scene), block_cells):
            yield index, arrays
            pbar.update(math.prod(s.stop - s.start for s in index))


def write_scene(scene, path, *, block_cells: int | None = None, complevel: int = 4,
                overwrite: bool = True) -> pathlib.Path:
    """Compute ``scene`` block by block straight into a netCDF atlas at ``path``.

    The file is the one :func:`phasemap.write_atlas` writes for
    ``scene.compute()`` (same variables, attributes and encoding), but memory
    holds one block at a time and no dask graph is built.  The atlas appears
    at ``path`` only when complete: an interrupt, a signal that ends the
    process or an error (a full disk) leaves no partial file, and a
    :class:`phasemap.atlas.atomic.WriteError` says what happened in one line.
    Without ``overwrite``, an existing file is never replaced, even one that
    appears while the atlas is being computed.
    """
    import netCDF4

    path = check_output(path, overwrite=overwrite)
    reg = layers_for(scene.model)
    shape = scene.shape
    k, length = plan(shape, CHUNK_CELLS["fate" if scene.slow_cells else "map"])
    ds = prepare(scene.template())
    dims = list(scene.axes)
    encoding = cf_encoding(ds, {d: 1 for d in dims[:k]}, complevel=complevel)
    chunk_shape = tuple([1] * k + [length] + list(shape[k + 1:]))
    with no_partial_file(path, overwrite=overwrite) as tmp:
        nc = netCDF4.Dataset(tmp, "w", format="NETCDF4")
        try:  # a failure or an interrupt: close (quietly) and let atomic_path remove tmp
            cycle = "cycle" in ds.dims     # the orbit layers' section points
            for d, n in zip(dims + ["cycle"] * cycle, shape + (ds.sizes.get("cycle"),) * cycle):
                nc.createDimension(d, n)
            for d in dims + ["cycle"] * cycle:
                var = nc.createVariable(d, ds[d].dtype.str if d == "cycle" else "f8", (d,),
                                        fill_value=False)
                var.setncatts(ds[d].attrs)
                var[:] = ds[d].values
            for name in scene.layers:
                enc = encoding[name]
                itemsize = np.dtype(reg[name].dtype).itemsize
                extra = scene.layer_shape(name)[len(shape):]
                chunks = default_chunks(chunk_shape + extra, itemsize, fixed=set(range(k)))
                fill = enc["_FillValue"]
                var = nc.createVariable(name, reg[name].dtype, tuple(ds[name].dims), zlib=True,
                                        complevel=enc["complevel"], shuffle=True,
                                        chunksizes=chunks,
                                        fill_value=fill if fill is not None else None)
                var.setncatts(ds[name].attrs)
            nc.setncatts(ds.attrs)
            for index, arrays in compute_blocks(scene, f"{scene.model.name} -> {path.name}",
                                                block_cells):
                for name, a in arrays.items():
                    nc.variables[name][index] = a
        except BaseException:
            with contextlib.suppress(Exception):
                nc.close()
            raise
        nc.close()  # a full disk may only show here
    return path
