r"""What every phasemap Dataset shares: its CF header, its kind, and the words of its figures.

Three producers make Datasets: :class:`phasemap.Scene` (atlases and fate
maps), :func:`phasemap.simulate` (trajectories) and
:func:`phasemap.phase_curve` (phase curves).  Each starts its global
attributes with :func:`cf_header`, so that the ``Conventions``, the
provenance and the model's description are written in one place; the writer
(:mod:`phasemap.atlas.write`, :mod:`phasemap.atlas.read`), the accessor and the figures decide what a Dataset
is with :func:`dataset_kind`, here, and without matplotlib.

The model's description (``phasemap_variables``, JSON) carries the symbol,
UDUNITS units and long name of every variable, acceleration, reaction and the
coefficient, with the branch names, so that a figure of a declared system
reads ``$\theta$ (rad)`` and ``$\omega$ = 0 rad s$^{-1}$`` from the file
alone, with no code loaded (:func:`vocabulary`).

>>> import phasemap
>>> from phasemap.atlas.dataset import cf_header, squared_units, vocabulary
>>> head = cf_header(phasemap.get_model("ladder"), "trajectory", "phasemap.simulate")
>>> head["Conventions"], head["phasemap_kind"], head["phasemap_model"]
('CF-1.8', 'trajectory', 'ladder')
>>> vocabulary(head).variables["phi"]
('\\varphi', 'rad', 'angle of the bar from the vertical')
>>> squared_units("rad s-1")
'rad2 s-2'
"""

from __future__ import annotations

import datetime as _dt
import json
import re
import time as _time
from dataclasses import dataclass, field
from typing import Mapping

from phasemap.core.lazy import xarray as xr

from phasemap.core.memo import Memo
from phasemap._version import __version__

__all__ = [
    "CONVENTIONS",
    "KINDS",
    "MOTIONS",
    "Vocabulary",
    "assemble",
    "cf_header",
    "created",
    "dataset_kind",
    "declaration_hash",
    "recorded_model",
    "first_layer",
    "is_categorical",
    "motion_kind",
    "squared_units",
    "variable_attrs",
    "vocabulary",
]

#: The CF version every Dataset declares: cfchecker 4.1.0, the newest on PyPI and the
#: independent checker the tests use, knows CF versions up to 1.8 and reports an
#: error for any later version string; nothing introduced after CF-1.8 is used.
CONVENTIONS = "CF-1.8"

#: What a Dataset can be, as ``ds.phasemap.kind`` names it.
KINDS = ("map", "profile", "fate", "phase_curve", "trajectory", "boundaries", "threshold",
         "periodic_orbit", "orbit_branch", "orbit_diagram")
#: The kinds that follow one motion (global attribute ``phasemap_kind``).
MOTIONS = ("phase_curve", "trajectory")
#: The kinds of the bifurcation set: pieces of curves on a dimension ``vertex``, special
#: points on ``point`` (:func:`phasemap.boundaries`, ``threshold(..., along=)``).
CURVES = ("boundaries", "threshold")

#: The title of each producer's Dataset, by kind (``phasemap_kind``; ``atlas`` for a Scene's).
_TITLES = {"atlas": "atlas", "trajectory": "trajectory", "phase_curve": "phase curve",
           "boundaries": "boundaries", "threshold": "threshold curve",
           "periodic_orbit": "periodic orbit", "orbit_branch": "orbit branch",
           "orbit_diagram": "orbit diagram"}


#: (whole seconds since the epoch, their ISO 8601 time stamp): the last one made
_STAMP = [None, ""]


def created() -> str:
    """The time stamp a Dataset made now records as ``date_created`` (UTC, ISO 8601)."""
    return _now()


def _now() -> str:
    """The time stamp of now (UTC, whole seconds), formatted once per second."""
    second = int(_time.time())
    if _STAMP[0] != second:
        _STAMP[0] = second
        _STAMP[1] = _dt.datetime.fromtimestamp(second, _dt.timezone.utc).strftime(
            "%Y-%m-%dT%H:%M:%SZ")
    return _STAMP[1]


