"""What the machine can give this process: memory available now, and its own size.

The memory checks of every entry point (a scene's estimate, a long motion's saved
points) read these, so that what does not fit is refused or cut in one line instead
of ending in a ``MemoryError`` inside compiled code or the kernel's OOM killer.
"""

from __future__ import annotations

import contextlib
import math
import os
import pathlib
import time

#: The share of the available memory one call's saved results may take (a motion's
#: points, a phase curve's points): the rest is for the caller and the Dataset built.
MEMORY_SHARE = 0.5
#: How many copies of saved results may live at once: the compiled arrays while they
#: grow by doubling (the old and the new), and the Dataset's columns built from them.
MEMORY_COPIES = 4


def resident() -> int:
    """This process's resident memory now, in bytes (0 where it cannot tell)."""
    return _status("VmRSS:")


def _status(key: str) -> int:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(key):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


#: How long the machine's share of :func:`available_memory` (the kernel's and the
#: cgroup's figures) is answered again, in seconds: a map followed through contact
#: changes asks twice per cell (a ``simulate`` each), and reading those files took 22 us,
#: 3 % of such a cell.  The process's own address-space limit is read at every call (a
#: process that lowers it sees it at once).
FRESH = 0.1
_READING: list = [-math.inf, []]     # (when, what): the machine's last reading


def available_memory() -> int | None:
    """Memory the system can give this process now, in bytes: the kernel's
    ``MemAvailable``, less if a cgroup limits the process, less if the process's own
    address-space limit (``ulimit -v``, ``RLIMIT_AS``) leaves less room; None if unknown.
    The kernel's and the cgroup's figures are read at most every :data:`FRESH` seconds."""
    now = time.monotonic()
    when, machine = _READING
    if not now - when < FRESH:
        machine = _machine()
        _READING[:] = now, machine
    found = list(machine)
    with contextlib.suppress(ImportError, OSError, ValueError):
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            found.append(max(0, soft - _status("VmSize:")))
    if not found and hasattr(os, "sysconf"):
        with contextlib.suppress(OSError, ValueError):
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    return min(found) if found else None


def _machine() -> list[int]:
    """The machine's figures of :func:`available_memory`, read now: the kernel's
    ``MemAvailable`` and the cgroup's room (those it has)."""
    found = []
    with contextlib.suppress(OSError, ValueError, IndexError):
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    with contextlib.suppress(OSError, ValueError):
        limit = pathlib.Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = pathlib.Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if limit != "max":
            found.append(max(0, int(limit) - int(used)))
    return found
