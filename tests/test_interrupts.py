"""numba's compile events: a Ctrl-C during a first compile ends the call (issue 44), never
lost inside LLVM's callbacks into Python (phasemap.core.interrupts); and the time numba
compiles is counted (phasemap.core.compiletime, issue 40)."""

from __future__ import annotations

import subprocess
import sys

import pytest

CHILD = """
import os, signal, sys, time
import numba.core.codegen as c

# the object-file hook LLVM calls back through ctypes: deliver SIGINT exactly there
orig = c.CPUCodeLibrary._object_compiled_hook.__func__
FIRED = []
def hook(cls, ll_module, buf):
    if not FIRED:
        FIRED.append(1)
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(10000))  # Python runs the handler here, inside the callback
    return orig(cls, ll_module, buf)
c.CPUCodeLibrary._object_compiled_hook = classmethod(hook)
if sys.argv[1] == "phasemap":
    import phasemap  # noqa: F401 - installs phasemap.core.interrupts
from numba import njit

@njit
def f(x):
    return x + 1

try:
    f(1)
    for _ in range(100):
        time.sleep(0.01)
    print("finished", len(FIRED))
except KeyboardInterrupt:
    print("interrupted", len(FIRED))
"""


@pytest.mark.parametrize("mode, expected", [("plain", "finished 1"),
                                            ("phasemap", "interrupted 1")])
def test_a_ctrl_c_inside_llvms_callback_is_raised_not_lost(mode, expected, tmp_path):
    """Without phasemap, numba loses the KeyboardInterrupt ("Exception ignored in") and
    the program runs on (the control: it shows the test can fail); with phasemap
    imported the interrupt is raised once the callback has returned."""
    done = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True,
                          text=True, timeout=300, env={"NUMBA_CACHE_DIR": str(tmp_path),
                                                       "PATH": "/usr/bin:/bin"})
    assert done.stdout.strip().splitlines()[-1] == expected, done.stderr[-2000:]


def test_handlers_are_restored_after_the_compile():
    import signal

    from phasemap.core import interrupts

    before = signal.getsignal(signal.SIGINT)
    interrupts._start()
    during = signal.getsignal(signal.SIGINT)
    interrupts._start()  # nested compiles
    interrupts._end()
    assert signal.getsignal(signal.SIGINT) is during
    interrupts._end()
    assert signal.getsignal(signal.SIGINT) is before
    if callable(before):
        assert getattr(during, "phasemap_wraps", None) is before


def test_compile_time_counts_outermost_compiles_only():
    """A function that calls another: one outermost compile, timed once; a second call
    compiles nothing."""
    import time

    from numba import njit

    import phasemap  # noqa: F401 - installs the listener
    from phasemap.core import compiletime

    @njit
    def inner(x):
        return x * 2.0

    @njit
    def outer(x):
        return inner(x) + 1.0

    n0, s0 = compiletime.count(), compiletime.seconds()
    t0 = time.perf_counter()
    assert outer(1.0) == 3.0
    wall = time.perf_counter() - t0
    assert compiletime.count() == n0 + 1
    assert 0.0 < compiletime.seconds() - s0 <= wall
    assert outer(2.0) == 5.0
    assert compiletime.count() == n0 + 1