def cf_header(model, kind: str = "atlas", producer: str = "phasemap") -> dict:
    """The global attributes every Dataset made from ``model`` starts with.

    ``Conventions``, ``title`` (``"phasemap <kind>: <model title>"``),
    ``source``, ``history`` (``"<time> created by <producer> <version>"``),
    ``references`` (the model's citation), ``phasemap_kind`` (a motion only:
    ``"trajectory"`` or ``"phase_curve"``), ``phasemap_model``,
    ``phasemap_version``, ``date_created`` and ``phasemap_variables`` (the
    model's description, see :func:`vocabulary`), and for a declared model
    ``phasemap_declaration_sha256`` (:func:`declaration_hash`).  The producer
    adds what is its own (the scene, the fixed values, the end of a motion).
    """
    now = _now()
    if kind not in _TITLES:
        raise ValueError(f"kind must be one of {', '.join(_TITLES)}, got {kind!r}")
    attrs = dict(_HEADERS.get((model,), (kind, producer),
                              lambda: _header(model, kind, producer, now)))
    if attrs["date_created"] != now:
        attrs["history"] = f"{now} created by {producer} {__version__}"
        attrs["date_created"] = now
    return attrs


#: (model, kind, producer) -> its header as first made: the model's description in JSON
#: is made once (a tenth of a short motion's wrapper otherwise)
_HEADERS = Memo("dataset.headers")


def _header(model, kind: str, producer: str, now: str) -> dict:
    attrs = {
        "Conventions": CONVENTIONS,
        "title": f"phasemap {_TITLES[kind]}: {model.title}",
        "source": f"phasemap {__version__}",
        "history": f"{now} created by {producer} {__version__}",
        "references": model.citation,
    }
    if kind != "atlas":
        attrs["phasemap_kind"] = kind
    attrs |= {
        "phasemap_model": model.name,
        "phasemap_version": __version__,
        "date_created": now,
        "phasemap_variables": json.dumps(_describe(model), ensure_ascii=False),
    }
    declared = declaration_hash(model)
    if declared is not None:
        attrs["phasemap_declaration_sha256"] = declared
    return attrs


#: model -> its declaration's hash
_DECLARATION_HASHES = Memo("dataset.declaration_hashes")


def declaration_hash(model) -> str | None:
    """SHA-256 (hex) of a declared model's declaration in its canonical form (what the
    build step keys the kernel cache with), None for a model derived by hand.

    An atlas records it (``phasemap_declaration_sha256``), so that it is recomputed
    only from the very declaration it was made with (:meth:`phasemap.Scene.from_spec`).
    """
    declaration = getattr(model, "declaration", None)
    if declaration is None:
        return None
    def digest():
        # a model loaded from the kernel cache carries its hash (no sympy needed)
        known = getattr(declaration, "sha256", None)
        if known is not None:
            return known
        from phasemap.declare.build import declaration_sha256

        return declaration_sha256(declaration)

    return _DECLARATION_HASHES.get((model,), (), digest)


def assemble(data_vars: dict, coords: dict, attrs: dict) -> xr.Dataset:
    """The Dataset of ``data_vars`` over the dimension coordinates ``coords``.

    What ``xr.Dataset(data_vars, coords, attrs)`` builds (the tests check it),
    built directly: the variables are already aligned on the coordinates, so
    xarray's merge and alignment (a few tenths of a millisecond, more than
    the kernel of a small map or a short motion) have nothing to do.  No array is copied.
    """
    import pandas as pd  # loaded with xarray

    # a named pandas Index of the coordinate's own array: what PandasIndex would make of
    # the Variable (its safe cast and the copy it takes of an unnamed index skipped)
    indexes = {name: xr.indexes.PandasIndex(pd.Index(var.values, name=name, copy=False),
                                            name, coord_dtype=var.dtype, fastpath=True)
               for name, var in coords.items()}
    variables = {}
    for name, var in coords.items():
        variables.update(indexes[name].create_variables({name: var}))
    variables.update(data_vars)
    return xr.Dataset._construct_direct(variables, set(coords), attrs=attrs, indexes=indexes)


