"""The ladder and wheel studies run in quick mode, write their files and check what they claim.

Each study runs once per module (about 10 s each), in a temporary folder, with
every warning an error, so the figures render without warnings, at both widths
(``--size both``); each figure's layout is reviewed at its printed size.
"""

from __future__ import annotations

import pytest
import xarray as xr

import figure_review

from phasemap.study import VERDICTS

pytestmark = pytest.mark.slow

#: Files each study writes, by stem: which suffixes.
FILES = {
    "ladder": {"ladder_solvability": ("nc", "pdf", "png"),
               "ladder_portraits": ("nc", "pdf", "png"),
               "ladder_errata": ("nc",),
               "ladder_first_integral": ("pdf", "png")},
    "wheel": {"wheel_stagnation": ("nc",), "wheel_bounce": ("nc",),
              "wheel_maps": ("pdf", "png"), "wheel_portraits": ("pdf", "png"),
              "wheel_fates": ("nc", "pdf", "png"), "wheel_fates_one_way": ("nc",),
              "wheel_singular": ("nc",)},
}

#: The verdict expected of each claim, in the order the study checks them (claim prefix).
EXPECTED = {
    "ladder": [
        ("ladder: coefficient 2 - f^2 of (8) vanishes", "agrees"),
        ("ladder: at f = sqrt 2 (8) has no solution", "agrees"),
        ("ladder: (8), both contacts kept, solvable for phi'' when f != sqrt 2",
         "agrees"),
        ("ladder: static zone at omega = 0, f < 1", "finding"),
        ("ladder: static zone at omega = 0, f >= 1", "finding"),
        ("ladder: the phase curves stop only in the static zone", "finding"),
        ("ladder (8) at l = 0.5", "erratum"),
        ("ladder N1, N2 after (7) at m = 2", "erratum"),
        ("ladder first integral, b", "erratum"),
        ("ladder first integral, a and b", "erratum"),
        ("ladder: (8) has a first integral", "agrees"),
        ("ladder: slide coefficient vanishes (phasemap.threshold)", "agrees"),
        ("ladder: static zone (omega = 0, f = 0.5) ends (phasemap.threshold)", "agrees"),
    ],
    "wheel": [
        ("wheel: stagnation zone (15)", "agrees"),
        ("wheel: delta >= l, zone (15) covers all positions", "agrees"),
        ("wheel, delta/l = 0.1: damped oscillation", "agrees"),
        ("wheel, delta/l = 0.1: phase curve = time integration", "agrees"),
        ("wheel, delta/l = 1.2 >= 1: moves one way", "agrees"),
        ("wheel: no-bounce condition (12)", "agrees"),
        ("wheel (13): sign of the omega^2 term", "erratum"),
        ("wheel fate map, delta/l = 0.1: stops after a reversal", "agrees"),
        ("wheel fate maps: no Painleve state of (13), the rolling contact kept, on "
         "any motion", "agrees"),
        ("wheel fate map, delta/l = 1.2: no reversal", "agrees"),
        ("wheel: bracket of (13) can vanish", "finding"),
        ("wheel: (13) has no solution where its bracket vanishes", "agrees"),
        ("wheel: singular bracket first vanishes (phasemap.threshold)", "agrees"),
    ],
}


#: Every figure is drawn at both widths: ``stem.png`` (7.2 in) and ``stem_one_column.png``.
for _files in FILES.values():
    for _stem, _exts in list(_files.items()):
        if "png" in _exts:
            _files[f"{_stem}_one_column"] = ("pdf", "png")


@pytest.fixture(scope="module", params=["ladder", "wheel"])
def run(request, studies):
    """(name, folder, claims, printed output, figures seen) of one quick run (conftest)."""
    r = studies(request.param)
    return r.name, r.out, r.claims, r.printed, r.seen


def test_files(run):
    name, out, _, printed, _ = run
    expected = {f"{stem}.{ext}" for stem, exts in FILES[name].items() for ext in exts}
    assert {p.name for p in out.iterdir()} == expected
    for file in expected:
        assert str(out / file) in printed  # finish() lists every file written
    for stem, exts in FILES[name].items():
        if "nc" in exts:
            with xr.open_dataset(out / f"{stem}.nc") as ds:
                assert ds.attrs["phasemap_study"] == name
                assert ds.attrs["phasemap_model"] == name
                assert ds.attrs["phasemap_version"]
                assert ds.data_vars
        if "pdf" in exts:
            assert (out / f"{stem}.pdf").read_bytes()[:5] == b"%PDF-"
            assert (out / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_verdicts(run):
    name, _, claims, printed, _ = run
    assert all(c.verdict in VERDICTS for c in claims)
    got = [(c.claim, c.verdict) for c in claims]
    assert len(got) == len(EXPECTED[name]), got
    for (claim, verdict), (prefix, expected) in zip(got, EXPECTED[name]):
        assert claim.startswith(prefix), (claim, prefix)
        assert verdict == expected, (claim, verdict, [c for c in claims if c.claim == claim])
    assert "DISAGREES" not in printed


def test_claims_table_printed(run):
    """The table printed at the end has a row per claim: measured beside paper, verdict."""
    _, _, claims, printed, _ = run
    table = printed[printed.index("claim "):]
    header = table.splitlines()[0].split()
    assert header == ["claim", "paper", "measured", "verdict"]
    for c in claims:
        row = next(line for line in table.splitlines() if line.startswith(c.claim))
        assert c.paper in row and c.measured in row and row.rstrip().endswith(c.verdict)


def test_figures_state_what_was_held_fixed_and_letter_their_panels(run):
    """Issue 11: each figure says g (and so the values held fixed), multi-panel figures are
    lettered, and no symbol is set upright outside mathtext."""
    name, _, _, _, seen = run
    assert set(seen) == {stem for stem, exts in FILES[name].items() if "png" in exts}
    assert {what["width"] for what in seen.values()} == {3.5, 7.2}
    figure_review.check(seen)
