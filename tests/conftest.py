"""Shared test helpers: external checkers (cfchecks, ncdump)."""

from __future__ import annotations

import contextlib
import os
import pathlib
import shutil
import subprocess

import pytest

#: What each quick study run in this session produced: {study: (verdicts, figures)}.
#: The README's tour counts are checked against it once every study has run.
STUDY_RUNS: dict[str, tuple[list[str], int]] = {}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (``-n``, ``--dist loadgroup``), run each test module on one
    worker, so that a module's fixtures (its compiled kernels) are built once, and every
    study on the same worker, so that the tour counts see all of them (:data:`STUDY_RUNS`)."""
    studies = set()
    for item in items:
        module = item.nodeid.split("::")[0]
        group = "studies" if pathlib.Path(module).name.startswith("test_study_") else module
        item.add_marker(pytest.mark.xdist_group(group))
        if group == "studies":
            studies.add(item.nodeid)
    # the studies are the longest group: scheduled first, one worker runs them while the
    # other takes the rest, instead of one worker running them alone at the end
    items.sort(key=lambda item: item.nodeid not in studies)


def record_study(name: str, claims, out) -> None:
    # the tour's figures are the two-column ones; "_one_column" files are their narrow layouts
    figures = [p for p in pathlib.Path(out).glob("*.png") if not p.stem.endswith("_one_column")]
    STUDY_RUNS[name] = ([c.verdict for c in claims], len(figures))


def require_tool(name: str, install: str):
    """Skip a test locally when a command is missing; in CI (CI=true) fail instead."""
    if shutil.which(name) is None:
        message = f"{name} not installed ({install}): run .ci/system-deps"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


def cfchecks(path, folder) -> str:
    """Run cfchecks offline on ``path`` (as ``phasemap cfcheck`` does); return its report."""
    from phasemap.cfcheck import cfcheck

    require_tool("cfchecks", "pip install cfchecker; needs libudunits2-0")
    report, _ = cfcheck(path)
    assert "ERRORS detected" in report, report  # cfchecks ran to the end
    return report


def assert_atlas_round_trip(ds, folder, name: str = "atlas.nc") -> str:
    """Write ``ds`` with ``write_atlas``; it must read back identical and pass cfchecks cleanly."""
    import phasemap
    import xarray as xr

    path = phasemap.write_atlas(ds, folder / name)
    with xr.open_dataset(path) as back:
        back.load()
    xr.testing.assert_identical(back, ds)
    report = cfchecks(path, folder)
    assert "ERRORS detected: 0" in report and "WARNINGS given: 0" in report, report
    return report


@contextlib.contextmanager
def small_filesystem(folder: pathlib.Path, size: str, readonly: bool = False):
    """A real tmpfs of ``size`` mounted on ``folder`` (root only; skipped elsewhere)."""
    folder.mkdir()
    opts = f"size={size}" + (",ro" if readonly else "")
    mount = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(folder)],
                           capture_output=True, text=True)
    if mount.returncode != 0:
        message = f"cannot mount a tmpfs here: {mount.stderr.strip()}"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)
