"""The rod-on-a-step study runs in quick mode, every claim agrees and its figures pass review."""

from __future__ import annotations

import pytest

import figure_review

pytestmark = pytest.mark.slow
NAME = "rod_on_step"

#: The verdict each claim must get, in the order the study checks them.
EXPECTED = [
    ("(S3) is the kept-kept coefficient", "agrees"),
    ("kept-kept coefficient first vanishes (omega < 0)", "agrees"),
    ("no geometry is singular below f*", "agrees"),
    ("at theta*, h* the count stays 1 across f*", "agrees"),
    ("omega = -1: no solution where the floor-only rod is singular", "finding"),
    ("omega < 0: smallest f of a paradox on the map", "finding"),
    ("omega = +1: no solution where (S3) < 0", "finding"),
    ("three solutions (f = 1.3, h/l = 1.59, theta = 1.128, omega = -2.7)", "agrees"),
    ("rest at h/l = 1.5749: stagnation region", "finding"),
    ("rest and sliding from rest coexist (f = 0.5, h/l = 0.60257)", "agrees"),
    ("rest at h/l = 0.6: rest and sliding from rest", "finding"),
    ("the rod slides down from rest off the step", "finding"),
    ("the motion ends where the rod leaves the step", "finding"),
]
ATLASES = ["motion", "omega_scan", "rest", "rest_low_step", "slide"]
FIGURES = ["rest", "motion", "slide"]


@pytest.fixture(scope="module")
def run(studies):
    """The study's quick run (conftest): (claims, printed, folder, figures seen)."""
    r = studies(NAME)
    return r.claims, r.printed, r.out, r.seen


def test_claims_and_verdicts(run):
    claims, printed, _, _ = run
    assert [(c.claim, c.verdict) for c in claims] == EXPECTED
    assert "DISAGREES" not in printed


def test_atlases_carry_provenance(run):
    _, printed, out, _ = run
    figure_review.check_atlases(NAME, ATLASES, printed, out)


def test_figures_written_and_reviewed_at_both_widths(run):
    _, printed, out, seen = run
    for stem in [s + w for s in FIGURES for w in ("", "_one_column")]:
        pdf, png = out / f"{NAME}_{stem}.pdf", out / f"{NAME}_{stem}.png"
        assert pdf.read_bytes()[:5] == b"%PDF-"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert str(png) in printed
    assert all(p.name.startswith(f"{NAME}_") for p in out.iterdir())
    assert set(seen) == {f"{NAME}_{s}{w}" for s in FIGURES for w in ("", "_one_column")}
    assert {what["width"] for what in seen.values()} == {3.5, 7.2}
    figure_review.check(seen)