def variable_attrs(var) -> dict:
    """The attributes of a coordinate or variable that is a model :class:`~phasemap.Variable`:
    ``units``, ``long_name`` and ``phasemap_symbol`` (its mathtext symbol, without ``$``)."""
    return {"units": var.units, "long_name": var.long_name,
            "phasemap_symbol": var.symbol or var.name}


def squared_units(units: str | None) -> str | None:
    """UDUNITS spelling of the square of ``units``: ``"rad s-1"`` -> ``"rad2 s-2"``.

    None, ``""`` and ``"1"`` are returned as they are; a spelling that is not a
    product of powers is wrapped, ``"(units)2"``.
    """
    if units is None or str(units).strip() in ("", "1"):
        return units
    out = []
    for token in str(units).split():
        m = re.fullmatch(r"([A-Za-z]+)(-?\d+)?", token)
        if not m:
            return f"({units})2"
        out.append(f"{m.group(1)}{2 * int(m.group(2) or 1)}")
    return " ".join(out)


# --------------------------------------------------------------------------- the model's words


def _entry(var) -> list[str]:
    return [var.symbol or var.name, var.units, var.long_name]


def _describe(model) -> dict:
    coef = model.coefficient
    return {
        "variables": {v.name: _entry(v) for v in model.variables.values()},
        "accelerations": {v.name: _entry(v) for v in model.accelerations},
        "reactions": {v.name: _entry(v) for v in model.reactions},
        "coefficient": ([coef.name, coef.symbol, coef.units, coef.long_name]
                        if coef is not None else None),
        "branches": list(model.branches),
        "edges": {name: list(meanings) for name, meanings in
                  (model.dynamics.edges if model.dynamics is not None else {}).items()},
    }


@dataclass(frozen=True)
class Vocabulary:
    """The symbols, units and long names a figure of one model uses.

    ``variables``, ``accelerations`` and ``reactions`` map a name to
    ``(symbol, units, long_name)``, ``coefficient`` is ``(name, symbol,
    units, long_name)`` or None, ``branches`` the branch names in order,
    ``edges`` maps a coordinate to what reaching its lower and upper bound
    means.  Empty when nothing is known.
    """

    variables: Mapping[str, tuple] = field(default_factory=dict)
    accelerations: Mapping[str, tuple] = field(default_factory=dict)
    reactions: Mapping[str, tuple] = field(default_factory=dict)
    coefficient: tuple | None = None
    branches: tuple[str, ...] = ()
    edges: Mapping[str, tuple] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.variables)


def _strings(value, n: int, where: str) -> tuple:
    """``value`` as a tuple of ``n`` strings (None allowed), or ValueError naming ``where``."""
    if (not isinstance(value, (list, tuple)) or len(value) != n
            or not all(v is None or isinstance(v, str) for v in value)):
        raise ValueError(f"phasemap_variables: {where} must be a list of {n} strings, "
                         f"got {str(value)[:60]}")
    return tuple(value)


def _from_description(d) -> Vocabulary:
    """The :class:`Vocabulary` of a description (JSON data from a file: every part is
    checked; ValueError in one line for anything malformed)."""
    if not isinstance(d, dict):
        raise ValueError("phasemap_variables: must be a JSON object")

    def table(key, n=3):
        items = d.get(key) or {}
        if not isinstance(items, dict):
            raise ValueError(f"phasemap_variables: {key} must be an object")
        return {str(k): _strings(v, n, f"{key}.{k}") for k, v in items.items()}

    coef = d.get("coefficient")
    branches = d.get("branches") or []
    if not isinstance(branches, list) or not all(isinstance(b, str) for b in branches):
        raise ValueError("phasemap_variables: branches must be a list of strings")
    return Vocabulary(table("variables"), table("accelerations"), table("reactions"),
                      _strings(coef, 4, "coefficient") if coef else None, tuple(branches),
                      table("edges", 2))


