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


def test_simulate_prints_events_and_writes_the_trajectory(tmp_path):
    out = tmp_path / "swing.nc"
    r = run("simulate", "hinge_pendulum", "phi=2.5", "omega=0", "--t-end", "20", "-o", str(out))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].split()[:4] == ["t", "(s)", "event", "branch"]
    kinds = [line.split()[1] for line in lines[1:] if line[:1].isdigit()]
    assert kinds[0] == "start" and kinds[-1] == "rest" and set(kinds[1:-1]) == {"reversal"}
    with xr.open_dataset(out) as ds:
        assert ds.attrs["phasemap_kind"] == "trajectory" and ds.attrs["end_reason"] == "rest"
        assert len(kinds) == ds.sizes["event"]
        assert abs(float(ds.phi[-1])) <= 0.1 + 1e-12  # inside l |sin phi| <= delta


def test_fate_atlas_takes_integrator_options(tmp_path):
    out = tmp_path / "fates.nc"
    r = run("atlas", "hinge_pendulum", "--axis", "phi=-3:3:9", "--axis", "omega=-4:4:5",
            "--layers", "fate,t_final", "--option", "t_end=0.5", "-o", str(out))
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(out) as ds:
        assert float(ds.t_final.max()) <= 0.5
        assert '"t_end": 0.5' in ds.attrs["phasemap_scene"]
        assert int((ds.fate == 11).sum()) > 0  # horizon: still moving after 0.5 s
    bad = run("atlas", "hinge_pendulum", "--layers", "fate", "--option", "t_stop=3", "-o",
              str(tmp_path / "x.nc"))
    assert bad.returncode == 2 and "unknown integrator option 't_stop'" in bad.stderr


def test_simulate_bad_input_is_one_line(tmp_path):
    r = run("simulate", "wheel", "--t-end", "-1")
    assert r.returncode == 2 and r.stderr.strip() == (
        "phasemap: error: wheel: t_end must be a positive number, got -1.0")


def test_tour_runs_the_studies_it_finds(tmp_path):
    studies = tmp_path / "studies"
    studies.mkdir()
    (studies / "ladder.py").write_text(
        "import pathlib\n"
        "from phasemap.study import Claim, arguments\n"
        "def main(argv=None):\n"
        "    args = arguments('fake study', argv)\n"
        "    (args.out / 'ladder_fig.png').write_bytes(b'')\n"
        "    return [Claim('quick is passed', 'yes', str(args.quick), 'agrees')]\n")
    r = run("tour", "--studies", str(studies), "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    assert "[1/1] ladder (quick)" in r.stdout and "verdicts: 1 agrees" in r.stdout
    assert str(tmp_path / "out" / "ladder_fig.png") in r.stdout
    # --size reaches the studies: every figure at both widths, the narrow ones named so
    (studies / "ladder.py").write_text(
        "from phasemap.study import Claim, arguments, figure_name\n"
        "def main(argv=None):\n"
        "    args = arguments('fake study', argv)\n"
        "    for size in args.sizes:\n"
        "        (args.out / (figure_name('ladder_fig', size) + '.png')).write_bytes(b'')\n"
        "    return [Claim('sizes', '-', ' '.join(args.sizes), 'agrees')]\n")
    r = run("tour", "--studies", str(studies), "--out", str(tmp_path / "both"), "--size", "both")
    assert r.returncode == 0, r.stderr
    assert {p.name for p in (tmp_path / "both").iterdir()} == {"ladder_fig.png",
                                                               "ladder_fig_one_column.png"}
    missing = run("tour", "--studies", str(tmp_path / "nowhere"))
    assert missing.returncode == 2 and "no study scripts found" in missing.stderr
