"""Reading atlases: :func:`open_atlas` (an atlas file back as the Dataset that was
written, checked to be one of phasemap's) and :func:`describe_atlas` (the human summary
``phasemap info`` prints: what a file holds, its axes and its classes, read in slabs of
bounded memory)."""

from __future__ import annotations

import math
import os
from typing import Iterator

import numpy as np
from phasemap.core.lazy import xarray as xr

from phasemap.core import args as _args

from phasemap.atlas.dataset import curve_axes, curve_kind, motion_kind


#: Layers are read in slabs of at most this many bytes by :func:`describe_atlas`.
_SLAB_BYTES = 16 << 20


def open_atlas(path: str | os.PathLike, **kwargs) -> xr.Dataset:
    """Open an atlas file lazily, checking that it is one.

    Close the result (or use it in a ``with`` block) when done.

    Parameters
    ----------
    path : str or os.PathLike
        an atlas file written by :func:`write_atlas` or ``phasemap atlas``.
    **kwargs
        passed to :func:`xarray.open_dataset` (``chunks=`` for dask arrays).

    Returns
    -------
    xarray.Dataset
        the atlas, its layers read lazily.

    Raises
    ------
    ValueError
        with a one-line message if the file does not exist, is not netCDF, or
        is not a phasemap atlas.

    Examples
    --------
    >>> import phasemap
    >>> phasemap.open_atlas("no_such_atlas.nc")
    Traceback (most recent call last):
    ...
    ValueError: no_such_atlas.nc: no such file

    Reading one back is shown in :func:`write_atlas`.
    """
    path = _args.existing_file("path", path, "open_atlas")
    kwargs.setdefault("engine", "netcdf4")
    kwargs.setdefault("decode_times", False)
    kwargs.setdefault("decode_timedelta", False)
    try:
        ds = xr.open_dataset(path, **kwargs)
    except Exception as err:  # netCDF4 and HDF5 raise a variety of types
        reason = " ".join(str(err).split()) or type(err).__name__
        raise ValueError(f"{path}: not a readable netCDF file ({reason})") from None
    try:
        _check_is_atlas(ds, str(path))
    except ValueError:
        ds.close()
        raise
    return ds


def describe_atlas(path_or_ds: str | os.PathLike | xr.Dataset) -> str:
    """A human summary of an atlas, as ``phasemap info`` prints it.

    It names the model, the axes (size, range, units, uniform or not), the
    fixed values, every layer with its units, and for each categorical layer
    the count and percentage of cells in each class, then the version and time
    that made the atlas.  Layers are read in slabs, so a large file is never
    loaded whole.

    Parameters
    ----------
    path_or_ds : str, os.PathLike or xarray.Dataset
        an atlas file, or an atlas in memory.

    Returns
    -------
    str
        the summary, several lines.

    Raises
    ------
    ValueError
        if the file does not exist, is not netCDF or is not a phasemap atlas.

    Examples
    --------
    >>> import numpy as np, phasemap
    >>> ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 4),
    ...                                     "f": [0.0, 0.5, 1.0]}, fixed={"omega": 0.0}).compute()
    >>> print(phasemap.describe_atlas(ds))   # doctest: +ELLIPSIS
    phasemap atlas (in memory)
    ...
      cells     12 = 4 phi x 3 f
    ...
    """
    if isinstance(path_or_ds, xr.Dataset):
        _check_is_atlas(path_or_ds, "dataset")
        return _describe(path_or_ds, "(in memory)")
    path = _args.path("path_or_ds", path_or_ds, "describe_atlas")  # a file name, or says so
    with open_atlas(path) as ds:
        try:
            return _describe(ds, str(path_or_ds))
        except (OSError, RuntimeError) as err:  # a damaged file opens but fails to read
            reason = " ".join(str(err).split()) or type(err).__name__
            raise ValueError(f"{path_or_ds}: cannot read the atlas ({reason})") from None


def _check_is_atlas(ds: xr.Dataset, where: str) -> None:
    if "phasemap_model" not in ds.attrs:
        raise ValueError(f"{where}: not a phasemap atlas (no phasemap_model global attribute)")
    if not ds.data_vars:
        raise ValueError(f"{where}: not a phasemap atlas (no layers)")


#: What a motion's description reads, by kind.
_MOTION_VARIABLES = {"trajectory": ("t", "event_kind", "event_t"),
                     "phase_curve": ("stage_end_reason",)}


