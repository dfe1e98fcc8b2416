"""Record what every figure a study saves says, and review its layout, for issue 11.

``recording()`` swaps :func:`phasemap.study.save_figure` for one that first
notes the figure's headings, legend texts and labels (``plot.figure_texts``),
its width and the problems :func:`layout_problems` finds, by file name, so a
test can check that each figure states what was held fixed, letters its
panels and is laid out cleanly at its printed width.  A study loaded inside
the block picks the recorder up whether it imported ``save_figure`` by name
or calls ``study.save_figure``.

The layout review is geometric, on the drawn figure at its printed size:

* every text is at least :data:`MIN_POINTS` pt and inside the figure;
* no two texts (headings, axis and tick labels, legends, colour-bar labels,
  annotations) overlap;
* no text or legend lies over another panel's plotting area; an inset's
  texts may lie over its parent panel but must not cross its lines;
* panel letters (a), (b), ... sit above their panels, at the same offset
  from each panel's left edge.
"""

from __future__ import annotations

import contextlib
import itertools
import re

from matplotlib.legend import Legend

from phasemap import plot as pplot
from phasemap import study

#: The smallest font a journal prints legibly (pt).
MIN_POINTS = 7.0
#: Slack in pixels (at the figure's dpi) for boxes that merely touch.
SLACK = 1.0


@contextlib.contextmanager
def recording():
    seen: dict[str, dict] = {}
    original = study.save_figure

    def save(fig, out, name):
        panels = [a for a in fig.axes if a.get_label() != "<colorbar>" and a.axison
                  and a.get_position().height > 0.2 and a.get_position().width > 0.15]
        seen[name] = {"texts": pplot.figure_texts(fig), "panels": len(panels),
                      "width": fig.get_figwidth(), "problems": layout_problems(fig)}
        return original(fig, out, name)

    study.save_figure = save
    try:
        yield seen
    finally:
        study.save_figure = original


def check(seen: dict[str, dict], exempt_fixed=()) -> None:
    """Every figure states g (so its fixed values), every multi-panel figure is lettered,
    and its layout has no problems."""
    assert seen
    for name, what in seen.items():
        text = " ".join(what["texts"])
        if name not in exempt_fixed:
            assert "$g$ = " in text, (name, what["texts"])
        if what["panels"] > 1:
            assert "(a)" in text and "(b)" in text, (name, what["texts"])
        assert "φ" not in text and "²" not in text, (name, "upright symbol outside mathtext")
        plain = " ".join(text.split("$")[::2])  # what lies outside mathtext
        spelled = _SPELLED.search(plain)
        assert spelled is None, (name, f"{spelled and spelled.group(0)!r}: a symbol spelled out")
        assert not what["problems"], (name, what["problems"])


#: A Greek letter's name given a value outside mathtext ("rho = 0.5 m"): a missing symbol.
_SPELLED = re.compile(r"\b(alpha|beta|gamma|delta|epsilon|zeta|eta|theta|kappa|lambda|mu|nu|xi"
                      r"|rho|sigma|tau|phi|chi|psi|omega)\s*=", re.IGNORECASE)


# --------------------------------------------------------------------------- layout


def _shrunk(box):
    return box.padded(-SLACK)


def _texts(fig, renderer):
    """(what, bbox, owner axes or None, font size) of every visible text and legend."""
    out = []

    def add(what, artist, owner):
        if artist is None or not artist.get_visible():
            return
        if isinstance(artist, Legend):
            out.append((what, artist.get_window_extent(renderer), owner, min(
                [t.get_fontsize() for t in artist.get_texts()]
                + [artist.get_title().get_fontsize()])))
        elif artist.get_text().strip():
            out.append((f"{what} {artist.get_text()[:40]!r}",
                        artist.get_window_extent(renderer), owner, artist.get_fontsize()))

    for f in [fig, *fig.subfigs]:
        add("figure title", getattr(f, "_suptitle", None), None)
        add("figure key", getattr(f, "_supxlabel", None), None)
        for leg in f.legends:
            add("figure legend", leg, None)
    for ax in _all_axes(fig):
        if not ax.get_visible():
            continue
        for loc in ("left", "center", "right"):
            add(f"title of {_name(ax)}", ax._left_title if loc == "left" else
                ax.title if loc == "center" else ax._right_title, ax)
        add(f"legend of {_name(ax)}", ax.get_legend(), ax)
        for t in ax.texts:
            add(f"text in {_name(ax)}", t, ax)
        if not ax.axison:
            continue
        add(f"x label of {_name(ax)}", ax.xaxis.label, ax)
        add(f"y label of {_name(ax)}", ax.yaxis.label, ax)
        for axis in (ax.xaxis, ax.yaxis):
            # the ticks matplotlib draws: those within the view limits (private, but the
            # public tick lists also hold ticks outside the view with stale positions)
            for tick in axis._update_ticks():
                if tick.get_visible():
                    for label in (tick.label1, tick.label2):
                        if label.get_visible():
                            add(f"tick label of {_name(ax)}", label, ax)
    return out