def read_json(text: str, what: str):
    """JSON text from a file's attribute, as data: ValueError in one line naming ``what``
    when it is not JSON, including a nesting too deep for Python's decoder (which raises
    RecursionError) and text too large to decode."""
    try:
        return json.loads(text)
    except ValueError as e:
        raise ValueError(f"{what}: not JSON ({e})") from None
    except (RecursionError, MemoryError):
        raise ValueError(f"{what}: JSON nested too deeply or too large to read") from None


def vocabulary(ds: xr.Dataset | Mapping) -> Vocabulary:
    """What the Dataset ``ds`` (or its global attributes) says about its model's words.

    Read from the global attribute ``phasemap_variables`` that :func:`cf_header`
    writes, as data: ValueError in one line if it is malformed.  A Dataset
    made before it existed falls back to the built-in model named by
    ``phasemap_model`` (never a file: nothing a file names is loaded); an
    empty :class:`Vocabulary` when neither is there.
    """
    attrs = ds.attrs if isinstance(ds, xr.Dataset) else ds
    text = attrs.get("phasemap_variables")
    if text is not None:
        if not isinstance(text, str):
            raise ValueError("phasemap_variables: must be JSON text")
        description = read_json(text, "phasemap_variables")
        return _from_description(description)
    try:
        model = recorded_model(attrs)
    except ValueError:
        return Vocabulary()
    return _from_description(_describe(model))


def recorded_model(ds: xr.Dataset | Mapping):
    """The built-in model a Dataset (or its global attributes) was made with.

    ``phasemap_model`` is looked up among the built-in models only: a name
    read from a file is data, and no file it names is ever run.  A declared
    model must also have the declaration the Dataset records
    (``phasemap_declaration_sha256``).  ValueError in one line otherwise.
    """
    from phasemap.systems import builtin_model

    attrs = ds.attrs if isinstance(ds, xr.Dataset) else ds
    name = attrs.get("phasemap_model")
    if name is None:
        raise ValueError("not a phasemap atlas: no phasemap_model global attribute")
    try:
        model = builtin_model(name)
    except ValueError as e:
        raise ValueError(f"the file's model: {e}; load a declaration yourself with "
                         "phasemap.get_model('path/to/system.py')") from None
    recorded = attrs.get("phasemap_declaration_sha256")
    if recorded is not None and recorded != declaration_hash(model):
        raise ValueError(f"the file's model {name!r} was declared otherwise than the built-in "
                         f"{name!r} (declaration sha256 {str(recorded)[:12]}..., built-in "
                         f"{str(declaration_hash(model))[:12]}...)")
    return model


# --------------------------------------------------------------------------- kinds


def is_categorical(var: xr.DataArray) -> bool:
    """Whether ``var`` is a categorical layer (it has ``flag_values`` and ``flag_meanings``)."""
    return "flag_values" in var.attrs and "flag_meanings" in var.attrs


def first_layer(ds: xr.Dataset) -> xr.DataArray:
    """The first categorical layer of ``ds``, else its first layer; a layer on the
    scene's cells before section points on one more dimension (``cycle``)."""
    layers = list(ds.data_vars.values())
    cells = [v for v in layers if "cycle" not in v.dims] or layers
    for var in cells:
        if is_categorical(var):
            return var
    return cells[0]


def curve_kind(ds: xr.Dataset) -> str | None:
    """``"boundaries"`` or ``"threshold"`` for a Dataset of the bifurcation set, else None."""
    kind = ds.attrs.get("phasemap_kind")
    return kind if isinstance(kind, str) and kind in CURVES else None