def _describe(ds: xr.Dataset, where: str) -> str:
    kind = motion_kind(ds)
    if kind is not None:
        missing = [n for n in _MOTION_VARIABLES[kind] if n not in ds.variables]
        if missing:
            raise ValueError(f"{where}: phasemap_kind says {kind}, but it has no "
                             f"{', '.join(missing)}")
        return _describe_motion(ds, where, kind)
    if curve_kind(ds) is not None:
        return _describe_curves(ds, where, curve_kind(ds))
    if ds.attrs.get("phasemap_kind") in ("periodic_orbit", "orbit_branch", "orbit_diagram"):
        return _describe_orbit(ds, where, str(ds.attrs["phasemap_kind"]))
    return _describe_grid(ds, where)


def _describe_orbit(ds: xr.Dataset, where: str, kind: str) -> str:
    """A periodic orbit or a branch of them, headed by where it is and what made it."""
    a = ds.attrs
    lines = [f"phasemap {kind.replace('_', ' ')} {where}", f"  title     {a.get('title', '')}",
             f"  model     {a.get('phasemap_model', '?')}", _made_by(a)]
    body = {"periodic_orbit": orbit_lines, "orbit_branch": branch_lines,
            "orbit_diagram": diagram_lines}[kind](ds)
    return "\n".join(lines + body)


def orbit_lines(ds: xr.Dataset) -> list[str]:
    """A periodic orbit (:func:`phasemap.periodic_orbit`, in memory or read back) as lines:
    its period and stability, a table of its segments (duration, each contact's mode, the
    event that ends it) and its Floquet multipliers."""
    state = ("one of a continuum of orbits" if int(ds.get("continuum", 0)) else
             "stable" if int(ds.stable) else "unstable")
    lines = [f"  period    {float(ds.period):.12g} s, {state}, shooting residual "
             f"{float(ds.residual):.1e}"]
    contacts = [str(v)[len("segment_mode_"):] for v in ds.data_vars
                if str(v).startswith("segment_mode_")]
    names = ds[f"segment_mode_{contacts[0]}"].attrs["flag_meanings"].split()
    ends = dict(zip(np.asarray(ds.segment_end.attrs["flag_values"]).tolist(),
                    ds.segment_end.attrs["flag_meanings"].split()))
    rows = [("segment", "duration (s)", *contacts, "ends with")]
    for j in range(ds.sizes["segment"]):
        rows.append((str(j), f"{float(ds.segment_duration[j]):.12g}",
                     *(names[int(ds[f"segment_mode_{c}"][j])] for c in contacts),
                     ends.get(int(ds.segment_end[j]), str(int(ds.segment_end[j])))))
    lines += ["segments", *("  " + r for r in _table(rows, right=(1,)))]
    if "floquet_real" in ds:
        mult = ds.floquet_real.values + 1j * ds.floquet_imag.values
    else:
        mult = ds.floquet.values
    lines.append("Floquet multipliers  " + ", ".join(f"{_rounded(x):.6g}" for x in mult))
    return lines


#: A multiplier's part below this is printed as 0: a stick segment's collapse gives an
#: exact 0, which the eigenvalue solver returns as a rounding error of either sign.
ZERO = 1e-12


def _rounded(x) -> complex:
    z = complex(x)
    return complex(0.0 if abs(z.real) < ZERO else z.real, 0.0 if abs(z.imag) < ZERO else z.imag)


def branch_lines(ds: xr.Dataset) -> list[str]:
    """A branch of periodic orbits (:func:`phasemap.continue_orbit`) as lines: its
    parameter's range, how many of its points are stable, and a table of its special
    points."""
    param = str(ds.attrs["phasemap_parameter"])
    p = ds[param].values
    lines = [f"  branch    {ds.sizes['vertex']} point(s), {param} from {p.min():.6g} to "
             f"{p.max():.6g}; {int(ds.stable.sum())} stable"]
    rows = [("point", param, "period (s)")]
    for i in range(ds.sizes["point"]):
        rows.append((str(ds.point_kind.values[i]), f"{float(ds[f'point_{param}'][i]):.12g}",
                     f"{float(ds.point_period[i]):.9g}"))
    return lines + ["special points", *("  " + r for r in _table(rows, right=(1, 2)))]