def _name(ax) -> str:
    label = ax.get_label()
    return "colour bar" if label == "<colorbar>" else f"panel at ({ax.get_position().x0:.2f}, " \
        f"{ax.get_position().y0:.2f})"


def _all_axes(fig) -> list:
    """The figure's axes and their insets (``Axes.inset_axes``, not in ``fig.axes``)."""
    out = []
    for ax in fig.axes:
        out += [ax, *ax.child_axes]
    return out


def _parent(ax, axes):
    """The panel an inset lies in, or None."""
    for other in axes:
        if ax in other.child_axes:
            return other
    return None


def _crosses_lines(box, ax) -> list[str]:
    hits = []
    for line in ax.get_lines():
        if not line.get_visible() or line.get_linestyle() in ("None", "none", " ", ""):
            continue
        path = line.get_transform().transform_path(line.get_path())
        if path.intersects_bbox(_shrunk(box), filled=False):
            hits.append(line.get_label() or "a line")
    return hits


def layout_problems(fig) -> list[str]:
    """What a referee would flag in the layout of ``fig`` at its printed size (see above)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    texts = _texts(fig, renderer)
    page = fig.bbox.padded(SLACK)
    areas = [ax for ax in _all_axes(fig) if ax.get_visible() and ax.axison
             and ax.get_label() != "<colorbar>"]
    parents = {ax: _parent(ax, areas) for ax in areas}
    for what, box, owner, size in texts:
        if size < MIN_POINTS - 1e-9:
            problems.append(f"{what}: {size:g} pt is below {MIN_POINTS:g} pt")
        if not (page.contains(box.x0, box.y0) and page.contains(box.x1, box.y1)):
            problems.append(f"{what}: cut off by the figure's edge")
        for ax in areas:
            if ax is owner:
                continue
            if parents.get(owner) is ax:
                problems += [f"{what} crosses {hit} of its parent panel"
                             for hit in _crosses_lines(box, ax)]
            elif parents.get(ax) is owner and owner is not None:
                continue  # a panel's own text over its inset: caught the other way round
            elif _shrunk(box).overlaps(ax.bbox):
                problems.append(f"{what} lies over {_name(ax)}")
    for (w1, b1, o1, _), (w2, b2, o2, _) in itertools.combinations(texts, 2):
        if _shrunk(b1).overlaps(_shrunk(b2)):
            problems.append(f"{w1} overlaps {w2}")
    problems += _letter_problems(fig, renderer)
    return problems


_LETTER = re.compile(r"\(([a-z])\)")


def _letter_problems(fig, renderer) -> list[str]:
    """Panel letters above their panels, at one offset from each panel's left edge."""
    found = []
    for ax in fig.axes:
        candidates = [ax._left_title]
        if ax.get_legend() is not None:
            candidates.append(ax.get_legend().get_title())
        for t in candidates:
            if t.get_visible() and _LETTER.match(t.get_text()):
                found.append((t.get_text()[:3], t.get_window_extent(renderer), ax))
    problems = []
    offsets = []
    for letter, box, ax in found:
        if box.y0 < ax.bbox.y1 - SLACK:
            problems.append(f"panel letter {letter} is not above its panel")
        offsets.append((letter, box.x0 - ax.bbox.x0))
    if offsets:
        lo, hi = min(o for _, o in offsets), max(o for _, o in offsets)
        if hi - lo > 2.0 * SLACK + 1.0:
            problems.append(f"panel letters at different offsets from their panels: {offsets}")
    return problems
