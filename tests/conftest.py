"""Shared test helpers: external checkers (cfchecks, ncdump)."""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest

CF_TABLES = {  # cfchecks reads these three tables; an atlas uses none of their names
    "cf_standard_names": "<standard_name_table><version_number>0</version_number>"
                         "<last_modified>none</last_modified></standard_name_table>",
    "area_types": "<area_type_table><version_number>0</version_number>"
                  "<date>none</date></area_type_table>",
    "region_names": "<standard_region_list><version_number>0</version_number>"
                    "<date>none</date></standard_region_list>",
}


def require_tool(name: str, install: str):
    """Skip a test locally when a command is missing; in CI (CI=true) fail instead."""
    if shutil.which(name) is None:
        message = f"{name} not installed ({install}): run .ci/system-deps"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


def cfchecks(path, folder) -> str:
    """Run cfchecks offline on ``path``; return its report (stdout and stderr)."""
    require_tool("cfchecks", "pip install cfchecker; needs libudunits2-0")
    # cfchecks downloads these tables by default; local stand-ins keep the
    # check offline and mean any standard_name, area_type or region used is an error
    tables = []
    for option, xml in CF_TABLES.items():
        (folder / f"{option}.xml").write_text(f'<?xml version="1.0"?>\n{xml}\n')
        tables += [f"--{option}", str(folder / f"{option}.xml")]
    run = subprocess.run(["cfchecks", "--version", "auto", *tables, str(path)],
                         capture_output=True, text=True, timeout=120)
    report = run.stdout + run.stderr
    assert run.returncode == 0, report
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