def diagram_lines(ds: xr.Dataset) -> list[str]:
    """An orbit diagram (:func:`phasemap.orbit_diagram`) as lines: its sweep, and the
    runs of values whose settled motion has one period (in forcing periods; 0: none found,
    a motion that is chaotic, quasi-periodic or still settling), with how the motions
    ended where not all ran through."""
    import json

    param = str(ds.attrs["phasemap_parameter"])
    p, mult = ds[param].values, ds.multiple.values
    spec = json.loads(ds.attrs.get("phasemap_diagram", "{}"))
    lines = [f"  sweep     {p.size} value(s) of {param} from {p[0]:.6g} to {p[-1]:.6g}; "
             f"{ds.sizes['cycle']} forcing period(s) kept after {spec.get('settle', '?')}"]
    rows = [(param, "", "period (forcing periods)")]
    start = 0
    for i in range(1, p.size + 1):
        if i == p.size or mult[i] != mult[start]:
            m = int(mult[start])
            rows.append((f"{p[start]:.6g}", f"to {p[i - 1]:.6g}" if i - 1 > start else "",
                         str(m) if m else "none (chaotic, quasi-periodic or settling)"))
            start = i
    lines += ["settled motion", *("  " + r for r in _table(rows))]
    from phasemap.core.events import HORIZON

    ended = ds.fate.values != HORIZON
    if ended.any():
        names = dict(zip(np.asarray(ds.fate.attrs["flag_values"]).tolist(),
                         ds.fate.attrs["flag_meanings"].split()))
        kinds = sorted({names.get(int(f), str(int(f))) for f in ds.fate.values[ended]})
        lines.append(f"  {int(ended.sum())} motion(s) ended early: {', '.join(kinds)}")
    return lines


def _made_by(a) -> str:
    """The summary's line of the version and time that made a file."""
    return (f"  made by   phasemap {a.get('phasemap_version', '?')}, "
            f"{a.get('date_created', 'creation time unknown')}")


def _prefixed(a, prefix: str) -> list[tuple[str, str, str]]:
    """The attributes named ``prefix<name>``, as rows (name, "=", value) of a table."""
    return [(k[len(prefix):], "=", _number(v)) for k, v in a.items() if k.startswith(prefix)]


def _describe_curves(ds: xr.Dataset, where: str, kind: str) -> str:
    """Boundaries or a threshold curve: its axes, pieces by condition, special points."""
    a = ds.attrs
    x, y = curve_axes(ds)
    lines = [f"phasemap {'threshold curve' if kind == 'threshold' else kind} {where}"]
    if "title" in a:
        lines.append(f"  title     {a['title']}")
    lines.append(f"  model     {a['phasemap_model']}")
    if kind == "threshold":
        lines.append(f"  threshold the {a.get('phasemap_side', '')} {y} at which "
                     f"{a.get('phasemap_layer', '?')} = {_number(a.get('phasemap_value'))}, "
                     f"followed in {x}")
    else:
        lines.append(f"  layer     {a.get('phasemap_layer', '?')}, over {x} and {y}")
    for name in (x, y):
        values = np.asarray(ds[name].values, dtype=float)
        span = (f"from {np.nanmin(values):.6g} to {np.nanmax(values):.6g}"
                if np.isfinite(values).any() else "(no vertex)")
        units = str(ds[name].attrs.get("units", ""))
        lines.append(f"  {name:<9} {span} {'' if units == '1' else units}".rstrip())
    conditions = np.asarray(ds["condition"].values).astype(str) if "condition" in ds else []
    counts: dict[str, int] = {}
    for c in conditions:
        counts[c] = counts.get(c, 0) + 1
    lines.append(f"  pieces    {ds.sizes.get('piece', 0)} with {ds.sizes.get('vertex', 0)} "
                 "vertices" + (": " + ", ".join(f"{c} {n}" for c, n in counts.items())
                               if counts else ""))
    kinds = np.asarray(ds["point_kind"].values).astype(str) if "point_kind" in ds else []
    points: dict[str, int] = {}
    for k in kinds:
        points[k] = points.get(k, 0) + 1
    lines.append(f"  points    {len(kinds)}" + (": " + ", ".join(
        f"{k} {n}" for k, n in points.items()) if points else ""))
    for name in ("residual", "point_residual"):
        if name in ds and ds[name].size and np.isfinite(ds[name].values).any():
            lines.append(f"  {'residual' if name == 'residual' else 'points residual':<9} "
                         f"at most {np.nanmax(np.abs(ds[name].values)):.3g} (relative to "
                         "the conditions' tie scales)")
    if "phasemap_tol" in a:
        lines.append(f"  tolerance {_number(a['phasemap_tol'])}")
    lines.append(_made_by(a))
    fixed = _prefixed(a, "phasemap_fixed_")
    lines.append("fixed")
    lines += _table(fixed) if fixed else ["  (none)"]
    return "\n".join(lines)


