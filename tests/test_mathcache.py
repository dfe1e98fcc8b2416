"""mathtext layouts shared between matplotlib's renderers (phasemap/plot/mathcache.py):
the same pixels as matplotlib's own cache, laid out once per process, and never reused
where the rcParams a layout reads have changed."""

from __future__ import annotations

import functools
import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import mathtext  # noqa: E402
from matplotlib.font_manager import FontProperties  # noqa: E402

from phasemap.plot import mathcache  # noqa: E402
from phasemap.plot.style import style  # noqa: E402  (importing it installs the cache)


def _png(labels) -> np.ndarray:
    with style():
        fig, ax = plt.subplots(figsize=(2.0, 1.5))
        ax.plot([0, 1], [0, 2])
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=100)
        plt.close(fig)
    buf.seek(0)
    return plt.imread(buf)


def test_importing_the_figures_installs_it_once():
    assert mathcache.installed()
    shared = mathtext.MathTextParser._parse_cached
    mathcache.install()
    assert mathtext.MathTextParser._parse_cached is shared


def test_the_same_pixels_as_matplotlibs_own_cache(monkeypatch):
    labels = (r"$\varphi$ (rad)", r"$\omega$ (rad s$^{-1}$)")
    ours = _png(labels)
    own = functools.lru_cache(50)(mathtext.MathTextParser._parse_cached.__wrapped__)
    monkeypatch.setattr(mathtext.MathTextParser, "_parse_cached", own)
    theirs = _png(labels)
    assert ours.shape == theirs.shape and np.array_equal(ours, theirs)


def test_a_second_file_lays_out_nothing_again():
    labels = (r"$\dot{x}_{11}$ (m s$^{-1}$)", r"$\ddot{y}_{12}$ (m s$^{-2}$)")
    _png(labels)
    misses = mathtext.MathTextParser._parse_cached.cache_info().misses
    _png(labels)                      # a new renderer, with a new parser
    assert mathtext.MathTextParser._parse_cached.cache_info().misses == misses


def test_a_changed_rcparam_is_laid_out_again():
    parser = mathtext.MathTextParser("path")
    prop = FontProperties(size=8.0)
    with matplotlib.rc_context({"mathtext.default": "it"}):
        italic = parser.parse(r"$abc$", 72, prop)
    with matplotlib.rc_context({"mathtext.default": "regular"}):
        upright = parser.parse(r"$abc$", 72, prop)
        mathtext.MathTextParser._parse_cached.cache_clear()
        fresh = mathtext.MathTextParser("path").parse(r"$abc$", 72, prop)
    with matplotlib.rc_context({"mathtext.default": "it"}):
        again = parser.parse(r"$abc$", 72, prop)
    assert italic.glyphs != upright.glyphs        # not the italic layout reused
    assert upright.glyphs == fresh.glyphs and again.glyphs == italic.glyphs
