"""Progress on stderr, in one style (tqdm), wherever a user waits.

The library is quiet by default; the command line and the tour switch
progress on with :func:`enable`, and it shows only where someone watches: when
stderr is a terminal (a log written by ``phasemap tour > log 2>&1``, or a pipe,
gets no ticker and no cursor codes).  ``PHASEMAP_PROGRESS=always`` in the
environment forces it on and shows every bar at once (the tests use it to see
that work has started); ``PHASEMAP_PROGRESS=never`` forces it off.

* :func:`bar` counts cells (or any unit) of work that is done in pieces.
* :func:`activity` is a ticking timer for a wait that has no count: numba
  compiling a kernel, one long call.  A background thread refreshes it twice
  a second, so the elapsed time moves even while nothing else prints.
* :func:`status` names what the innermost :func:`activity` is doing now (the
  tour's line shows the study's current step).
* :func:`human_bytes` and :func:`human_duration` write sizes and times for a
  person, as the estimates print them.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from typing import TYPE_CHECKING, Iterator

if TYPE_CHECKING:
    from tqdm import tqdm

_state = {"on": False, "force": False, "activities": []}


def enabled() -> bool:
    """Whether progress is shown: inside :func:`enable` with stderr a terminal, or as
    ``PHASEMAP_PROGRESS`` says."""
    env = os.environ.get("PHASEMAP_PROGRESS", "")
    if env == "always":
        return True
    if env == "never":
        return False
    return _state["on"] and (_state["force"] or _isatty(sys.stderr))


def wanted(show: bool | None = None) -> bool:
    """Whether a library call asked for ``progress=show`` shows it: as given, or
    (None) in an interactive session (stderr is a terminal).  ``PHASEMAP_PROGRESS``
    overrides both."""
    env = os.environ.get("PHASEMAP_PROGRESS", "")
    if env in ("always", "never"):
        return env == "always"
    if show is not None:
        return bool(show)
    return _isatty(sys.stderr)


def _isatty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # replaced or closed
        return False


def _delay() -> float:
    return 0.0 if os.environ.get("PHASEMAP_PROGRESS") == "always" else 1.0


@contextlib.contextmanager
def enable(on: bool = True, force: bool = False) -> Iterator[None]:
    """Show progress (on stderr) inside the block, where stderr is a terminal (anywhere
    with ``force``: a library call given ``progress=True``)."""
    before = _state["on"], _state["force"]
    _state["on"], _state["force"] = on, force
    try:
        yield
    finally:
        _state["on"], _state["force"] = before


def bar(total: int, desc: str, unit: str = "cell") -> "tqdm":
    """A progress bar on stderr; silent unless :func:`enabled`, shown after one second."""
    from tqdm import tqdm  # imported when a bar is made (tqdm costs a start-up 0.05 s)

    return tqdm(total=total, desc=desc, unit=unit, unit_scale=True, file=sys.stderr,
                delay=_delay(), disable=not enabled(), dynamic_ncols=True, leave=False,
                mininterval=0.2)


@contextlib.contextmanager
def activity(desc: str) -> Iterator[None]:
    """A ticking ``desc: elapsed`` line on stderr while the block runs (when enabled)."""
    if not enabled():
        yield
        return
    from tqdm import tqdm

    delay = _delay()
    line = tqdm(total=None, desc=desc, file=sys.stderr, delay=delay, leave=False,
                bar_format="{desc} [{elapsed}]", dynamic_ncols=True)
    stop = threading.Event()
    start = time.monotonic()

    def tick():
        while not stop.wait(0.5):
            if time.monotonic() - start >= delay:
                line.refresh()

    thread = threading.Thread(target=tick, daemon=True)
    _state["activities"].append(line)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        _state["activities"].remove(line)
        line.close()


def status(text: str) -> None:
    """Show ``text`` as what the innermost :func:`activity` is doing now."""
    if _state["activities"]:
        line = _state["activities"][-1]
        base = line.desc.split(": ", 1)[0]
        line.set_description_str(f"{base}: {text}", refresh=False)


def human_bytes(n: float) -> str:
    """A byte count for a person: 12 B, 3.4 MB, 2 TB (powers of 1000)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000:
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"


def human_duration(s: float) -> str:
    """A duration for a person: 0.25 s, 3.5 min, 2 h, 4.17 days."""
    if s < 60:
        return f"{s:.2g} s"
    if s < 3600:
        return f"{s / 60:.2g} min"
    if s < 86400 * 2:
        return f"{s / 3600:.2g} h"
    return f"{s / 86400:.3g} days"
