"""Each mathtext string is laid out once per process, not once per saved file.

phasemap's figures label their axes and ticks with mathtext (``$\\varphi$ (rad)``,
``$\\pi/2$``, and every tick number, for ``axes.formatter.use_mathtext``).  matplotlib
caches a string's layout on the renderer's own parser, 50 strings deep, and makes a new
renderer, with a new parser, for every file it saves; a figure saved as PDF and PNG lays
out each of its labels four times (the layout pass and the drawing, in each format),
and every figure of a study again.  Parsing is pyparsing's, about 10 ms a string:
the hinge pendulum's study laid out 171 strings 524 times, a fifth of its run.

:func:`install` keys matplotlib's own cached function by the parser's output kind
(vector for PDF, raster for PNG) instead of the parser object, in one cache of
:data:`SIZE` layouts for the process.  The layout of a string depends only on the
string, the dpi, the font properties, antialiasing, the hinting flags, the output kind
and the ``mathtext.*`` rcParams, which are the key (a call without font properties, which
reads the fonts of the moment's rcParams, is not shared); what is drawn is what
matplotlib draws.  A matplotlib whose
``MathTextParser`` does not have the function this expects is left as it is.

>>> install(); installed()
True
"""

from __future__ import annotations

import functools
import inspect
import threading

__all__ = ["install", "installed", "SIZE"]

#: Layouts kept (a study's figures use one or two hundred strings at two dpi).
SIZE = 2048

_STATE = {"installed": False}
_LOCK = threading.Lock()


def installed() -> bool:
    """Whether :func:`install` has shared matplotlib's mathtext layouts in this process."""
    return _STATE["installed"]


def install() -> None:
    """Share matplotlib's mathtext layouts between its parsers (once per process)."""
    with _LOCK:
        if _STATE["installed"]:
            return
        import matplotlib as mpl
        from matplotlib import mathtext

        cls = mathtext.MathTextParser
        cached = cls.__dict__.get("_parse_cached")
        inner = getattr(cached, "__wrapped__", None)
        if inner is None or list(inspect.signature(inner).parameters) != [
                "self", "s", "dpi", "prop", "antialiased", "load_glyph_flags"]:
            return
        parsers: dict = {}      # one parser per output kind computes the shared layouts

        # the rcParams a layout reads besides its font properties (the custom fontset's
        # fonts, the default style, the fallback): part of the key
        keys = sorted(k for k in mpl.rcParams if k.startswith("mathtext."))

        @functools.lru_cache(SIZE)
        def layout(key, s, dpi, prop, antialiased, load_glyph_flags):
            return inner(parsers[key[0]], s, dpi, prop, antialiased, load_glyph_flags)

        def _parse_cached(self, s, dpi, prop, antialiased, load_glyph_flags):
            kind = getattr(self, "_output_type", None)
            if kind is None or prop is None:   # fonts from the rcParams of the moment
                return inner(self, s, dpi, prop, antialiased, load_glyph_flags)
            parsers.setdefault(kind, self)
            rc = repr([mpl.rcParams[k] for k in keys])
            return layout((kind, rc), s, dpi, prop, antialiased, load_glyph_flags)

        _parse_cached.__wrapped__ = inner
        _parse_cached.cache_info = layout.cache_info
        _parse_cached.cache_clear = layout.cache_clear
        cls._parse_cached = _parse_cached
        _STATE["installed"] = True
