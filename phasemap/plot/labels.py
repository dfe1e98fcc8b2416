r"""Label and unit text: axis labels from the model's symbols, fixed values, wrapping.

The words of a figure come from the Dataset itself (its ``phasemap_variables``
description, see :func:`phasemap.atlas.dataset.vocabulary`, and each variable's
``units``, ``long_name`` and ``phasemap_symbol``), so that an atlas of a
declared system is labelled as a built-in one is: ``$\theta$ (rad)``.
"""

from __future__ import annotations

import functools
import re
from typing import Sequence

import numpy as np
import xarray as xr

from phasemap.atlas.dataset import read_json, squared_units, vocabulary
from phasemap.core.args import describe
from phasemap.plot.style import _FONT

# --------------------------------------------------------------------------- labels


def format_units(units: str | None) -> str:
    """UDUNITS units as mathtext: ``"rad s-1"`` -> ``"rad s$^{-1}$"``; ``"1"`` -> ``""``."""
    if units is None:
        return ""
    units = str(units).strip()
    if units in ("", "1"):
        return ""
    out = []
    for token in units.split():
        m = re.fullmatch(r"([A-Za-z]+)(-?\d+)", token)
        if m and m.group(2) != "1":
            out.append(f"{m.group(1)}$^{{{m.group(2)}}}$")
        else:
            out.append(m.group(1) if m else _plain(token))
    return " ".join(out)


def _plain(text: str) -> str:
    """Text read from a file, shown as it is (a ``$`` does not start mathtext)."""
    return text.replace("$", r"\$")


@functools.lru_cache(maxsize=512)
def _is_mathtext(symbol: str) -> bool:
    """Whether ``$symbol$`` is mathtext matplotlib can draw (a symbol read from a file may
    not be: it is then not used)."""
    from matplotlib.mathtext import MathTextParser

    try:
        MathTextParser("path").parse(f"${symbol}$")
    except ValueError:
        return False
    return True


def _with_units(text: str, units: str | None) -> str:
    u = format_units(units)
    return f"{text} ({u})" if u else text


def _symbol_and_units(ds: xr.Dataset, name: str) -> tuple[str, str | None] | None:
    """The mathtext symbol (without $) and units of ``name``, if the Dataset says them.

    A variable's own ``phasemap_symbol`` attribute first; then the model's
    description (:func:`phasemap.atlas.dataset.vocabulary`): a variable, a branch's
    acceleration, reaction or coefficient (``phi_ddot_slide_pos``), a variable
    at a moment of a motion (``phi_rest``).  None if the symbol is not mathtext
    (the label is then made from the name or ``long_name``).
    """
    known = _declared_symbol(ds, name)
    if known is None or not _is_mathtext(known[0]):
        return None
    return known


def _declared_symbol(ds: xr.Dataset, name: str) -> tuple[str, str | None] | None:
    attrs = ds[name].attrs if name in ds.variables else {}
    if attrs.get("phasemap_symbol"):
        return str(attrs["phasemap_symbol"]), attrs.get("units")
    words = vocabulary(ds)
    if name in words.variables:
        symbol, units, _ = words.variables[name]
        return symbol, units
    for table in (words.accelerations, words.reactions):
        if name in table:       # the unique motion's (a map in full coordinates)
            symbol, units, _ = table[name]
            return symbol, units
        for var, (symbol, units, _) in table.items():
            for branch in words.branches:
                if name == f"{var}_{branch}":
                    return rf"{symbol}\ [\mathrm{{{_math_words(branch)}}}]", units
    if words.coefficient is not None:
        for branch in words.branches:
            if name == f"coef_{branch}":
                _, symbol, units, _ = words.coefficient
                return rf"{symbol}\ [\mathrm{{{_math_words(branch)}}}]", units
    head, _, moment = name.rpartition("_")  # phi_rest, omega_end: the value at a moment
    if head in words.variables and moment in _MOMENTS:
        symbol, units, _ = words.variables[head]
        return rf"{symbol}_{{\mathrm{{{moment}}}}}", units
    # section_x: the settled motion's points on a Poincare section (maps.motions)
    if name.startswith("section_") and name[len("section_"):] in words.variables:
        symbol, units, _ = words.variables[name[len("section_"):]]
        return rf"{symbol}_{{\mathrm{{section}}}}", units
    return None


