"""One memo for every cache of derived Python objects in a process.

phasemap derives much from a model once and looks it up after: its layer registry,
its compiled kernels, its conditions, the JSON of its description.  Every such cache
is a :class:`Memo`; a look-up is ``MEMO.get(owners, values, make)``:

* ``owners``: the objects the result is derived from, matched by identity (a model,
  a declaration, a condition module).  The entry holds them, so that their ``id`` can
  never be taken by a new object while the entry lives: two keys cannot collide;
* ``values``: hashable plain values the result also depends on (names, a kind, a
  numba signature);
* ``make()``: builds the result on a miss.

A memo made with ``replace=True`` keeps one entry per ``values`` and builds anew when
the owners differ (a reloaded declaration replaces the old model of the same name, and
the old one can be freed).  Without it, the key is the owners' identities with the
values, and entries stay for the life of the process (a process holds a handful of
models).  ``maxsize`` bounds a memo by dropping its oldest entry.

Look-ups are thread-safe: ``make()`` runs outside the lock, so two threads may both
build on a first miss; the first result stored wins and both return it.

>>> memo = Memo("squares")
>>> class Owner: pass
>>> a = Owner()
>>> memo.get((a,), (3,), lambda: 9), memo.get((a,), (3,), lambda: 0)
(9, 9)
>>> memo.get((Owner(),), (3,), lambda: 16)     # another owner: another entry
16
>>> len(memo)
2
"""

from __future__ import annotations

import threading
from typing import Callable, Hashable

#: Every memo made, by name (a reloaded module's memo replaces its old one):
#: :func:`clear_all` empties them.
MEMOS: dict[str, "Memo"] = {}


class Memo:
    """A cache of objects derived from ``owners`` (by identity) and ``values``."""

    def __init__(self, name: str, *, replace: bool = False, maxsize: int | None = None):
        self.name, self.replace, self.maxsize = name, replace, maxsize
        self._entries: dict[Hashable, tuple] = {}
        self._lock = threading.Lock()
        MEMOS[name] = self

    def _key(self, owners: tuple, values: tuple) -> Hashable:
        return values if self.replace else (tuple(map(id, owners)), values)

    def get(self, owners: tuple, values: tuple, make: Callable[[], object]):
        """The value derived from ``owners`` and ``values``, built by ``make()`` once."""
        key = self._key(owners, values)
        hit = self._entries.get(key)
        if hit is not None and len(hit[0]) == len(owners) and all(
                a is b for a, b in zip(hit[0], owners)):
            return hit[1]
        value = make()
        with self._lock:
            hit = self._entries.get(key)
            if hit is not None and all(a is b for a, b in zip(hit[0], owners)):
                return hit[1]  # another thread stored it first
            if self.maxsize is not None and len(self._entries) >= self.maxsize:
                self._entries.pop(next(iter(self._entries)))
            self._entries[key] = (tuple(owners), value)
        return value

    def __len__(self) -> int:
        return len(self._entries)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()


def clear_all() -> None:
    """Empty every memo of the process."""
    for memo in MEMOS.values():
        memo.clear()
