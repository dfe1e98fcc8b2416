"""The overview study (work-precision and a wheel fate map) runs in quick mode."""

from __future__ import annotations

import pytest
import xarray as xr
from conftest import STUDIES

import figure_review

import phasemap

pytestmark = pytest.mark.slow


def test_overview_quick(studies):
    run = studies("overview")
    seen, claims, tmp_path = run.seen, run.claims, run.out
    # issue 11: the fate map states its parameters; work-precision panels are lettered
    assert set(seen) == {f"overview_{s}{w}" for s in ("work_precision", "wheel_fates")
                         for w in ("", "_one_column")}
    figure_review.check(seen, exempt_fixed={"overview_work_precision",
                                            "overview_work_precision_one_column"})
    wp = " ".join(seen["overview_work_precision"]["texts"])
    assert "fastest of 5 timing rounds" in wp and "SciPy DOP853" in wp
    assert [c.verdict for c in claims] == ["finding", "finding", "agrees", "agrees", "finding",
                                          "agrees"]
    printed = run.printed
    assert "verdict" in printed and "DISAGREES" not in printed
    for stem in ("overview_work_precision", "overview_wheel_fates"):
        assert (tmp_path / f"{stem}.pdf").stat().st_size > 0
        assert (tmp_path / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = (tmp_path / "overview_work_precision.md").read_text()
    assert "| hinge_weightless | phasemap |" in table and "| hinge_pendulum | DOP853 |" in table
    with xr.open_dataset(tmp_path / "overview_wheel_fates.nc") as ds:
        assert ds.attrs["phasemap_study"] == "overview" and ds.phasemap.kind == "fate"
        assert set(np_unique(ds.fate)) <= {int(phasemap.Event.REST),
                                           int(phasemap.Event.CONTACT_LOST),
                                           int(phasemap.Event.NO_SOLUTION)}


def np_unique(a):
    import numpy as np

    return np.unique(a.values).tolist()


def test_readme_tour_counts_are_the_studies_own(studies):
    """The README's count of claims, verdicts and figures is what the studies give (each
    study runs once per session: the study modules share these runs)."""
    import re

    from phasemap.tour import ORDER

    runs = [studies(n) for n in ORDER]
    verdicts = [c.verdict for r in runs for c in r.claims]
    figures = sum(r.figures for r in runs)
    readme = " ".join(" ".join((STUDIES.parent / page).read_text()   # README, studies page
                               for page in ("README.md", "docs/guide/studies.md")).split())
    count = {k: verdicts.count(k) for k in ("agrees", "erratum", "sharper", "finding")}
    assert (f"The quick tour checks {len(verdicts)} claims: {count['agrees']} agree, "
            f"{count['erratum']} confirm errata, {count['sharper']} is sharper and "
            f"{count['finding']} are findings") in readme
    assert re.search(rf"an overview, {figures} figures", readme)


def test_one_layer_has_one_label_across_the_tour(studies):
    """The referee read the tour's figures together: ``n_reversals`` was "Reversals
    before rest" in the wheel's fate figure and its long name in the hinge pendulum's
    map.  Each study's review checks its own figures; this checks them all."""
    from phasemap.tour import ORDER

    labels = {f"{n}/{fig}": what["layers"] for n in ORDER
              for fig, what in studies(n).seen.items()}
    assert any(layer == "n_reversals" for pairs in labels.values() for layer, _ in pairs)
    assert figure_review.layer_label_problems(labels) == []