#: Suffixes that name a variable's value at a moment of a motion (``phi_rest``).
_MOMENTS = ("rest", "start", "end", "final", "initial", "min", "max")


def _units(ds: xr.Dataset, name: str) -> str | None:
    """The units of ``name`` as the Dataset says them (see :func:`_symbol_and_units`)."""
    known = _symbol_and_units(ds, name)
    if known is not None:
        return known[1]
    return ds[name].attrs.get("units") if name in ds.variables else None


def _math_words(text: str) -> str:
    return text.replace("_", r"\ ")


def axis_label(ds: xr.Dataset, name: str) -> str:
    r"""The axis label of variable or coordinate ``name`` of ``ds``, as mathtext.

    From the model's :class:`~phasemap.Variable` when it knows the name
    (``"$\varphi$ (rad)"``, ``"$f$"`` for units ``1``), including a branch's
    fields (``"$\ddot\varphi\ [\mathrm{slide\ pos}]$ (rad s$^{-2}$)"``) and a
    variable at a moment (``phi_rest``: ``"$\varphi_{\mathrm{rest}}$ (rad)"``);
    otherwise from the variable's attributes: ``"$t$ (s)"`` for a one- or
    two-letter name, else ``"Long name (units)"``.
    """
    known = _symbol_and_units(ds, name)
    if known is not None:
        symbol, units = known
        return _with_units(f"${symbol}$", units)
    attrs = ds[name].attrs if name in ds.variables else {}
    units = attrs.get("units")
    if re.fullmatch(r"[A-Za-z]{1,2}", name):
        return _with_units(f"${name}$", units)
    text = _plain(str(attrs.get("long_name", name.replace("_", " "))))
    return _with_units(text[:1].upper() + text[1:], units)


def _squared_label(ds: xr.Dataset, name: str) -> str:
    known = _symbol_and_units(ds, name)
    if known is not None:
        symbol, units = known
    else:
        symbol, units = name, ds[name].attrs.get("units")
    return _with_units(f"${symbol}^2$", squared_units(units))


def _meaning_text(meaning: str) -> str:
    return meaning.replace("_", " ")


# --------------------------------------------------------------------------- what was held fixed


def format_number(value: float) -> str:
    """A value for a label: 4 significant digits, a typographic minus, powers of ten as
    mathtext (``1.5e-13`` -> ``"$1.5\\times10^{-13}$"``)."""
    text = f"{float(value):.4g}"
    if "e" in text:
        mant, exp = text.split("e")
        text = rf"{mant}\times10^{{{int(exp)}}}"
        text = f"${text}$"
    return text.replace("-", "\u2212")


def _value_text(ds: xr.Dataset, name: str, value: float, initial: bool = False) -> str:
    known = _symbol_and_units(ds, name)
    symbol, units = known if known is not None else (name, None)
    if initial:
        symbol = rf"{symbol}_0" if "_" not in symbol and "^" not in symbol else \
            rf"{{{symbol}}}_0"
    u = format_units(units)
    return f"${symbol}$ = {format_number(value)}" + (f" {u}" if u else "")


def _fixed_items(ds: xr.Dataset) -> tuple[list[str], list[str]]:
    order = list(vocabulary(ds).variables)
    out: tuple[list[str], list[str]] = ([], [])
    for items, prefix, initial in ((out[0], "phasemap_initial_", True),
                                   (out[1], "phasemap_fixed_", False)):
        names = [k[len(prefix):] for k in ds.attrs if k.startswith(prefix)]
        names.sort(key=lambda n: order.index(n) if n in order else len(order))
        for name in names:
            if name in ds.coords or name in ds.dims:
                continue
            try:
                value = float(np.asarray(ds.attrs[prefix + name]).ravel()[0])
            except (TypeError, ValueError, IndexError):
                continue
            if initial and name == "x" and "xdot" in names:
                continue  # the slider's position does not enter the equations
            items.append(_value_text(ds, name, value, initial))
    horizon = _horizon(ds)
    if horizon is not None:
        out[1].append(rf"$t_\mathrm{{end}}$ = {format_number(horizon)} s")
    return out


def _horizon(ds: xr.Dataset) -> float | None:
    """The time horizon ``t_end`` of a fate map (from the scene that made it), else None."""
    if "fate" not in ds.data_vars:
        return None
    try:
        return float(read_json(str(ds.attrs["phasemap_scene"]), "phasemap_scene")
                     ["options"]["t_end"])
    except (KeyError, TypeError, ValueError):
        return None


