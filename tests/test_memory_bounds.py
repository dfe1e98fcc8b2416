"""A long motion cannot take the machine's memory (issue 42 item 1): under an address-space
limit, ``simulate`` with limits that would save billions of points stops where its
saved points still fit, says so in one line, and keeps what it computed."""

from __future__ import annotations

import json
import subprocess
import sys

import phasemap

CHILD = """
import json, resource, warnings
import phasemap
phasemap.simulate("hinge_pendulum", 1.0, phi=2.5, omega=0.0)      # compiled (or loaded) first
vm = int([l for l in open("/proc/self/status") if l.startswith("VmSize")][0].split()[1]) * 1024
resource.setrlimit(resource.RLIMIT_AS, (vm + 600 * 2 ** 20, resource.RLIM_INFINITY))
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    ds = phasemap.simulate("hinge_pendulum", 1e7, phi=2.5, omega=0.0, delta=0.0,
                           max_steps=10 ** 12, max_events=10 ** 12)
print(json.dumps({"end": ds.attrs["end_reason"], "message": ds.attrs["end_message"],
                  "points": ds.sizes["t"], "t_last": float(ds.t[-1]),
                  "warnings": [str(w.message) for w in caught]}))
"""


def test_a_long_motion_under_a_memory_limit_stops_cleanly():
    done = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert got["end"] in ("max_steps", "max_events")
    assert "not fit in the memory available" in got["message"] and "t_eval" in got["message"]
    assert "\n" not in got["message"]
    assert any("not fit in the memory available" in w for w in got["warnings"])
    assert 10 ** 5 < got["points"] < 10 ** 8 and got["t_last"] > 1000.0


def test_a_motion_that_fits_is_not_cut():
    """The default limits fit: nothing is lowered, and the motion is what it always was."""
    from phasemap.motion.simulate import _memory_cap, Options

    opts = Options().checked("hinge_pendulum")
    assert _memory_cap(phasemap.get_model("hinge_pendulum"), opts, 2, True, 0) is None
    ds = phasemap.simulate("hinge_pendulum", 10.0, phi=2.5, omega=0.0, delta=0.1)
    assert ds.attrs["end_reason"] == "rest"


def test_a_batch_shares_the_memory_among_its_starts():
    """Three starts at once hold three motions' points: each gets a third of the room."""
    from phasemap.motion.simulate import Options, _memory_cap
    from phasemap.core import resources

    m = phasemap.get_model("hinge_pendulum")
    opts = Options(max_steps=10 ** 12, max_events=10 ** 12).checked(m.name)
    one = _memory_cap(m, opts, 2, True, 0, 1)
    three = _memory_cap(m, opts, 2, True, 0, 3)
    assert one is not None and three is not None
    assert three[0] * 3 <= one[0] * 1.01 and three[0] * 3 >= one[0] * 0.98
    assert resources.available_memory() > 0
