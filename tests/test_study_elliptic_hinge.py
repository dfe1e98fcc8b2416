"""The elliptic-pendulum and hinge-pendulum studies run in quick mode and check what they claim."""

from __future__ import annotations

import pytest
import xarray as xr

import figure_review


pytestmark = pytest.mark.slow

#: The verdict each claim must get, in the order the study checks them.
EXPECTED = {
    "elliptic_pendulum": [
        ("unique solution for f <= 2 (27)", "sharper"),
        ("xdot > 0, lambda_1 < 0 (28)", "agrees"),
        ("xdot < 0, lambda_1 < 0 (28)", "agrees"),
        ("lambda_k = 0 bounds the paradox regions", "agrees"),
        ("lambda = 0 (text after (28))", "erratum"),
        ("Q = g + l cos(phi) omega^2 < 0, f = 4", "finding"),
        ("a motion from a unique state hits a paradox", "finding"),
        ("at v = 0 sliding can cease (after (5))", "agrees"),
        ("elliptic_pendulum: no solution (xdot > 0) first exists (phasemap.threshold)", "agrees"),
    ],
    "hinge_pendulum": [
        ("stagnation zone (35), delta < l", "agrees"),
        ("stagnation zone for delta >= l", "finding"),
        ("delta > l, rest at phi = +-pi/2", "finding"),
        ("delta > l: no solution (after (33))", "erratum"),
        ("delta = l in motion (singular)", "finding"),
        ("delta/l = 1.5 over (phi, omega)", "agrees"),
        ("falling into (35) with omega = 0, the pendulum stops", "agrees"),
        ("g = 0: omega = omega0/(1 + omega0 k t) (36)", "agrees"),
        ("every motion ends at rest in the zone", "agrees"),
        ("hinge_pendulum: turning coefficient vanishes (phasemap.threshold)", "agrees"),
        ("hinge_pendulum: stagnation zone (omega = 0, delta = 0.5) ends (phasemap.threshold)",
         "agrees"),
    ],
}

#: Files each study must write (stems; every figure as .pdf and .png).
ATLASES = {
    "elliptic_pendulum": ["threshold_right", "threshold_left", "lambda_zero", "phi_omega_right",
                          "phi_omega_left", "paradox_motion", "stick_slip"],
    "hinge_pendulum": ["rest", "moving_phi_delta", "phi_omega_delta_above_l", "phase_curve_0",
                       "weightless_0", "weightless_1", "fates"],
}
FIGURES = {
    "elliptic_pendulum": ["phi_f", "phi_omega", "paradox_motion", "stick_slip"],
    "hinge_pendulum": ["rest", "moving", "phase_curves", "weightless", "fates"],
}


@pytest.fixture(scope="module", params=sorted(EXPECTED))
def run(request, studies):
    """One study's quick run (conftest): (name, claims, printed, folder, figures seen)."""
    r = studies(request.param)
    return r.name, r.claims, r.printed, r.out, r.seen


def test_claims_and_verdicts(run):
    name, claims, printed, _, _ = run
    assert [(c.claim, c.verdict) for c in claims] == EXPECTED[name]
    assert "DISAGREES" not in printed
    # the printed table: a header, a rule, then one row per claim ending in its verdict
    lines = printed.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("claim ") and
                line.rstrip().endswith("verdict"))
    rows = lines[head + 2:head + 2 + len(claims)]
    for claim, row in zip(claims, rows):
        assert row.startswith(claim.claim) and row.rstrip().endswith(claim.verdict), row
        assert claim.paper in row and claim.measured in row


def test_atlases_carry_provenance(run):
    name, _, printed, out, _ = run
    figure_review.check_atlases(name, ATLASES[name], printed, out)
    if name == "elliptic_pendulum":  # the threshold atlases span the paper's 2 and 2 sqrt 2
        with xr.open_dataset(out / f"{name}_threshold_right.nc") as ds:
            assert float(ds.f.min()) <= 2.0 and float(ds.f.max()) >= 2.9
    else:  # delta = l exactly is on the rest map's axis
        with xr.open_dataset(out / f"{name}_rest.nc") as ds:
            assert float(ds.attrs["phasemap_fixed_l"]) in ds.delta.values


def test_figures_written(run):
    name, _, printed, out, _ = run
    for stem in [s + w for s in FIGURES[name] for w in ("", "_one_column")]:
        pdf, png = out / f"{name}_{stem}.pdf", out / f"{name}_{stem}.png"
        assert pdf.read_bytes()[:5] == b"%PDF-"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert str(pdf) in printed and str(png) in printed
    # every file in the folder carries the study's prefix
    assert all(p.name.startswith(f"{name}_") for p in out.iterdir())


def test_figures_state_what_was_held_fixed_and_letter_their_panels(run):
    """Issue 11: each figure says g (and so the values held fixed), multi-panel figures are
    lettered, and no symbol is set upright outside mathtext."""
    name, _, _, _, seen = run
    assert set(seen) == {f"{name}_{stem}{w}" for stem in FIGURES[name]
                         for w in ("", "_one_column")}
    assert {what["width"] for what in seen.values()} == {3.5, 7.2}
    figure_review.check(seen)