def _describe_motion(ds: xr.Dataset, where: str, kind: str) -> str:
    """A trajectory (times, events) or a phase curve (points, stages), as what it is."""
    from phasemap.core.events import Event

    a = ds.attrs
    lines = [f"phasemap {kind.replace('_', ' ')} {where}"]
    if "title" in a:
        lines.append(f"  title     {a['title']}")
    lines.append(f"  model     {a['phasemap_model']}")
    if kind == "trajectory":
        t = np.asarray(ds["t"].values, dtype=float)
        span = f", t from {t.min():.6g} to {t.max():.6g} s" if t.size else ""
        lines.append(f"  saved     {t.size} states{span}")
        codes = np.asarray(ds["event_kind"].values).tolist()
        count_of = "events"
    else:
        lines.append(f"  points    {ds.sizes.get('point', 0)} points of omega(phi) on "
                     f"{ds.sizes.get('stage', 0)} stages")
        codes = np.asarray(ds["stage_end_reason"].values).tolist()
        count_of = "stages end"
    counts: dict[str, int] = {}
    for code in codes:
        try:
            name = Event(int(code)).name.lower()
        except ValueError:
            name = f"(unlisted {code})"
        counts[name] = counts.get(name, 0) + 1
    lines.append(f"  {count_of:<9} {len(codes)}: " + ", ".join(f"{n} {k}" for n, k in
                                                             counts.items()))
    if "end_reason" in a:
        lines.append(f"  ended     {a['end_reason']}: {a.get('end_message', '')}")
    if "n_reversals" in a:
        lines.append(f"  reversals {int(np.squeeze(a['n_reversals']))}")
    lines.append(_made_by(a))
    start = _prefixed(a, "phasemap_initial_")
    fixed = _prefixed(a, "phasemap_fixed_")
    lines.append("initial state")
    lines += _table(start) if start else ["  (none)"]
    lines.append("parameters")
    lines += _table(fixed) if fixed else ["  (none)"]
    if kind == "trajectory":
        rows = [("t (s)", "event", *[str(n)[len("event_"):] for n in ds.data_vars
                                     if str(n).startswith("event_")
                                     and str(n) not in ("event_t", "event_kind",
                                                        "event_branch")])]
        names = [f"event_{n}" for n in rows[0][2:]]
        for i in range(ds.sizes.get("event", 0)):
            e = ds.isel(event=i)
            try:
                name = Event(int(e.event_kind)).name.lower()
            except ValueError:
                name = str(int(e.event_kind))
            rows.append((f"{float(e.event_t):.6g}", name,
                         *(f"{float(e[n]):.6g}" for n in names)))
        lines.append("events")
        lines += _table(rows)
    return "\n".join(lines)


