"""The overview study (work-precision and a wheel fate map) runs in quick mode."""

from __future__ import annotations

import importlib.util
import pathlib
import warnings

import pytest
import xarray as xr
from conftest import STUDY_RUNS, record_study

import figure_review

import phasemap

STUDIES = pathlib.Path(__file__).resolve().parents[1] / "studies"


def test_overview_quick(tmp_path, capsys):
    spec = importlib.util.spec_from_file_location("overview", STUDIES / "overview.py")
    module = importlib.util.module_from_spec(spec)
    with warnings.catch_warnings(), figure_review.recording() as seen:
        spec.loader.exec_module(module)  # inside: the study binds save_figure by name
        warnings.simplefilter("error")
        claims = module.main(["--quick", "--out", str(tmp_path), "--size", "both"])
    # issue 11: the fate map states its parameters; work-precision panels are lettered
    assert set(seen) == {f"overview_{s}{w}" for s in ("work_precision", "wheel_fates")
                         for w in ("", "_one_column")}
    figure_review.check(seen, exempt_fixed={"overview_work_precision",
                                            "overview_work_precision_one_column"})
    wp = " ".join(seen["overview_work_precision"]["texts"])
    assert "fastest of 5 timing rounds" in wp and "SciPy DOP853" in wp
    record_study("overview", claims, tmp_path)
    assert [c.verdict for c in claims] == ["finding", "finding", "agrees", "agrees", "finding",
                                          "agrees"]
    printed = capsys.readouterr().out
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


def test_readme_tour_counts_are_the_studies_own():
    """The README's count of claims, verdicts and figures is what the studies give."""
    import re

    from phasemap.tour import ORDER

    missing = [n for n in ORDER if n not in STUDY_RUNS]
    if missing:
        pytest.skip(f"studies not run in this session: {', '.join(missing)}")
    verdicts = [v for n in ORDER for v in STUDY_RUNS[n][0]]
    figures = sum(STUDY_RUNS[n][1] for n in ORDER)
    readme = " ".join(" ".join((STUDIES.parent / page).read_text()   # README, studies page
                               for page in ("README.md", "docs/guide/studies.md")).split())
    count = {k: verdicts.count(k) for k in ("agrees", "erratum", "sharper", "finding")}
    assert (f"The quick tour checks {len(verdicts)} claims: {count['agrees']} agree, "
            f"{count['erratum']} confirm errata, {count['sharper']} is sharper and "
            f"{count['finding']} are findings") in readme
    assert re.search(rf"an overview, {figures} figures", readme)
