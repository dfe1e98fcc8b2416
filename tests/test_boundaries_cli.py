"""phasemap boundaries and phasemap threshold on the command line."""

from __future__ import annotations

import math
import subprocess
import sys

import xarray as xr

PHASEMAP = [sys.executable, "-m", "phasemap.cli"]
ROD = ["--set", "xdot=-1", "--set", "omega=0"]


def run(*args):
    return subprocess.run(PHASEMAP + list(args), capture_output=True, text=True, timeout=900)


def test_threshold_prints_value_point_and_condition():
    r = run("threshold", "painleve_rod", "f", "--over", "theta=0.1:1.5", *ROD)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert abs(float(lines[0].split(">=")[1]) - 4 / 3) <= 1e-13
    theta = float(lines[1].split("theta = ")[1].split(",")[0])
    assert abs(theta - math.atan(2)) <= 1e-13
    assert "fold_f of coef_A_slip_neg" in lines[2]


def test_threshold_of_an_empty_region_and_a_bad_range():
    r = run("threshold", "painleve_rod", "f", "--over", "theta=0.1:1.5", "--set", "xdot=1",
            "--set", "omega=0")
    assert r.returncode == 0 and "nowhere in the ranges given" in r.stdout
    r = run("threshold", "painleve_rod", "f", "--over", "theta=1.5", *ROD)
    assert r.returncode == 2 and "--over expects NAME=LO:HI" in r.stderr


def test_boundaries_writes_the_pieces(tmp_path):
    out = tmp_path / "rod.nc"
    r = run("boundaries", "painleve_rod", "--axis", "theta=0.2:1.5", "--axis", "f=0:3", *ROD,
            "-o", str(out))
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        fold = ds.point_kind.values == "fold_f"
        assert abs(float(ds.point_f.values[fold][0]) - 4 / 3) <= 1e-10
    assert "fold_f" in r.stdout and "theta = 1.10714871779" in r.stdout


def test_boundaries_without_two_axes_names_them_and_gives_the_models_as_an_example(tmp_path):
    """A first try without --axis (or with one) is one line that says what to add, with
    the model's default axes to copy; nothing is written."""
    for axes, got in (([], "got 0"), (["--axis", "phi=0:1"], "got 1 (phi)")):
        r = run("boundaries", "ladder", *axes, "-o", str(tmp_path / "l.nc"))
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert r.stderr.strip().splitlines()[-1] == (
            f"phasemap: error: ladder: the slice needs two axes, --axis NAME=LO:HI twice; "
            f"{got}, e.g. --axis phi=0:1.5708 --axis f=0:3 (ladder's default axes)")
    assert not (tmp_path / "l.nc").exists()


def test_info_and_plot_take_a_boundaries_file(tmp_path):
    """``info`` called a boundaries file an atlas ("cells 303 = 101 vertex x ..."), and
    ``plot`` refused it (issue 41 item 2)."""
    out = tmp_path / "rod.nc"
    assert run("boundaries", "painleve_rod", "--axis", "theta=0.2:1.5", "--axis", "f=0:3",
               *ROD, "-o", str(out)).returncode == 0
    info = run("info", str(out))
    assert info.returncode == 0, info.stderr
    assert info.stdout.startswith(f"phasemap boundaries {out}") and "cells" not in info.stdout
    assert "over theta and f" in info.stdout and "fold_f 1" in info.stdout
    assert "coef_A_slip_neg" in info.stdout
    drawn = run("plot", str(out), "-o", str(tmp_path / "fig"))
    assert drawn.returncode == 0, drawn.stderr
    assert (tmp_path / "fig.png").stat().st_size > 10_000