def curve_axes(ds: xr.Dataset) -> tuple[str, str]:
    """The (x, y) variables of a bifurcation-set Dataset: the slice's two axes for
    boundaries, the followed parameter and the threshold's for a threshold curve.
    ValueError in one line if the file does not say them."""
    kind = curve_kind(ds)
    attr = "phasemap_axes" if kind == "boundaries" else "phasemap_along"
    text = ds.attrs.get(attr)
    if not isinstance(text, str):
        raise ValueError(f"{attr}: a {kind} file names its axes there, as JSON text")
    names = read_json(text, attr)
    if not isinstance(names, dict) or not all(isinstance(n, str) for n in names):
        raise ValueError(f"{attr}: must map axis names to ranges")
    names = list(names)
    if kind == "threshold":
        param = ds.attrs.get("phasemap_param")
        names = names[:1] + ([param] if isinstance(param, str) else [])
    if len(names) != 2 or any(n not in ds.variables or ds[n].dims != ("vertex",)
                              for n in names):
        raise ValueError(f"a {kind} file needs its two axes as variables on 'vertex', "
                         f"got {names!r}")
    return names[0], names[1]


def motion_kind(ds: xr.Dataset) -> str | None:
    """``"trajectory"`` or ``"phase_curve"`` for a Dataset that follows one motion, else None."""
    kind = ds.attrs.get("phasemap_kind")
    return kind if isinstance(kind, str) and kind in MOTIONS else None


def dataset_kind(ds: xr.Dataset) -> str:
    """Which of :data:`KINDS` the Dataset ``ds`` is, and so which figure suits it.

    The global attribute ``phasemap_kind`` decides first (``"atlas"`` there
    means: decide from the dimensions); then section points on a ``cycle``
    dimension over one axis make an orbit diagram; then a ``fate`` layer makes a fate
    map; otherwise the dimensions of the first categorical layer (or of the
    first layer, if none is categorical) make a ``profile`` (1-D) or a
    ``map`` (2-D).

    Raises
    ------
    ValueError
        if ``ds`` is not a Dataset, carries neither ``phasemap_kind`` nor
        ``phasemap_model``, has no layers, names an unknown kind, or is an
        atlas of 3 or more dimensions (select a 2-D slice first).
    """
    if not isinstance(ds, xr.Dataset):
        raise ValueError(f"not a phasemap atlas: ds must be an xarray.Dataset, "
                         f"got {type(ds).__name__}")
    kind = ds.attrs.get("phasemap_kind")
    if kind is not None and not isinstance(kind, str):
        raise ValueError(f"phasemap_kind must be text, got {type(kind).__name__}")
    if kind is not None and kind != "atlas":
        if kind not in KINDS:
            raise ValueError(f"unknown phasemap_kind {kind!r}; known kinds: {', '.join(KINDS)}")
        return str(kind)
    if kind is None and "phasemap_model" not in ds.attrs:
        raise ValueError("not a phasemap atlas: no phasemap_model or phasemap_kind "
                         "global attribute")
    if not ds.data_vars:
        raise ValueError("not a phasemap atlas: it has no layers (data variables)")
    cycles = [v for v in ds.data_vars.values() if v.ndim == 2 and v.dims[1] == "cycle"]
    if cycles and all(v.dims[:1] == cycles[0].dims[:1] for v in ds.data_vars.values()):
        return "orbit_diagram"      # a scene's section points over one axis (maps.motions)
    if "fate" in ds.data_vars:
        return "fate"
    var = first_layer(ds)
    if var.ndim == 1:
        return "profile"
    if var.ndim == 2:
        return "map"
    dims = ", ".join(map(str, var.dims))
    raise ValueError(f"a {var.ndim}-D atlas ({dims}) has no single figure: select a 1-D or 2-D "
                     f"slice first, e.g. ds.isel({var.dims[-1]}=0)")
