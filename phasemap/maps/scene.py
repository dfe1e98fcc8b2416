"""Scenes: one study's choice of system, axes, fixed values and layers.

A :class:`Scene` validates its inputs up front (in Python, never inside numba),
decides which layers it needs, and computes exactly those, eagerly with numpy
arrays or lazily with dask.  The result is a self-describing
:class:`xarray.Dataset`: an atlas.

>>> import numpy as np, phasemap
>>> scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 4),
...                                        "f": [0.1, 0.5, 1.0]}, fixed={"omega": 0.0})
>>> scene.layers
('n_solutions', 'stagnation')
>>> ds = scene.compute()
>>> ds.n_solutions.dims, int(ds.stagnation.sum())   # rest iff phi <= 2 arctan f: 1 + 2 + 4
(('phi', 'f'), 7)
"""

from __future__ import annotations

import json
import math
import numbers
from typing import Mapping, Sequence

import numpy as np
from phasemap.core.lazy import xarray as xr

from phasemap.core import args as _args
from phasemap.core import numerics as nx
from phasemap.core.codegen import content_hash
from phasemap.atlas.dataset import assemble, cf_header, declaration_hash, read_json, variable_attrs
from phasemap.maps.grid import evaluate
from phasemap.motion.integrate import run_fate_map
from phasemap.maps import full, motions, through
from phasemap.maps.full import FullModel, map_model
from phasemap.maps.layers import Outcome, layers_for
from phasemap.core.model import Model
from phasemap.systems import OSCILLATORS, builtin_model
from phasemap.motion.simulate import Options

#: Default relative tolerance of a fate map's trajectories.
FATE_RTOL = 1e-6
#: Cells above which an eager map is computed in blocks (each well under a second, so
#: that Ctrl-C and a progress bar work); a map of fewer cells is one kernel call.
SLAB_CELLS = 1 << 26