def _describe_grid(ds: xr.Dataset, where: str) -> str:
    a = ds.attrs
    # (a scene's section points have one more dimension, cycle, than its cells)
    dims = [str(d) for d in ds.dims if d != "cycle"]
    cells = math.prod(ds.sizes[d] for d in dims)
    lines = [f"phasemap atlas {where}"]
    if "title" in a:
        lines.append(f"  title     {a['title']}")
    lines.append(f"  model     {a['phasemap_model']}")
    lines.append(f"  cells     {cells} = " + " x ".join(f"{ds.sizes[d]} {d}" for d in dims))
    lines.append(_made_by(a))
    if "Conventions" in a:
        lines.append(f"  follows   {a['Conventions']}")

    lines.append("axes")
    rows = []
    for d in dims + ["cycle"] * ("cycle" in ds.dims):
        if d in ds.coords:
            x = np.asarray(ds[d].values, dtype=float)
            attrs = ds[d].attrs
            rng = f"[{x.min():.6g}, {x.max():.6g}]" if x.size else "[]"
            rows.append((d, str(x.size), rng, str(attrs.get("units", "?")), _spacing(x),
                         str(attrs.get("long_name", ""))))
        else:
            rows.append((d, str(ds.sizes[d]), "(no coordinate)", "", "", ""))
    lines += _table(rows)

    fixed = {k[len("phasemap_fixed_"):]: v for k, v in a.items() if k.startswith("phasemap_fixed_")}
    lines.append("fixed values")
    if fixed:
        lines += _table([(k, "=", _number(v)) for k, v in fixed.items()])
    else:
        lines.append("  (none)")

    lines.append("layers")
    for name, var in ds.data_vars.items():
        attrs = var.attrs
        values = int(var.size)      # (the cells, or their section points)
        if "flag_meanings" in attrs:
            lines.append(f"  {name} ({var.dtype}, categorical): {attrs.get('long_name', '')}")
            lines += _class_lines(var, values)
        else:
            defined = _count_finite(var) if np.issubdtype(var.dtype, np.floating) else values
            pct = 100.0 * defined / values if values else 0.0
            lines.append(f"  {name} ({var.dtype}, {attrs.get('units', 'no units')}): "
                         f"{attrs.get('long_name', '')}; defined on {defined} "
                         f"{'points' if 'cycle' in var.dims else 'cells'} ({pct:.1f}%)")
    return "\n".join(lines)


def _number(value) -> str:
    try:
        return f"{float(np.squeeze(value)):.6g}"
    except (TypeError, ValueError):
        return str(value)


def _spacing(x: np.ndarray) -> str:
    if x.size < 2:
        return "single value"
    step = np.diff(x)
    mean = (x[-1] - x[0]) / (x.size - 1)
    scale = max(abs(mean), np.finfo(float).tiny)
    if np.all(np.abs(step - mean) <= 1e-6 * scale):
        return f"uniform, step {mean:.6g}"
    return f"non-uniform, steps {np.abs(step).min():.3g} to {np.abs(step).max():.3g}"


def _class_lines(var: xr.DataArray, cells: int) -> list[str]:
    meanings = str(var.attrs["flag_meanings"]).split()
    values = np.atleast_1d(np.asarray(var.attrs.get("flag_values", np.arange(len(meanings)))))
    counts: dict[int, int] = {}
    for block in _slabs(var):
        if block.dtype == np.int8:  # the usual case: one pass, no sort
            c = np.bincount(block.view(np.uint8).ravel(), minlength=256)
            v = np.arange(256, dtype=np.uint8).view(np.int8)
            v, c = v[c > 0], c[c > 0]
        else:
            v, c = np.unique(block, return_counts=True)
        for value, count in zip(v.tolist(), c.tolist()):
            counts[value] = counts.get(value, 0) + count
    rows = []
    for value, meaning in zip(values.tolist(), meanings):
        n = counts.pop(value, 0)
        rows.append(("  " + meaning, str(value), str(n), f"{_pct(n, cells)}%"))
    for value, n in sorted(counts.items(), key=lambda kv: str(kv[0])):
        rows.append(("  (unlisted)", str(value), str(n), f"{_pct(n, cells)}%"))
    return _table(rows, right=(1, 2, 3))


def _pct(n: int, cells: int) -> str:
    return f"{100.0 * n / cells:.2f}" if cells else "0.00"


def _count_finite(var: xr.DataArray) -> int:
    return sum(int(np.count_nonzero(np.isfinite(block))) for block in _slabs(var))


def _slabs(var: xr.DataArray) -> Iterator[np.ndarray]:
    """The values of ``var`` in slabs along its first dimension, each about :data:`_SLAB_BYTES`."""
    if var.ndim == 0:
        yield np.asarray(var.values)
        return
    per_row = max(1, var.size // max(var.shape[0], 1)) * var.dtype.itemsize
    step = max(1, _SLAB_BYTES // per_row)
    dim = var.dims[0]
    for start in range(0, var.shape[0], step):
        yield np.asarray(var.isel({dim: slice(start, start + step)}).values)


def _table(rows: list[tuple[str, ...]], right: tuple[int, ...] = ()) -> list[str]:
    if not rows:
        return []
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    out = []
    for r in rows:
        cells = [c.rjust(w) if i in right else c.ljust(w) for i, (c, w) in enumerate(zip(r, widths))]
        out.append(("  " + "  ".join(cells)).rstrip())
    return out
