"""The seeded fuzz of every public function and command (tests/fuzzing.py, issue 42), a
few hundred cases on the ladder and the hinge pendulum, whose kernels the suite compiles
anyway.  ``benchmarks/fuzz.py`` runs thousands on every model and records the counts in
BENCHMARKS.md."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import phasemap

import fuzzing

#: compiles the hinge pendulum's phase-curve tracer, as tests/test_phase_curve.py does
XDIST_GROUP = "tests/test_phase_curve.py"


@pytest.fixture(scope="module")
def atlas(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    ds = phasemap.Scene("ladder", axes={"phi": np.linspace(0.1, 1.4, 6),
                                        "f": np.linspace(0.0, 2.0, 5)}).compute()
    return folder, phasemap.write_atlas(ds, folder / "ladder.nc")


@pytest.mark.parametrize("seed", [1, 2])
def test_every_entry_point_answers_or_refuses_in_one_line(atlas, seed):
    folder, path = atlas
    tally = fuzzing.run(250, seed, ["hinge_pendulum", "ladder"], folder, path,
                        heavy=seed == 1, slices=["ladder"])
    assert tally.calls == 250
    assert not tally.failures, "\n".join(tally.failures[:20])
    # every kind of case was drawn, and the fuzz both refused and answered
    assert {"classify", "Scene", "simulate", "phase_curve", "boundaries", "threshold",
            "open_atlas"} <= set(tally.entries()), tally.entries()
    assert any(e.startswith("phasemap ") for e in tally.entries())
    assert sum(tally.refused.values()) > 50 and sum(tally.answered.values()) > 50


def test_the_fuzz_can_fail():
    """A refusal that does not name its argument, an exception of another kind and an
    answer with a NaN solution are each recorded as failures."""
    tally = fuzzing.Tally()

    def unnamed():
        raise ValueError("something is wrong")

    def other():
        raise KeyError("phi")

    fuzzing._judge(tally, "classify", "phi", 1.0, unnamed)
    fuzzing._judge(tally, "classify", "phi", 1.0, other)
    fuzzing._judge(tally, "phasemap atlas", "argv", ["x"],
                   lambda: (2, "", "Traceback (most recent call last):\n  ..."))
    fuzzing._judge(tally, "phasemap atlas", "argv", ["x"], lambda: (2, "", "oops\n"))
    fuzzing._judge(tally, "classify", "phi", 1.0, lambda: phasemap.classify("ladder"))
    good = phasemap.classify("ladder")
    branch = dataclasses.replace(good.branches[0], accelerations={"phi_ddot": math.nan})
    fuzzing._judge(tally, "classify", "phi", 1.0,
                   lambda: dataclasses.replace(good, branches=(branch,)))
    # "f" is not named by a message about omega being finite
    fuzzing._judge(tally, "classify", "f", 1.0,
                   lambda: (_ for _ in ()).throw(ValueError("omega must be finite")))
    assert len(tally.failures) == 6, tally.failures
    assert "non-finite" in tally.failures[4] and "does not name 'f'" in tally.failures[5]
    assert tally.calls == 7