def fixed_values(ds: xr.Dataset) -> list[str]:
    r"""The initial state and the fixed values of ``ds``, one label each, as mathtext.

    Read from the global attributes ``phasemap_initial_<name>`` (a trajectory
    or a phase curve: ``$\varphi_0$ = 1 rad``) and ``phasemap_fixed_<name>``
    (``$\omega$ = 0.5 rad s$^{-1}$``), in the order of the model's variables;
    a name that is a coordinate of ``ds`` is not fixed and is left out.
    """
    initial, fixed = _fixed_items(ds)
    return initial + fixed


def _visible_length(text: str) -> float:
    """Roughly how many characters wide ``text`` renders (mathtext markup dropped)."""
    plain = re.sub(r"\\[A-Za-z]+", "x", text)
    plain = re.sub(r"[${}^_]", "", plain)
    return len(plain)


def wrap(items: Sequence[str], width: float, sep: str = ", ") -> str:
    """Join ``items`` with ``sep`` in lines no wider than ``width`` inches at the house font.

    An item too long for a line of its own is broken at its spaces (never inside
    ``$...$`` mathtext).
    """
    per_line = max(10, int(width / (0.5 * _FONT / 72.0)))
    lines, line = [], ""
    for item in items:
        candidate = f"{line}{sep}{item}" if line else item
        if line and _visible_length(candidate) > per_line:
            lines.append(line + sep.rstrip())
            line = item
        else:
            line = candidate
        while _visible_length(line) > per_line:
            head, rest = _break(line, per_line)
            if not rest:
                break
            lines.append(head)
            line = rest
    if line:
        lines.append(line)
    return "\n".join(lines)


def _break(text: str, per_line: int) -> tuple[str, str]:
    """``text`` split at the last space outside mathtext that leaves a head of at most
    ``per_line`` visible characters (at the first such space if none does)."""
    spaces = [i for i, c in enumerate(text) if c == " " and text[:i].count("$") % 2 == 0]
    fits = [i for i in spaces if _visible_length(text[:i]) <= per_line]
    cut = fits[-1] if fits else (spaces[0] if spaces else None)
    if cut is None:
        return text, ""
    return text[:cut], text[cut + 1:]


def fixed_values_text(ds: xr.Dataset, width: float | None = None) -> str:
    r"""What was held fixed, as one annotation: ``"$\omega$ = 0.5 rad s$^{-1}$, $f$ = 0.3, ..."``.

    :func:`fixed_values`, joined and wrapped to ``width`` inches (no wrapping
    when None); the initial state of a motion comes first, separated from
    the parameters by a semicolon.  Empty when nothing was fixed.
    """
    initial, fixed = _fixed_items(ds)
    if initial and fixed:
        initial[-1] += ";"
    items = initial + fixed
    if not items:
        return ""
    text = ", ".join(items) if width is None else wrap(items, width)
    return text.replace(";,", ";")


# --------------------------------------------------------------------------- reading the Dataset


def _flags(var: xr.DataArray) -> tuple[list[int], list[str]]:
    values = [int(v) for v in np.atleast_1d(np.asarray(var.attrs["flag_values"])).ravel()]
    meanings = str(var.attrs["flag_meanings"]).split()
    if len(values) != len(meanings):
        raise ValueError(f"layer {var.name!r}: {len(values)} flag_values but "
                         f"{len(meanings)} flag_meanings")
    return values, meanings


def _layer(ds: xr.Dataset, name: str) -> xr.DataArray:
    if not isinstance(name, str) or name not in ds.data_vars:
        shown = repr(name) if isinstance(name, str) else describe(name)
        raise ValueError(f"unknown layer {shown}; this dataset has: "
                         f"{', '.join(map(str, ds.data_vars))}")
    return ds[name]


def _require(ds: xr.Dataset, names: Sequence[str], kind: str) -> None:
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise ValueError(f"not a {kind} dataset: missing {', '.join(missing)}")


def _coord(ds: xr.Dataset, dim: str) -> np.ndarray:
    if dim in ds.coords:
        return np.asarray(ds[dim].values, dtype=float)
    return np.arange(ds.sizes[dim], dtype=float)


