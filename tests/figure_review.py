"""Record what every figure a study saves says, for the review tests of issue 11.

``recording()`` swaps :func:`phasemap.study.save_figure` for one that first
notes the figure's headings, legend texts and labels (``plot.figure_texts``)
by file name, so a test can check that each figure states what was held fixed
and letters its panels.  A study loaded inside the block picks the recorder
up whether it imported ``save_figure`` by name or calls ``study.save_figure``.
"""

from __future__ import annotations

import contextlib

from phasemap import plot as pplot
from phasemap import study


@contextlib.contextmanager
def recording():
    seen: dict[str, dict] = {}
    original = study.save_figure

    def save(fig, out, name):
        panels = [a for a in fig.axes if a.get_label() != "<colorbar>" and a.axison
                  and a.get_position().height > 0.2 and a.get_position().width > 0.15]
        seen[name] = {"texts": pplot.figure_texts(fig), "panels": len(panels)}
        return original(fig, out, name)

    study.save_figure = save
    try:
        yield seen
    finally:
        study.save_figure = original


def check(seen: dict[str, dict], exempt_fixed=()) -> None:
    """Every figure states g (so its fixed values), every multi-panel figure is lettered."""
    assert seen
    for name, what in seen.items():
        text = " ".join(what["texts"])
        if name not in exempt_fixed:
            assert "$g$ = " in text, (name, what["texts"])
        if what["panels"] > 1:
            assert "(a)" in text and "(b)" in text, (name, what["texts"])
        assert "φ" not in text and "²" not in text, (name, "upright symbol outside mathtext")
