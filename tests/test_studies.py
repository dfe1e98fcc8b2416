"""Study scripts run in quick mode in a temporary folder and check what they claim."""

from __future__ import annotations

import importlib.util
import pathlib

import xarray as xr

STUDIES = pathlib.Path(__file__).resolve().parents[1] / "studies"


def load(name):
    spec = importlib.util.spec_from_file_location(name, STUDIES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_elliptic_threshold_study(tmp_path, capsys):
    rows = load("elliptic_threshold").main(["--quick", "--out", str(tmp_path)])
    assert [r[3] for r in rows] == ["sharp at 2 sqrt 2", "sharp at 2 sqrt 2", "agrees"]
    assert "sharp threshold 2 sqrt 2 = 2.8284" in capsys.readouterr().out
    for side in ("left", "right"):
        with xr.open_dataset(tmp_path / f"elliptic_threshold_{side}.nc") as ds:
            assert ds.attrs["phasemap_model"] == "elliptic_pendulum" and "phasemap_version" in ds.attrs