class Scene:
    """A grid over some of a model's names, with the others fixed.

    Parameters
    ----------
    model:
        model name or :class:`phasemap.Model`; a friction oscillator's name (``belt``,
        ``den_hartog``...) maps it in full coordinates (:mod:`phasemap.maps.full`: its
        names include the forcing's phase ``t``, its stagnation is riding with the belt).
    axes:
        ``{name: values}`` for 1 or more state or parameter names, each a
        non-empty 1-D sequence of finite values inside the variable's domain,
        strictly increasing or strictly decreasing (uniform or not).  The Dataset's dimensions follow this order.
    fixed:
        values for other names; names neither on an axis nor fixed take the
        model's defaults.
    layers:
        the layer names to compute (see :func:`phasemap.layers_for`).  The
        default is ``n_solutions``, plus ``stagnation`` when the model's
        relative velocity is zero on an axis value or in the fixed values.
        The fate layers (``fate``, ``n_reversals``, ``t_final``, ``t_rest``,
        ``phi_rest``) integrate the motion from every cell, taken as an
        initial state: a fate map, the dry-friction counterpart of basins of
        attraction.
    options:
        integrator settings of the fate layers, as for
        :func:`phasemap.simulate`: ``t_end`` (default 10 s), ``rtol`` (1e-6: enough
        to tell the outcomes apart and place the rest angles to ~1e-6 rad),
        ``atol``, ``max_step``, ``max_steps``, ``max_events``, ``method``
        (``"DOPRI5"`` or ``"DOP853"``).  ``through_contacts=True`` (a declared system)
        follows the cells whose motion ends where a contact changes on through lift-off,
        flight and impacts, as :func:`phasemap.simulate` does, with its ``impact_law``,
        ``restitution``, ``painleve`` and ``zeno_speed`` (:mod:`phasemap.maps.through`:
        those cells run in Python, 10-50 ms each).  A map in full coordinates (a
        friction oscillator) always moves through its contact changes: it takes those
        settings without ``through_contacts``, and its orbit layers (``multiple``,
        ``section_x``...) take ``periods``, ``settle``, ``phase`` and ``section``, as
        :func:`phasemap.orbit_diagram` does (:mod:`phasemap.maps.motions`).

    Examples
    --------
    A fate map of the hinge pendulum over initial angle and velocity:

    >>> import numpy as np, phasemap
    >>> fates = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 7),
    ...                        "omega": [0.0, 2.0]}, layers=["fate", "phi_rest"],
    ...                        options={"t_end": 30.0}).compute()
    >>> fates.fate.attrs["flag_meanings"].split()[0]
    'rest'
    >>> bool((fates.fate == phasemap.Event.REST).all())   # all stop within 30 s
    True

    Raises
    ------
    ValueError
        for an unknown model, variable or layer, a name both on an axis and
        fixed, an empty, multi-dimensional or non-finite axis, or a value
        outside the model's domain.
    """

    def __init__(self, model: str | Model, axes: Mapping[str, Sequence[float]],
                 fixed: Mapping[str, float] | None = None,
                 layers: Sequence[str] | None = None,
                 options: Mapping[str, float] | None = None):
        self.model = map_model(model)
        m = self.model
        for what, given in (("axes", axes), ("fixed", fixed), ("options", options)):
            if given is not None and not isinstance(given, Mapping):
                raise _args.WrongType(f"{m.name}: {what} must be a mapping "
                                              f"{{name: value}}, got {type(given).__name__}")
        if not axes:
            raise ValueError(f"{m.name}: axes is empty: a scene needs at least one axis; "
                             f"choose from {', '.join(m.names)}")
        fixed = dict(fixed or {})
        both = set(axes) & set(fixed)
        if both:
            raise ValueError(f"{m.name}: {sorted(both)[0]!r} is both an axis and fixed")
        self.axes: dict[str, np.ndarray] = {}
        for name, values in axes.items():
            a = _args.reals(f"axis {_args.check_name('variable', name, m.names, m.name)}",
                            values, m.name)
            if a.ndim != 1 or a.size == 0:
                raise ValueError(f"{m.name}: axis {name} must be a non-empty 1-D sequence, "
                                 f"got shape {a.shape}")
            self.axes[name] = a
        fixed = _args.scalars(fixed, m.names, m.name, " as a fixed value (an axis takes arrays)")
        # Validate every value, with the axes broadcast as an open mesh so that
        # cross-variable checks (the wheel's l <= r) see every combination.
        mesh = {n: a.reshape([-1 if i == j else 1 for j in range(len(self.axes))])
                for i, (n, a) in enumerate(self.axes.items())}
        full = m.complete({**fixed, **mesh})
        self.fixed: dict[str, float] = {n: float(v) for n, v in full.items() if n not in self.axes}
        for name, a in self.axes.items():  # CF coordinates: strictly monotonic
            step = np.diff(a)
            if a.size > 1 and not (np.all(step > 0) or np.all(step < 0)):
                what = "repeats a value" if np.any(step == 0) else "goes back and forth"
                raise ValueError(f"{m.name}: axis {name} {what}; an axis must be strictly "
                                 "increasing or strictly decreasing")
        registry = layers_for(m)
        if layers is None:
            layers = ["n_solutions"] + (["stagnation"] if self._velocity_can_be_zero() else [])
        self.layers: tuple[str, ...] = tuple(_args.layers(layers, registry, m.name, (
            f"phasemap.layers_for({m.name!r}) lists its {len(registry)} layers; on the "
            f"command line: phasemap models {m.name}")))
        known = {**Options().as_dict(), **through.DEFAULTS}
        if self.full:
            known.update(motions.ORBIT_OPTIONS)
        for name in options or {}:
            _args.check_name("integrator option", name, known, m.name)
        options = dict(options or {})
        #: the orbit layers' settings (phasemap.maps.motions), None without such a layer
        self.orbit = None
        if self.full:
            options, self.orbit = motions.split(m, options, self.layers, registry)
        options, self.contact = through.split(m, options)
        rtol = FATE_RTOL if self.orbit is None else self.orbit["rtol"]
        self.options = Options(**{"rtol": rtol, **options}).checked(m.name)

    # ------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(a.size for a in self.axes.values())

    @property
    def size(self) -> int:
        return math.prod(a.size for a in self.axes.values())

    @property
    def has_fates(self) -> bool:
        """Whether a layer integrates the motion from each cell (a fate map)."""
        reg = layers_for(self.model)
        return any(reg[n].fate for n in self.layers)

    @property
    def full(self) -> bool:
        """Whether the model has no reduced model: its map surveys the phases in full
        coordinates cell by cell (:mod:`phasemap.maps.full`)."""
        return isinstance(self.model, FullModel)

    @property
    def slow_cells(self) -> bool:
        """Whether a cell costs a motion or a survey (a fate map, or a map in full
        coordinates): such a scene runs in small blocks, with a progress bar."""
        return self.has_fates or self.full

    def _velocity_can_be_zero(self) -> bool:
        if self.full:   # a surface's velocity may be anything: the stick state too
            return True
        name = self.model.velocity
        values = self.axes.get(name)
        if values is None:
            return self.fixed[name] == 0.0
        return bool(np.any(np.abs(values) <= nx.TOL * max(1.0, float(np.max(np.abs(values))))))

    def spec(self) -> dict:
        """A JSON-ready description, enough to recompute the atlas (see :meth:`from_spec`)."""
        axes = {}
        for name, a in self.axes.items():
            if a.size > 1 and np.array_equal(a, np.linspace(a[0], a[-1], a.size)):
                axes[name] = {"start": a[0], "stop": a[-1], "count": int(a.size)}
            else:
                axes[name] = a.tolist()
        spec = {"model": self.model.name, "axes": axes, "fixed": self.fixed,
                "layers": list(self.layers)}
        declared = declaration_hash(self.model)
        if declared is not None:
            spec["declaration_sha256"] = declared
        if self.has_fates:
            spec["options"] = {**self.options.as_dict(), **through.as_options(self.contact)}
            if self.orbit is not None:
                spec["options"].update({k: self.orbit[k] for k in motions.ORBIT_OPTIONS})
        return spec

    @classmethod
    def from_spec(cls, spec: Mapping | str, model: str | Model | None = None) -> "Scene":
        """The scene a :meth:`spec` describes (an atlas's ``phasemap_scene``, as JSON
        text or parsed).

        A spec is data, checked before anything it names is made: unknown
        keys, wrong types, more than :data:`MAX_SPEC_CELLS` cells or
        :data:`MAX_SPEC_VALUES` values on an axis are refused in one ValueError.
        Its model name resolves to a built-in model only; nothing the spec
        names is run.  To recompute the atlas of a system declared in a file,
        pass the declaration, ``model="my_rod.py"`` (or its Model): it must
        declare the system the spec records (``declaration_sha256``, the hash
        of the declaration's canonical form), else ValueError saying what differs.

        >>> import numpy as np, phasemap
        >>> scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 4)},
        ...                        fixed={"f": 0.5, "omega": 0.0})
        >>> phasemap.Scene.from_spec(scene.spec()).spec() == scene.spec()
        True
        >>> phasemap.Scene.from_spec({**scene.spec(), "model": "evil.py"})
        Traceback (most recent call last):
        ...
        ValueError: Scene.from_spec: the spec's model 'evil.py' is not a built-in model; pass the declaration it was made with explicitly, Scene.from_spec(spec, model='path/to/system.py')
        """
        name, axes, fixed, layers, options, recorded = _read_spec(spec)
        if model is None:
            try:
                m = map_model(name) if name in OSCILLATORS else builtin_model(name)
            except ValueError:
                raise ValueError(f"Scene.from_spec: the spec's model {name!r} is not a built-in "
                                 "model; pass the declaration it was made with explicitly, "
                                 "Scene.from_spec(spec, model='path/to/system.py')") from None
        else:
            m = map_model(model)
            if m.name != name:
                raise ValueError(f"Scene.from_spec: the spec is of {name!r}, the model given "
                                 f"is {m.name!r}")
            if recorded is None and m.declaration is not None:
                raise ValueError(f"Scene.from_spec: the spec records no declaration hash, so "
                                 f"it cannot be checked against the declaration of {name!r}")
        if recorded is not None and recorded != declaration_hash(m):
            raise ValueError(
                f"Scene.from_spec: {name!r} is declared otherwise than when the atlas was "
                f"made (declaration sha256 {recorded[:12]}... recorded, "
                f"{str(declaration_hash(m))[:12]}... given)"
                + _what_differs({*axes, *fixed}, m))
        arrays = {n: (np.linspace(a["start"], a["stop"], int(a["count"]))
                      if isinstance(a, Mapping) else np.asarray(a, dtype=float))
                  for n, a in axes.items()}
        return cls(m, axes=arrays, fixed=fixed, layers=layers, options=options)

    def __repr__(self) -> str:
        axes = ", ".join(f"{n}[{a.size}]" for n, a in self.axes.items())
        return f"Scene({self.model.name!r}, axes=({axes}), layers={list(self.layers)})"

    # ------------------------------------------------------------------
    def estimate(self, timed: bool = True):
        """What :meth:`compute` will cost, before any work: a
        :class:`phasemap.maps.blocks.Estimate` with ``cells``, ``bytes`` (uncompressed
        output), ``memory`` (peak resident memory of this process with the whole
        result in memory), ``available`` (memory free now) and, with ``timed``,
        ``seconds`` from a timed sample of the scene's own cells (which compiles
        the kernels first).  ``text(scene)`` says it as the command line does.

        >>> import numpy as np, phasemap
        >>> scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 1000),
        ...                                        "f": np.linspace(0, 3, 1000)})
        >>> est = scene.estimate(timed=False)
        >>> est.cells, est.bytes      # two int8 layers
        (1000000, 2000000)
        """
        from phasemap.maps import blocks

        return blocks.estimate(self, timed=timed, eager=True)

    def compute(self, chunks: int | Mapping[str, int] | None = None,
                progress: bool | None = None) -> xr.Dataset:
        """Evaluate the scene's layers and return the atlas.

        With ``chunks`` (cells per axis, as an int for every axis or a mapping,
        or ``"auto"`` for dask's choice) the Dataset is dask-backed and each
        block runs the same numba kernel when computed, locally or on a ``dask.distributed`` cluster.  Without,
        it is computed now: a map in one kernel call (in blocks above
        :data:`SLAB_CELLS` cells), a fate map in blocks of well under a second
        (Ctrl-C interrupts it between two), with a progress
        bar after a second in an interactive session (``progress=True`` or
        ``False`` decides; ``PHASEMAP_PROGRESS`` overrides).

        Raises
        ------
        ValueError
            before any work, if the result will not fit in memory
            (:meth:`estimate`): compute it with ``chunks=`` or write it block by
            block (``phasemap atlas``, :func:`phasemap.maps.blocks.write_scene`).
        """
        if chunks is not None:
            return self._lazy(chunks)
        from phasemap.maps import blocks

        if blocks.eager_bytes(self) > blocks.UNCHECKED_BYTES:
            blocks.check_memory(self, blocks.estimate(self, eager=True))
        return self._dataset(self._eager(progress))

    def _eager(self, show: bool | None) -> dict[str, np.ndarray]:
        """Every layer in memory: the map layers in one kernel call (up to
        :data:`SLAB_CELLS`), the fate layers block by block (a progress bar as
        ``show`` decides)."""
        from phasemap.maps.blocks import compute_blocks

        reg = layers_for(self.model)
        maps = [n for n in self.layers if not reg[n].fate]
        out = {}
        if maps and self.size <= SLAB_CELLS and not self.full:
            out = self.evaluate(self.axes, maps)
            maps = []
        blocked = maps + [n for n in self.layers if reg[n].fate]
        if blocked:
            arrays = {n: np.empty(self.layer_shape(n), dtype=reg[n].dtype) for n in blocked}
            for index, block in compute_blocks(self, f"{self.model.name} atlas", show=show,
                                               layers=blocked):
                for name, a in block.items():
                    arrays[name][index] = a
            out.update(arrays)
        return {n: out[n] for n in self.layers}

    def evaluate(self, axes: Mapping[str, np.ndarray] | None = None,
                 layers: Sequence[str] | None = None) -> dict[str, np.ndarray]:
        """Layers over a sub-grid, as NumPy arrays: what one block of a large atlas computes.

        ``axes`` gives values of every axis (a part of the scene's, in any
        order; default the whole axes), ``layers`` some of the scene's layers
        (default all).  Map layers come from the grid kernel, fate layers from
        integrating from each cell; no validation beyond the scene's own.
        """
        axes = self.axes if axes is None else axes
        reg = layers_for(self.model)
        wanted = [reg[n] for n in (self.layers if layers is None else layers)]
        result = {}
        maps = [l for l in wanted if not l.fate]
        if maps and self.full:
            result.update(full.evaluate(self.model, dict(axes), self.fixed, maps))
        elif maps:
            result.update(evaluate(self.model, dict(axes), self.fixed, maps))
        fates = [l for l in wanted if l.fate]
        if fates and self.full:
            result.update(motions.evaluate(self, dict(axes), fates))
        elif fates:
            m, o = self.model, self.options
            # positions that are not model inputs (the slider's x) start at 0
            y0 = np.zeros(2 * len(m.dynamics.coordinates))
            outcome = Outcome(*run_fate_map(
                m, dict(axes), self.fixed, y0, o.t_end, o.rtol, o.atol, o.max_step,
                o.max_steps, o.max_events, o.method))
            if self.contact is not None:   # the cells that end at a contact change go on
                outcome = through.go_on(self, dict(axes), outcome)
            result.update({l.name: l.outcome(outcome) for l in fates})
        return result

    def template(self) -> xr.Dataset:
        """The atlas's Dataset with every layer zero (broadcast, no memory), for a writer
        that fills it block by block: coordinates, attributes, provenance."""
        reg = layers_for(self.model)
        return self._dataset({n: np.broadcast_to(np.zeros((), dtype=reg[n].dtype),
                                                 self.layer_shape(n))
                              for n in self.layers})

    def layer_shape(self, name: str) -> tuple[int, ...]:
        """The shape of the layer ``name``: the scene's, and the ``cycle`` dimension's
        length after it for an orbit layer's section points."""
        if layers_for(self.model)[name].cycle:
            return self.shape + (motions.cycles(self),)
        return self.shape

    def _lazy(self, chunks) -> xr.Dataset:
        """Dask-backed layers: one blockwise task per block computes every layer once.

        The graph is a few blockwise layers, never materialised block by block,
        so it builds at once whatever the number of blocks.  Task names hash
        everything that decides the values (the model's content, the scene,
        the options and the chunks), so two scenes share a name only if they
        share every value.
        """
        import dask.array as da
        from dask.base import tokenize

        sizes = _args.chunks(chunks, dict(zip(self.axes, self.shape)), self.model.name)
        sizes = sizes if sizes == "auto" else tuple(sizes.values())
        reg = layers_for(self.model)
        ndim = len(self.axes)
        limit = None
        if sizes == "auto" and motions.cycles(self) > 1:   # a cell holds its section points
            from dask.utils import parse_bytes

            import dask

            limit = max(8, parse_bytes(dask.config.get("array.chunk-size"))
                        // motions.cycles(self))
        normal = da.core.normalize_chunks(sizes, self.shape, dtype=np.float64, limit=limit)
        token = tokenize(declaration_hash(self.model) if self.full else
                         content_hash(self.model), json.dumps(self.spec(), default=str),
                         self.options.as_dict(), [a.tobytes() for a in self.axes.values()],
                         normal)
        token = f"phasemap-{self.model.name}-{token}"
        raw = da.map_blocks(_raw_block, chunks=normal, dtype=object,
                            meta=np.empty((0,) * ndim, dtype=object), name=f"{token}-blocks",
                            scene=self)
        arrays = {}
        for n in self.layers:
            # the section points: one more axis, whole in each block
            extra = ({"chunks": normal + ((motions.cycles(self),),), "new_axis": ndim}
                     if reg[n].cycle else {})
            arrays[n] = raw.map_blocks(_pick, n, dtype=reg[n].dtype, name=f"{token}-{n}",
                                       meta=np.empty((0,) * (ndim + bool(extra)),
                                                     dtype=reg[n].dtype), **extra)
        return self._dataset(arrays)

    def _dataset(self, arrays: Mapping[str, object]) -> xr.Dataset:
        m, reg = self.model, layers_for(self.model)
        dims = tuple(self.axes)
        coords = {}
        for name, a in self.axes.items():
            var = m.variables[name]
            coords[name] = xr.Variable(name, a, variable_attrs(var), fastpath=True)
        # fastpath: the arrays are ours, so xarray need not ask whether they are dask
        # arrays (which imports dask.array, seconds in a fresh process)
        data_vars = {n: xr.Variable(dims + (("cycle",) if reg[n].cycle else ()), arrays[n],
                                    reg[n].attrs, fastpath=True)
                     for n in self.layers}
        if self.orbit is not None and any(reg[n].cycle for n in self.layers):
            each = ("forcing periods" if self.orbit["section"] is None
                    else f"maxima of {self.orbit['section']}")
            coords["cycle"] = xr.Variable("cycle", np.arange(1, self.orbit["periods"] + 1,
                                                             dtype=np.int32),
                                          {"long_name": f"{each} after the settling ones",
                                           "units": "1"}, fastpath=True)
        attrs = {**cf_header(m), "phasemap_scene": json.dumps(self.spec())}
        for name, value in self.fixed.items():
            attrs[f"phasemap_fixed_{name}"] = value
        return assemble(data_vars, coords, attrs)


#: The most cells a spec read from a file may describe (:meth:`Scene.from_spec`) ...
MAX_SPEC_CELLS = 10 ** 10
#: ... and the most values on one of its axes.
MAX_SPEC_VALUES = 10 ** 7
_SPEC_KEYS = {"model", "axes", "fixed", "layers", "options", "declaration_sha256"}


def _number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _read_spec(spec):
    """The parts of a scene spec (data from a file), each checked for its type and size
    before anything is made from it; ValueError in one line otherwise."""
    def bad(what):
        raise ValueError(f"Scene.from_spec: {what}")

    if isinstance(spec, str):
        spec = read_json(spec, "Scene.from_spec: the spec")
    if spec is None:
        bad("no spec (an atlas written by phasemap records it in its phasemap_scene "
            "attribute, which this one lacks)")
    if not isinstance(spec, Mapping):
        bad(f"a spec is a mapping, got {type(spec).__name__}")
    unknown = set(spec) - _SPEC_KEYS
    if unknown:
        bad(f"unknown key {str(sorted(map(str, unknown))[0])[:40]!r}; a spec has "
            f"{', '.join(sorted(_SPEC_KEYS))}")
    for key in ("model", "axes"):
        if key not in spec:
            bad(f"the spec has no {key!r}")
    name, axes = spec["model"], spec["axes"]
    fixed, layers, options = spec.get("fixed") or {}, spec.get("layers"), spec.get("options")
    recorded = spec.get("declaration_sha256")
    if not isinstance(name, str):
        bad(f"model must be a name, got {type(name).__name__}")
    if recorded is not None and not isinstance(recorded, str):
        bad(f"declaration_sha256 must be text, got {type(recorded).__name__}")
    if not isinstance(axes, Mapping) or not axes:
        bad("axes must be a non-empty mapping of names to values")
    cells = 1
    for axis, a in axes.items():
        if not isinstance(axis, str):
            bad(f"axis names must be text, got {type(axis).__name__}")
        if isinstance(a, Mapping):
            if set(a) != {"start", "stop", "count"}:
                bad(f"axis {axis[:40]!r} must be a list of numbers or "
                    "{start, stop, count}")
            if not (_number(a["start"]) and _number(a["stop"])):
                bad(f"axis {axis[:40]!r}: start and stop must be numbers")
            count = a["count"]
            if not isinstance(count, numbers.Integral) or isinstance(count, (bool, np.bool_)) \
                    or count < 1:
                bad(f"axis {axis[:40]!r}: count must be a positive integer")
        elif isinstance(a, (list, tuple)) and all(_number(v) for v in a):
            count = len(a)
        else:
            bad(f"axis {axis[:40]!r} must be a list of numbers or {{start, stop, count}}")
        if count > MAX_SPEC_VALUES:
            bad(f"axis {axis[:40]!r} has {count:,} values, more than {MAX_SPEC_VALUES:,}")
        cells *= max(count, 1)
        if cells > MAX_SPEC_CELLS:
            bad(f"the axes describe more than {MAX_SPEC_CELLS:,} cells")
    if not isinstance(fixed, Mapping) or not all(isinstance(k, str) and _number(v)
                                                 for k, v in fixed.items()):
        bad("fixed must map names to numbers")
    if layers is not None and not (isinstance(layers, (list, tuple))
                                   and all(isinstance(n, str) for n in layers)):
        bad("layers must be a list of names")
    if options is not None and not (
            isinstance(options, Mapping)
            and all(isinstance(k, str) and (_number(v) or isinstance(v, (str, bool))
                                            or v is None) for k, v in options.items())):
        bad("options must map names to numbers, text or true/false")
    return name, dict(axes), dict(fixed), layers, options, recorded


def _what_differs(named: set, model: Model) -> str:
    """What a declaration and a spec naming the variables ``named`` disagree on, as far as
    the spec tells."""
    only = sorted(named - set(model.variables))
    if only:
        return f"; the atlas has {', '.join(only)}, which the given declaration does not"
    return ("; the names agree, so the bodies, forces, contacts, bounds, units or texts "
            "differ")


def _raw_block(scene: Scene, block_info=None) -> dict[str, np.ndarray]:
    """Every layer of one dask block: the scene restricted to the block's cells."""
    where = block_info[None]["array-location"]
    return scene.evaluate({n: a[lo:hi] for (n, a), (lo, hi) in zip(scene.axes.items(), where)})


def _pick(block: dict, name: str) -> np.ndarray:
    return block[name]
