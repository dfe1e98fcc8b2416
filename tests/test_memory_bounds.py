"""A long motion cannot take the machine's memory (issue 42 item 1): under an address-space
limit, ``simulate`` with limits that would save billions of points stops where its
saved points still fit, says so in one line, and keeps what it computed."""

from __future__ import annotations

import json
import subprocess
import sys

import phasemap


def _child(code: str) -> dict:
    """Run ``code`` in a fresh interpreter (the suite's kernel cache inherited) and return
    the JSON of its last line."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


LIMIT = """
import json, resource, warnings
import numpy as np
import phasemap

def limit(margin_mib):
    vm = int([l for l in open("/proc/self/status") if l.startswith("VmSize")][0].split()[1])
    resource.setrlimit(resource.RLIMIT_AS, (vm * 1024 + margin_mib * 2 ** 20,
                                            resource.RLIM_INFINITY))

def refused(call):
    try:
        call()
    except ValueError as err:
        return str(err)
    return None
"""

CHILD = LIMIT + """
phasemap.simulate("hinge_pendulum", 1.0, phi=2.5, omega=0.0)      # compiled (or loaded) first
limit(600)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    ds = phasemap.simulate("hinge_pendulum", 1e7, phi=2.5, omega=0.0, delta=0.0,
                           max_steps=10 ** 12, max_events=10 ** 12)
print(json.dumps({"end": ds.attrs["end_reason"], "message": ds.attrs["end_message"],
                  "points": ds.sizes["t"], "t_last": float(ds.t[-1]),
                  "warnings": [str(w.message) for w in caught]}))
"""


def test_a_long_motion_under_a_memory_limit_stops_cleanly():
    got = _child(CHILD)
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


def test_the_machines_memory_is_read_again_after_a_moment_the_process_limit_at_every_call(
        monkeypatch):
    """The kernel's and the cgroup's figures are answered again for FRESH seconds (a map
    followed through contact changes asks twice a cell); the process's own address-space
    limit is read at every call, so a limit set a moment after a reading holds at once."""
    import math
    import resource
    import time

    from phasemap.core import resources

    reads = []

    def machine():
        reads.append(1)
        return [10 ** 15]

    monkeypatch.setattr(resources, "_machine", machine)
    monkeypatch.setattr(resources, "_READING", [-math.inf, []])
    monkeypatch.setattr(resources, "FRESH", 3600.0)     # (however slow the machine)
    unlimited = (resource.RLIM_INFINITY, resource.RLIM_INFINITY)
    monkeypatch.setattr(resource, "getrlimit", lambda which: unlimited)
    assert resources.available_memory() == resources.available_memory() == 10 ** 15
    assert len(reads) == 1
    resources._READING[0] = time.monotonic() - resources.FRESH
    resources.available_memory()
    assert len(reads) == 2
    # a limit the process sets after the reading: seen by the next call, not FRESH later
    monkeypatch.setattr(resource, "getrlimit", lambda which: (resources._status("VmSize:")
                                                              + 12345, unlimited[1]))
    assert 0 < resources.available_memory() <= 12345 + 2 ** 20 and len(reads) == 2


CURVE = LIMIT + """
kw = dict(phi=2.5, omega=0.0, delta=0.0)
phasemap.phase_curve("hinge_pendulum", max_stages=2, **kw)     # compiled (or loaded) first
limit(600)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    ds = phasemap.phase_curve("hinge_pendulum", max_stages=10 ** 9, points_per_stage=10 ** 5,
                              **kw)
limit(100)
one_stage = refused(lambda: phasemap.phase_curve("hinge_pendulum", points_per_stage=10 ** 6,
                                                 **kw))
print(json.dumps({"end": ds.attrs["end_reason"], "message": ds.attrs["end_message"],
                  "stages": ds.sizes["stage"], "points": ds.sizes["point"],
                  "reversals": int(ds.attrs["n_reversals"]), "one_stage": one_stage,
                  "warnings": [str(w.message) for w in caught]}))
"""


def test_a_phase_curve_of_endless_stages_under_a_memory_limit_stops_cleanly():
    """The frictionless hinge pendulum reverses for ever: asked for 10^9 stages of 10^5
    points (2.4 PB) under a 600 MiB limit, the curve stops where its points still fit,
    says so and keeps what it traced; a single stage that cannot fit is refused."""
    phase_curve = phasemap.phase_curve
    phase_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.0, max_stages=2)
    got = _child(CURVE)
    assert got["end"] == "max_events"
    assert "not fit in the memory available" in got["message"]
    assert "points_per_stage" in got["message"] and "\n" not in got["message"]
    assert any("not fit in the memory available" in w for w in got["warnings"])
    # 600 MiB at 4 copies in half of it: about 30 stages of 2.4 MB; every one traced whole
    assert 5 <= got["stages"] <= 200 and got["points"] == got["stages"] * 10 ** 5
    assert got["reversals"] == got["stages"] - 1
    assert got["one_stage"] is not None and "points_per_stage" in got["one_stage"]
    assert got["one_stage"].startswith("hinge_pendulum: ") and "\n" not in got["one_stage"]


def test_a_phase_curve_that_fits_is_not_cut():
    from phasemap.motion.phase import _stage_cap

    m = phasemap.get_model("hinge_pendulum")
    assert _stage_cap(m, 50, 200) is None
    assert _stage_cap(m, 2 ** 31 - 1, 10 ** 6) is not None


MAPS = LIMIT + """
limit(300)
fate = refused(lambda: phasemap.Scene(
    "hinge_pendulum", axes={"phi": np.linspace(-3, 3, 40000), "omega": np.linspace(-6, 6, 40000)},
    layers=["fate", "t_final", "phi_rest"]).compute())
grid = refused(lambda: phasemap.Scene(
    "ladder", axes={"phi": np.linspace(0.1, 1.5, 50000), "f": np.linspace(0, 3, 50000)},
    fixed={"omega": 0.0}).compute())
print(json.dumps({"fate": fate, "grid": grid}))
"""


def test_maps_and_fate_maps_too_large_for_memory_are_refused_before_any_work():
    """1.6e9 fate cells and 2.5e9 map cells under a 300 MiB limit: one line each that says
    how much is needed and what to do, before anything is compiled or allocated."""
    got = _child(MAPS)
    for key, model in (("fate", "hinge_pendulum"), ("grid", "ladder")):
        text = got[key]
        assert text is not None and text.startswith(f"{model}: ") and "\n" not in text, text
        assert "more memory" in text and "chunks=" in text, text


BATCH = LIMIT + """
kw = dict(xdot=0.0, f=0.0)
phasemap.simulate("elliptic_pendulum", 0.1, phi=[0.1, 0.2], **kw)  # compiled (or loaded)
limit(600)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    ds = phasemap.simulate("elliptic_pendulum", 1e7, phi=[1.0, 1.1, 1.2],
                           max_steps=10 ** 12, max_events=10 ** 12, **kw)
print(json.dumps({"ends": [str(e) for e in ds.end_reason.values],
                  "starts": ds.sizes["start"],
                  "warnings": [str(w.message) for w in caught]}))
"""


def test_a_batch_of_endless_motions_under_a_memory_limit_stops_cleanly():
    """Three frictionless elliptic pendulums for 10^7 s in one call: each stops where the
    three motions' points still fit together, and one warning says why."""
    got = _child(BATCH)
    assert got["starts"] == 3
    cut = {str(int(phasemap.Event.MAX_STEPS)), str(int(phasemap.Event.MAX_EVENTS))}
    assert set(got["ends"]) <= cut, got["ends"]
    assert any("what their saved points can hold in memory" in w for w in got["warnings"])
