r"""What every phasemap Dataset shares: its CF header, its kind, and the words of its figures.

Three producers make Datasets: :class:`phasemap.Scene` (atlases and fate
maps), :func:`phasemap.simulate` (trajectories) and
:func:`phasemap.phase_curve` (phase curves).  Each starts its global
attributes with :func:`cf_header`, so that the ``Conventions``, the
provenance and the model's description are written in one place; the writer
(:mod:`phasemap.atlas`), the accessor and the figures decide what a Dataset
is with :func:`dataset_kind`, here, and without matplotlib.

The model's description (``phasemap_variables``, JSON) carries the symbol,
UDUNITS units and long name of every variable, acceleration, reaction and the
coefficient, with the branch names, so that a figure of a declared system
reads ``$\theta$ (rad)`` and ``$\omega$ = 0 rad s$^{-1}$`` from the file
alone, with no code loaded (:func:`vocabulary`).

>>> import phasemap
>>> from phasemap._dataset import cf_header, squared_units, vocabulary
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
from dataclasses import dataclass, field
from typing import Mapping

import xarray as xr

from ._version import __version__

__all__ = [
    "CONVENTIONS",
    "KINDS",
    "MOTIONS",
    "Vocabulary",
    "cf_header",
    "dataset_kind",
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
KINDS = ("map", "profile", "fate", "phase_curve", "trajectory")
#: The kinds that follow one motion (global attribute ``phasemap_kind``).
MOTIONS = ("phase_curve", "trajectory")

#: The title of each producer's Dataset, by kind (``phasemap_kind``; ``atlas`` for a Scene's).
_TITLES = {"atlas": "atlas", "trajectory": "trajectory", "phase_curve": "phase curve",
           "boundaries": "boundaries", "threshold": "threshold curve"}


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def cf_header(model, kind: str = "atlas", producer: str = "phasemap") -> dict:
    """The global attributes every Dataset made from ``model`` starts with.

    ``Conventions``, ``title`` (``"phasemap <kind>: <model title>"``),
    ``source``, ``history`` (``"<time> created by <producer> <version>"``),
    ``references`` (the model's citation), ``phasemap_kind`` (a motion only:
    ``"trajectory"`` or ``"phase_curve"``), ``phasemap_model``,
    ``phasemap_version``, ``date_created`` and ``phasemap_variables`` (the
    model's description, see :func:`vocabulary`).  The producer adds what is
    its own (the scene, the fixed values, the end of a motion).
    """
    if kind not in _TITLES:
        raise ValueError(f"kind must be one of {', '.join(_TITLES)}, got {kind!r}")
    now = _now()
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
    return attrs


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
    }


@dataclass(frozen=True)
class Vocabulary:
    """The symbols, units and long names a figure of one model uses.

    ``variables``, ``accelerations`` and ``reactions`` map a name to
    ``(symbol, units, long_name)``, ``coefficient`` is ``(name, symbol,
    units, long_name)`` or None, ``branches`` the branch names in order.
    Empty when nothing is known.
    """

    variables: Mapping[str, tuple] = field(default_factory=dict)
    accelerations: Mapping[str, tuple] = field(default_factory=dict)
    reactions: Mapping[str, tuple] = field(default_factory=dict)
    coefficient: tuple | None = None
    branches: tuple[str, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.variables)


def _from_description(d: Mapping) -> Vocabulary:
    def table(key):
        return {str(k): tuple(v) for k, v in dict(d.get(key) or {}).items()}

    coef = d.get("coefficient")
    return Vocabulary(table("variables"), table("accelerations"), table("reactions"),
                      tuple(coef) if coef else None, tuple(d.get("branches") or ()))


def vocabulary(ds: xr.Dataset | Mapping) -> Vocabulary:
    """What the Dataset ``ds`` (or its global attributes) says about its model's words.

    Read from the global attribute ``phasemap_variables`` that :func:`cf_header`
    writes; a Dataset made before it existed falls back to the registered model
    named by ``phasemap_model``; an empty :class:`Vocabulary` when neither is there.
    """
    attrs = ds.attrs if isinstance(ds, xr.Dataset) else ds
    text = attrs.get("phasemap_variables")
    if text:
        try:
            return _from_description(json.loads(str(text)))
        except (ValueError, TypeError, AttributeError):
            pass
    from .models import get_model

    try:
        model = get_model(attrs.get("phasemap_model"))
    except (ValueError, TypeError):
        return Vocabulary()
    return _from_description(_describe(model))


# --------------------------------------------------------------------------- kinds


def is_categorical(var: xr.DataArray) -> bool:
    """Whether ``var`` is a categorical layer (it has ``flag_values`` and ``flag_meanings``)."""
    return "flag_values" in var.attrs and "flag_meanings" in var.attrs


def first_layer(ds: xr.Dataset) -> xr.DataArray:
    """The first categorical layer of ``ds``, else its first layer."""
    for var in ds.data_vars.values():
        if is_categorical(var):
            return var
    return next(iter(ds.data_vars.values()))


def motion_kind(ds: xr.Dataset) -> str | None:
    """``"trajectory"`` or ``"phase_curve"`` for a Dataset that follows one motion, else None."""
    kind = ds.attrs.get("phasemap_kind")
    return str(kind) if kind in MOTIONS else None


def dataset_kind(ds: xr.Dataset) -> str:
    """Which of :data:`KINDS` the Dataset ``ds`` is, and so which figure suits it.

    The global attribute ``phasemap_kind`` decides first (``"atlas"`` there
    means: decide from the dimensions); then a ``fate`` layer makes a fate
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
        raise ValueError(f"not a phasemap atlas: expected an xarray.Dataset, "
                         f"got {type(ds).__name__}")
    kind = ds.attrs.get("phasemap_kind")
    if kind is not None and kind != "atlas":
        if kind not in KINDS:
            raise ValueError(f"unknown phasemap_kind {kind!r}; known kinds: {', '.join(KINDS)}")
        return str(kind)
    if kind is None and "phasemap_model" not in ds.attrs:
        raise ValueError("not a phasemap atlas: no phasemap_model or phasemap_kind "
                         "global attribute")
    if not ds.data_vars:
        raise ValueError("not a phasemap atlas: it has no layers (data variables)")
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
