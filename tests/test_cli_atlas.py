"""The phasemap command line, end to end in a temporary folder, as a new user runs it."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
import xarray as xr

PHASEMAP = [sys.executable, "-m", "phasemap.cli"]


def run(*args, cwd=None):
    return subprocess.run(PHASEMAP + list(args), capture_output=True, text=True, cwd=cwd,
                          timeout=300)


def test_atlas_then_info(tmp_path):
    out = tmp_path / "elliptic.nc"
    r = run("atlas", "elliptic_pendulum", "--axis", "phi=-3.1416:3.1416:64",
            "--axis", "f=0:6:32", "--set", "xdot=1", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert f"wrote {out}" in r.stdout and "2048 cells" in r.stdout
    with xr.open_dataset(out) as ds:
        assert ds.n_solutions.dims == ("phi", "f") and ds.attrs["phasemap_fixed_xdot"] == 1.0
        counts = {int(k): int((ds.n_solutions == k).sum()) for k in (0, 1, 2)}
    assert counts[0] > 0 and counts[2] > 0  # the paradoxes are on this map
    info = run("info", str(out))
    assert info.returncode == 0, info.stderr
    assert "elliptic_pendulum" in info.stdout and "2048 = 64 phi x 32 f" in info.stdout
    assert re.search(rf"none\s+0\s+{counts[0]}\s", info.stdout), info.stdout
    assert re.search(rf"two\s+2\s+{counts[2]}\s", info.stdout), info.stdout


def test_fixing_a_default_axis_drops_it(tmp_path):
    r = run("atlas", "ladder", "--set", "f=2", "-o", "l.nc", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(tmp_path / "l.nc") as ds:
        assert ds.n_solutions.dims == ("phi",) and ds.attrs["phasemap_fixed_f"] == 2.0


def test_atlas_on_built_in_defaults(tmp_path):
    r = run("atlas", "hinge_pendulum", "-o", "hinge.nc", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(tmp_path / "hinge.nc") as ds:
        assert dict(ds.sizes) == {"phi": 512, "delta": 512}
        assert set(ds.data_vars) == {"n_solutions", "stagnation"}


def test_block_by_block_writing_equals_the_eager_atlas(tmp_path):
    args = ["atlas", "wheel", "--axis", "phi=-3:3:50", "--axis", "delta=0:1:20",
            "--layers", "n_solutions,stagnation,phi_ddot_roll_pos"]
    assert run(*args, "-o", str(tmp_path / "a.nc")).returncode == 0
    r = run(*args, "--chunk-cells", "100", "-o", str(tmp_path / "b.nc"))
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(tmp_path / "a.nc") as a, xr.open_dataset(tmp_path / "b.nc") as b:
        xr.testing.assert_equal(a, b)


@pytest.mark.parametrize("args, message", [
    (["atlas", "nope", "-o", "x.nc"], "unknown model 'nope'"),
    (["atlas", "ladder", "--axis", "zz=0:1:3", "-o", "x.nc"], "unknown variable 'zz'"),
    (["atlas", "ladder", "--axis", "phi=0:1:0", "-o", "x.nc"], "COUNT must be at least 1"),
    (["atlas", "ladder", "--axis", "phi=0:1", "-o", "x.nc"], "NAME=START:STOP:COUNT"),
    (["atlas", "ladder", "--axis", "phi=0:inf:3", "-o", "x.nc"], "must be finite"),
    (["atlas", "ladder", "--axis", "phi=0:1:2.5", "-o", "x.nc"], "COUNT must be a whole number"),
    (["atlas", "ladder", "--axis", "phi=0:3:5", "-o", "x.nc"], "outside its domain"),
    (["atlas", "ladder", "--set", "f=-1", "-o", "x.nc"], "f = -1 is outside its domain"),
    (["atlas", "ladder", "--set", "f=abc", "-o", "x.nc"], "'abc' is not a number"),
    (["atlas", "ladder", "--layers", "nope", "-o", "x.nc"], "unknown layer 'nope'"),
    (["atlas", "ladder", "-o", "missing/x.nc"], "folder missing does not exist"),
    (["info", "missing.nc"], "no such file"),
])
def test_bad_input_one_line_error_and_no_file(tmp_path, args, message):
    r = run(*args, cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("phasemap: error: ") and message in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_help_shows_examples():
    r = run("atlas", "--help")
    assert r.returncode == 0 and "examples:" in r.stdout and "--axis phi=" in r.stdout


def test_models_lists_names_units_and_defaults():
    r = run("models")
    assert r.returncode == 0
    for word in ("ladder", "wheel", "elliptic_pendulum", "hinge_pendulum", "rad s-1", "delta"):
        assert word in r.stdout
