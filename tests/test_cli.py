"""The phasemap command line, end to end in a temporary folder, as a new user runs it.

Every test that runs ``phasemap`` as a command is here: atlases and info, bad input
met without a traceback (a closed pipe, a file that is not netCDF, did-you-mean),
large work (size checks, progress, Ctrl-C and other signals, output problems found
before any work), the tour's usage, help and tables.
"""

from __future__ import annotations

import contextlib
import math
import os
import pathlib
import re
import signal
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from conftest import small_filesystem

import phasemap
from phasemap import cli

ROOT = pathlib.Path(__file__).resolve().parents[1]
PHASEMAP = [sys.executable, "-m", "phasemap.cli"]
#: phasemap runs in child processes here (kernels come from the disk cache): nothing
#: in-process to share, so the tests spread over the xdist workers (conftest.py)
XDIST_SPREAD = True


def env(progress: str | None = "always") -> dict:
    """This tree's phasemap on the child's path; ``PHASEMAP_PROGRESS`` when given."""
    e = dict(os.environ)
    if progress is not None:
        e["PHASEMAP_PROGRESS"] = progress
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT), e.get("PYTHONPATH", "")])
    return e


def run(*args, cwd=None, progress=None):
    return subprocess.run(PHASEMAP + [str(a) for a in args], capture_output=True, text=True,
                          cwd=cwd, timeout=300, env=env(progress))


def quiet(*args, cwd=None, progress="never"):
    """:func:`run` with progress off unless asked for (the large-work tests)."""
    return run(*args, cwd=cwd, progress=progress)


def one_line_error(r, words):
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and lines[0].startswith("phasemap: error: "), r.stderr
    assert words in lines[0], lines[0]


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


@pytest.mark.slow
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


def test_the_tour_runs_its_studies_at_once_in_processes_of_their_own(tmp_path):
    """Two studies, two jobs: each runs in a worker process (its pid differs from the
    tour's and from the other's), their printing comes whole and in the tour's order,
    whichever ends first, and the verdicts add up."""
    studies = tmp_path / "studies"
    studies.mkdir()
    for name, wait in (("ladder", 1.5), ("wheel", 0.0)):
        (studies / f"{name}.py").write_text(
            "import os, time\n"
            "from phasemap.study import Claim, arguments\n"
            "def main(argv=None):\n"
            "    args = arguments('fake study', argv)\n"
            f"    time.sleep({wait})\n"
            f"    print('{name} says', os.getpid())\n"
            f"    return [Claim('{name}', 'yes', 'yes', 'agrees')]\n")
    r = run("tour", "--studies", str(studies), "--out", str(tmp_path / "out"), "--jobs", "2")
    assert r.returncode == 0, r.stderr
    assert "2 at a time in processes of their own" in r.stdout
    lines = r.stdout.splitlines()
    said = [line.split() for line in lines if " says " in line]
    assert [s[0] for s in said] == ["ladder", "wheel"], r.stdout
    pids = {int(s[2]) for s in said}
    assert len(pids) == 2
    assert lines.index(next(x for x in lines if x.startswith("[1/2] ladder"))) < \
        lines.index(next(x for x in lines if x.startswith("ladder says")))
    assert "verdicts: 2 agrees" in r.stdout
    bad = run("tour", "--studies", str(studies), "--jobs", "0")
    assert bad.returncode == 2 and "jobs must be an integer >= 1" in bad.stderr


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_the_tours_studies_compile_first_unless_told_otherwise(tmp_path, jobs):
    """A study makes many calls of each kernel: the tour runs it under PHASEMAP_JIT=eager
    (the twins and background compiles cost the cold tour a quarter more CPU), in a
    worker process or in the tour's own; a PHASEMAP_JIT the user set is kept."""
    studies = tmp_path / "studies"
    studies.mkdir()
    (studies / "ladder.py").write_text(
        "from phasemap.core import tiers\n"
        "from phasemap.study import Claim, arguments\n"
        "def main(argv=None):\n"
        "    arguments('fake study', argv)\n"
        "    print('mode', tiers.mode())\n"
        "    return [Claim('mode', '-', tiers.mode(), 'agrees')]\n")
    for given, want in ((None, "eager"), ("off", "off"), ("background", "background")):
        e = {k: v for k, v in env(None).items() if k != "PHASEMAP_JIT"}
        if given:
            e["PHASEMAP_JIT"] = given
        r = subprocess.run(PHASEMAP + ["tour", "--studies", str(studies), "--out",
                                       str(tmp_path / "out"), "--jobs", jobs],
                           capture_output=True, text=True, timeout=300, env=e)
        assert r.returncode == 0, r.stderr
        assert f"mode {want}" in r.stdout.splitlines(), (given, r.stdout)


# ---------------------------------------- a new user without a traceback -----
def test_a_closed_pipe_ends_quietly():
    """``phasemap classify ... | head`` with the reader gone before the output."""
    proc = subprocess.Popen([*PHASEMAP, "classify", "ladder", "phi=0.5", "omega=0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader leaves before phasemap has written a line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141  # 128 + SIGPIPE, as a tool killed by SIGPIPE
    assert err == ""


def test_cfcheck_on_a_file_that_is_not_netcdf(tmp_path):
    path = tmp_path / "notes.nc"
    path.write_text("these are notes, not an atlas\n")
    out = run("cfcheck", str(path))
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        f"phasemap: error: {path}: not a netCDF file (neither netCDF classic nor netCDF-4/HDF5 "
        "by its first bytes); cfchecks checks netCDF files"]


def test_the_help_examples_axes_work(tmp_path):
    """The help's ladder example (counts made small) and its pi/2 spelling both run; a
    typed 1.5708 is read as the domain's end pi/2, and says so."""
    ladder = [cmd for cmd, _ in cli.EXAMPLES["atlas"] if cmd.startswith("phasemap atlas ladder")]
    args = ladder[0].split()[1:]
    assert "phi=0:pi/2:1024" in args
    args = [a.replace(":1024", ":3") for a in args]
    args[args.index("-o") + 1] = str(tmp_path / "ladder.nc")
    out = run(*args)
    assert out.returncode == 0, out.stderr
    out = run("atlas", "ladder", "--axis", "phi=0:1.5708:3", "--axis", "f=0:3:2",
              "-o", str(tmp_path / "typed.nc"))
    assert out.returncode == 0, out.stderr
    assert ("phasemap: read phi=1.5708 as 1.5707963267948966, the upper end of its domain "
            "[0, 1.5707963267948966]") in out.stderr
    with xr.open_dataset(tmp_path / "typed.nc") as ds:
        assert float(ds.phi[-1]) == math.pi / 2


def test_errors_state_exact_bounds_and_did_you_mean():
    out = run("classify", "ladder", "phi=1.6", "omgea=0")
    assert out.returncode == 2
    assert "unknown variable 'omgea'; did you mean 'omega'?" in out.stderr
    out = run("classify", "ladder", "phi=1.6")
    assert out.stderr.strip() == ("phasemap: error: ladder: phi = 1.6 is outside its domain "
                                  "[0, 1.5707963267948966] (angle of the bar from the vertical, "
                                  "rad)")
    out = run("classify", "ladr")
    assert "unknown model 'ladr'; did you mean 'ladder'?" in out.stderr


def test_an_unknown_layer_says_how_to_list_them(tmp_path):
    out = run("atlas", "ladder", "--layers", "n_solution", "-o", str(tmp_path / "x.nc"))
    assert out.returncode == 2
    (line,) = out.stderr.strip().splitlines()
    assert "did you mean 'n_solutions'?" in line and "phasemap models ladder" in line
    assert "phi_ddot_stick" not in line and len(line) < 250
    listing = run("models", "ladder").stdout
    assert "layers (" in listing and "\n    phi_ddot_stick " in listing


def test_classify_prints_units_and_a_tie_as_zero():
    out = run("classify", "ladder", "phi=0.5", "omega=0", "f=0.3")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "ladder(phi=0.5 rad, omega=0 rad s-1, f=0.3, l=1 m, g=9.81 m s-2, m=1 kg)"
    stick = next(line for line in lines if line.split()[0] == "stick")
    assert "phi_ddot=0 rad s-2," in stick
    # At rest the reactions are statically indeterminate: with t = F_wall, the bar's
    # statics (l = m = 1; tests/test_independent_solve.py) give N_floor = w + t and
    # N_wall = -F_floor = tan(phi) (w + 2 t) / 2, and phasemap reports the middle of the
    # interval of t on which both contacts push and both frictions lie within their cones
    # (the middle of a segment, whatever its affine parametrisation).  Each condition is
    # a + b t >= 0, derived here; the value printed to 6 digits used to be hard-coded
    # from phasemap's own output.
    w, T, f = 9.81, math.tan(0.5), 0.3
    conds = [(w, 1.0),                          # N_floor >= 0
             (T * w / 2, T),                    # N_wall >= 0
             (f * w - T * w / 2, f - T),        # f N_floor - |F_floor| >= 0 (F_floor < 0)
             (f * T * w / 2, f * T - 1.0),      # f N_wall - F_wall >= 0
             (f * T * w / 2, f * T + 1.0)]      # f N_wall + F_wall >= 0
    lo = max(-a / b for a, b in conds if b > 0)
    hi = min(-a / b for a, b in conds if b < 0)
    assert lo < hi
    assert f"N_floor={w + (lo + hi) / 2:.6g} N" in stick


@pytest.mark.parametrize("text, value", [("pi/2", math.pi / 2), ("-2*pi/3", -2 * math.pi / 3),
                                         ("1e-3", 1e-3)])
def test_values_are_read_with_pi(text, value):
    assert cli._parse_values([f"f={text}"]) == {"f": value}


def test_values_refuse_code():
    with pytest.raises(ValueError, match="is not a number"):
        cli._parse_values(["phi=__import__('os').getcwd()"])


# --------------------------------------------- 4. a huge grid is refused -----
def test_a_huge_grid_is_refused_before_any_work(tmp_path):
    r = quiet("atlas", "ladder", "--axis", "phi=0:1.5:1000000", "--axis", "f=0:3:1000000",
            "-o", tmp_path / "huge.nc")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    # refused for the disk (2 TB uncompressed) or, on a disk that large, for --yes
    assert ("free" in lines[0] and "typical" in lines[0]) or "--yes" in lines[0], lines[0]
    assert list(tmp_path.iterdir()) == []


def test_above_a_billion_cells_asks_for_yes(tmp_path):
    from phasemap.maps import blocks

    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 40000),
                                           "f": np.linspace(0, 3, 40000)}, layers=["singular"])
    est = blocks.estimate(scene)
    assert est.cells == 1_600_000_000 > blocks.YES_CELLS
    assert est.bytes == est.cells and est.typical_bytes < est.bytes
    r = quiet("atlas", "ladder", "--axis", "phi=0:1.5:40000", "--axis", "f=0:3:40000",
            "--layers", "singular", "-o", tmp_path / "big.nc")
    if "free" in r.stderr:
        pytest.skip("this disk cannot hold the 80 MB the estimate asks for")
    one_line_error(r, "pass --yes to go ahead")
    assert list(tmp_path.iterdir()) == []


def test_the_estimate_is_printed_and_the_blocks_equal_the_eager_atlas(tmp_path):
    args = ["atlas", "hinge_pendulum", "--axis", "phi=-3:3:37", "--axis", "omega=-6:6:9",
            "--layers", "fate,t_final,phi_rest,n_solutions", "--option", "t_end=2"]
    r = quiet(*args, "--chunk-cells", "10", "-o", tmp_path / "blocks.nc")
    assert r.returncode == 0, r.stderr
    assert "333 cells (37 phi x 9 omega)" in r.stderr and "typical" in r.stderr
    assert "time about" in r.stderr
    scene = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 37),
                                                   "omega": np.linspace(-6, 6, 9)},
                           layers=["fate", "t_final", "phi_rest", "n_solutions"],
                           options={"t_end": 2.0})
    eager = scene.compute()
    with xr.open_dataset(tmp_path / "blocks.nc") as ds:
        xr.testing.assert_identical(ds.drop_attrs(deep=False), eager.drop_attrs(deep=False))
        assert ds.attrs["phasemap_scene"] == eager.attrs["phasemap_scene"]


# ------------------------------------------------------ 5. progress -----------
def test_progress_goes_to_stderr_and_results_to_stdout(tmp_path):
    r = quiet("atlas", "ladder", "--axis", "phi=0:1.5:3000", "--axis", "f=0:3:3000",
            "--chunk-cells", "100000", "-o", tmp_path / "l.nc", progress="always")
    assert r.returncode == 0, r.stderr
    assert "cell" in r.stderr and "l.nc" in r.stderr   # the tqdm bar, named after the file
    assert r.stdout.strip().splitlines() == [
        f"wrote {tmp_path / 'l.nc'} (9000000 cells, layers n_solutions, stagnation)"]


# ------------------------------------------------------ 6. Ctrl-C ------------
def interrupt(args, cwd, ready: str, sig=signal.SIGINT):
    """Start the CLI, wait until ``ready`` shows on stderr, send ``sig``; return
    (returncode, stderr)."""
    proc = subprocess.Popen(PHASEMAP + [str(a) for a in args], cwd=cwd, env=env("always"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            bufsize=1)
    seen = ""
    while ready not in seen:
        ch = proc.stderr.read(1)
        if not ch:
            break
        seen += ch
    assert ready in seen, seen
    proc.send_signal(sig)
    _, rest = proc.communicate(timeout=60)
    return proc.returncode, seen + rest


@pytest.mark.slow
@pytest.mark.parametrize("args, ready", [
    (["atlas", "hinge_pendulum", "--axis", "phi=-3:3:3000", "--axis", "omega=-6:6:3000",
      "--layers", "fate", "--option", "t_end=30", "--yes", "-o", "fates.nc"], "fates.nc:"),
    (["simulate", "hinge_pendulum", "phi=1", "delta=0", "--t-end", "1e5", "-o", "s.nc"],
     "integrating"),
    (["tour", "--out", "tour"], "[1/6] ladder"),
])
def test_ctrl_c_exits_130_with_one_line_and_no_partial_file(tmp_path, args, ready):
    code, err = interrupt(args, tmp_path, ready)
    assert code == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == "phasemap: interrupted; no partial file was left"
    leftovers = [p for p in tmp_path.rglob("*") if p.suffix in (".nc", ".part", ".pdf",
                                                                 ".png") and p.stat().st_size == 0
                 or p.name.endswith(".part")]
    assert leftovers == []
    assert not (tmp_path / "fates.nc").exists() and not (tmp_path / "s.nc").exists()


FATE_ATLAS = ["atlas", "hinge_pendulum", "--axis", "phi=-3:3:3000", "--axis", "omega=-6:6:3000",
              "--layers", "fate", "--option", "t_end=30", "--yes", "-o", "fates.nc"]


@pytest.mark.slow
@pytest.mark.parametrize("attempt", range(2))
@pytest.mark.parametrize("signame", ["SIGTERM", "SIGHUP"])
def test_sigterm_and_sighup_end_the_atlas_with_one_line_and_no_partial_file(tmp_path, signame,
                                                                          attempt):
    sig = getattr(signal, signame)
    code, err = interrupt(FATE_ATLAS, tmp_path, "fates.nc:", sig)
    assert code == 128 + sig, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == (f"phasemap: terminated by {signame}; no partial "
                                            "file was left")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("attempt", range(2))
def test_two_atlases_racing_for_one_name_never_both_write_it(tmp_path, attempt):
    """Both pass the check for an existing file before either has written it; the
    exclusive last step lets exactly one of them write."""
    args = ["atlas", "hinge_pendulum", "--axis", "phi=-3:3:15", "--axis", "omega=-6:6:15",
            "--set", "delta=0", "--layers", "fate", "--option", "t_end=1000", "-o", "c.nc"]
    procs = [subprocess.Popen(PHASEMAP + args, cwd=tmp_path, env=env("never"),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    results = [p.communicate(timeout=300) + (p.returncode,) for p in procs]
    codes = sorted(r[2] for r in results)
    assert codes == [0, 2], results
    loser = [r for r in results if r[2] == 2][0]
    assert loser[1].strip().splitlines()[-1] == ("phasemap: error: c.nc exists; pass "
                                                 "overwrite=True (--overwrite on the command "
                                                 "line) to replace it"), loser[1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.nc"]
    with xr.open_dataset(tmp_path / "c.nc") as ds:
        assert ds.sizes == {"phi": 15, "omega": 15}


# ----------------------------------------- 7. output problems found first ----
def test_an_existing_file_needs_overwrite(tmp_path):
    target = tmp_path / "a.nc"
    target.write_bytes(b"precious")
    for args in (["atlas", "ladder", "--axis", "phi=0:1:5", "-o", target],
                 ["simulate", "ladder", "phi=1", "-o", target]):
        one_line_error(quiet(*args), f"{target} exists; pass overwrite=True (--overwrite "
                                     "on the command line) to replace it")
        assert target.read_bytes() == b"precious"
    assert quiet("atlas", "ladder", "--axis", "phi=0:1:5", "--overwrite", "-o", target
               ).returncode == 0
    with xr.open_dataset(target) as ds:
        assert ds.sizes["phi"] == 5


def test_a_read_only_destination_is_refused_before_work(tmp_path):
    with small_filesystem(tmp_path / "ro", "1m", readonly=True) as ro:
        r = quiet("atlas", "ladder", "--axis", "phi=0:1:5", "-o", ro / "a.nc")
        one_line_error(r, "Read-only file system")
        assert "time about" not in r.stderr   # refused before any work


def test_a_disk_without_room_is_refused_before_work(tmp_path):
    with small_filesystem(tmp_path / "small", "1m") as small:
        r = quiet("atlas", "ladder", "--axis", "phi=0:1.5:3000", "--axis", "f=0:3:3000",
                "--layers", "n_solutions,phi_ddot_slide_pos", "-o", small / "a.nc")
        one_line_error(r, "free")
        assert "time about" not in r.stderr and list(small.iterdir()) == []


def test_a_full_disk_is_called_full_by_simulate_and_plot(tmp_path):
    """HDF5 reports a full disk as "Permission denied", and matplotlib's PDF writer as an
    AttributeError from its cleanup (a 40-line traceback): each is one line that says the
    disk is full, with no file left."""
    atlas = tmp_path / "a.nc"
    assert quiet("atlas", "ladder", "--axis", "phi=0:1:5", "-o", atlas).returncode == 0
    with small_filesystem(tmp_path / "full", "1m") as full:
        with contextlib.suppress(OSError), open(full / "ballast", "wb") as fh:
            while True:
                fh.write(b"\0" * 4096)
                fh.flush()
        for args in (["simulate", "ladder", "phi=1", "--t-end", "0.1", "-o", full / "m.nc"],
                     ["plot", atlas, "-o", full / "fig"]):
            r = quiet(*args)
            one_line_error(r, "no space left on the device")
            assert "no file was left" in r.stderr and "Traceback" not in r.stderr
            assert [p.name for p in full.iterdir()] == ["ballast"]


@pytest.mark.slow
def test_a_disk_that_fills_up_mid_write_leaves_no_file(tmp_path):
    """Another writer fills the disk while the atlas is being written."""
    with small_filesystem(tmp_path / "fills", "40m") as fills:
        args = ["atlas", "ladder", "--axis", "phi=0:1.5:2000", "--axis", "f=0:3:2000",
                "--layers", "phi_ddot_slide_pos,N_floor_slide_pos", "--chunk-cells", "20000",
                "-o", fills / "a.nc"]
        proc = subprocess.Popen(PHASEMAP + [str(a) for a in args], env=env("always"),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        seen = ""
        while "%|" not in seen:   # the bar: blocks are being written
            ch = proc.stderr.read(1)
            assert ch, seen
            seen += ch
        with open(fills / "ballast", "wb") as fh:   # fill the disk
            with contextlib.suppress(OSError):
                while True:
                    fh.write(b"\0" * (1 << 20))
                    fh.flush()
        _, rest = proc.communicate(timeout=120)
        err = (seen + rest).strip().splitlines()[-1]
        assert proc.returncode == 2, seen + rest
        assert err.startswith("phasemap: error: cannot write") and "no file was left" in err, \
            repr(rest[-600:])
        assert "Traceback" not in rest and "HDF5-DIAG" not in rest
        assert sorted(p.name for p in fills.iterdir()) == ["ballast"]


# ----------------------------------------------- 8. tour --quick, usage ------
def test_tour_accepts_quick_and_shows_its_own_usage_on_errors(tmp_path):
    r = quiet("tour", "--quick", "--only", "nope", "--out", tmp_path / "o")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2
    assert lines[0].startswith("usage: phasemap tour") and "--quick" in r.stderr
    assert lines[-1] == ("phasemap: error: unknown study 'nope'; available: ladder, wheel, "
                         "elliptic_pendulum, hinge_pendulum, rod_on_step, overview")
    bad = quiet("tour", "--bogus")
    assert bad.returncode == 2 and bad.stderr.startswith("usage: phasemap tour")
    assert quiet("tour", "--quick", "--full").returncode == 2   # one or the other


# ------------------------------------------- 9. axes without repeats --------
def test_an_axis_that_repeats_a_value_is_refused(tmp_path):
    one_line_error(quiet("atlas", "ladder", "--axis", "phi=0.5:0.5:3", "-o",
                         tmp_path / "a.nc"),
                   "START = STOP = 0.5 with COUNT 3 would repeat one value")
    assert quiet("atlas", "ladder", "--axis", "phi=0.5:0.5:1", "-o", tmp_path / "one.nc"
               ).returncode == 0
    # one rule for every command (issue 41 item 7): a range is written low end first
    one_line_error(quiet("atlas", "ladder", "--axis", "phi=1.5:0:4", "-o", tmp_path / "d.nc"),
                   "START 1.5 is above STOP 0; every range on the command line is written "
                   "low end first: phi=0:1.5:4")
    assert not (tmp_path / "d.nc").exists()
    one_line_error(quiet("threshold", "painleve_rod", "f", "--over", "theta=1.5:0.1", "--set",
                         "xdot=-1", "--set", "omega=0"), "lo < hi")
    one_line_error(quiet("boundaries", "painleve_rod", "--axis", "theta=1.5:0.2", "--axis",
                         "f=0:3", "--set", "xdot=-1", "--set", "omega=0", "-o",
                         tmp_path / "b.nc"), "lo < hi")
    assert "low end first" in quiet("atlas", "--help").stdout
    for axis, words in (([0.1, 0.1, 0.2], "repeats a value"),
                        ([0.1, 0.3, 0.2], "goes back and forth")):
        with pytest.raises(ValueError, match=words):
            phasemap.Scene("ladder", axes={"phi": axis})


# ------------------------------------------- 10. info on motions -------------
def test_info_describes_trajectories_and_phase_curves_as_what_they_are(tmp_path):
    r = quiet("simulate", "hinge_pendulum", "phi=2.5", "omega=0", "--t-end", "20",
            "-o", tmp_path / "swing.nc")
    assert r.returncode == 0, r.stderr
    ds = xr.open_dataset(tmp_path / "swing.nc")
    n_t, n_ev = ds.sizes["t"], ds.sizes["event"]
    ds.close()
    info = quiet("info", tmp_path / "swing.nc")
    assert info.returncode == 0, info.stderr
    text = info.stdout
    assert text.startswith("phasemap trajectory ") and "cells" not in text and "%" not in text
    assert f"saved     {n_t} states, t from 0 to " in text
    assert f"events    {n_ev}: start 1, reversal {n_ev - 2}, rest 1" in text
    assert "ended     rest: stopped in a stagnation zone" in text
    curve = phasemap.phase_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.1)
    phasemap.write_atlas(curve, tmp_path / "curve.nc")
    text = quiet("info", tmp_path / "curve.nc").stdout
    assert text.startswith("phasemap phase curve ") and "cells" not in text
    assert f"{curve.sizes['point']} points of omega(phi) on {curve.sizes['stage']} stages" in text
    assert "stages end 6: reversal 5, rest 1" in text


# ------------------------------------------- 12. cfchecks offline ------------
def test_cfcheck_runs_offline_from_the_command_line(tmp_path):
    from conftest import require_tool

    require_tool("cfchecks", "pip install cfchecker; needs libudunits2-0")
    assert quiet("atlas", "wheel", "--axis", "phi=-3:3:8", "-o", tmp_path / "w.nc"
               ).returncode == 0
    # no network: an unreachable proxy makes any download fail at once
    offline = dict(env("never"), http_proxy="http://127.0.0.1:9", https_proxy="http://127.0.0.1:9",
                   HTTP_PROXY="http://127.0.0.1:9", HTTPS_PROXY="http://127.0.0.1:9")
    r = subprocess.run(PHASEMAP + ["cfcheck", str(tmp_path / "w.nc")], capture_output=True,
                       text=True, env=offline, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "ERRORS detected: 0" in r.stdout and "WARNINGS given: 0" in r.stdout
    # a name from a table it would have downloaded is an error, not a silent pass
    with xr.open_dataset(tmp_path / "w.nc") as ds:
        ds.load()
    ds.phi.attrs["standard_name"] = "air_temperature"
    phasemap.write_atlas(ds, tmp_path / "named.nc")
    r = subprocess.run(PHASEMAP + ["cfcheck", str(tmp_path / "named.nc")],
                       capture_output=True, text=True, env=offline, timeout=300)
    assert r.returncode == 1 and "ERRORS detected: 0" not in r.stdout
    assert r.stderr.strip().splitlines()[-1].endswith("does not pass the CF checker (its "
                                                      "report is above)")


# ------------------------------------------- 13. help and tables -------------
def test_each_command_has_its_own_help():
    from phasemap.cli import build_parser

    parser, subs = build_parser()
    top = parser.format_help()
    for name, sub in subs.items():
        text = sub.format_help()
        assert sub.description, name                         # every command says what it does
        assert text.count("examples:") == 1, name
        others = [c for c in subs if c != name and f"phasemap {c} " in text]
        assert others == [], (name, others)                  # only its own examples
        assert f"phasemap {name}" in top
    for name in ("atlas", "simulate", "classify"):
        assert "ladder, wheel, elliptic_pendulum, hinge_pendulum" in " ".join(
            subs[name].format_help().split())
    lines = top.splitlines()          # a continued example keeps its line break
    assert not any("--axis omega" in line and "--layers" in line for line in lines)
    assert any(line.strip().startswith("--layers fate") for line in lines)


def test_claims_tables_fit_the_terminal():
    from phasemap.study import Claim, claims_table

    claims = [Claim("the no-solution region of the elliptic pendulum exists iff f > 2 sqrt 2 "
                    "(the sharp threshold, beyond the paper's f <= 2)", "f <= 2 is sufficient",
                    "minimum of lambda over phi is (3 - sqrt(1 + f^2))/2, zero at f = 2.8284",
                    "sharper")] * 2
    for width in (60, 100):
        table = claims_table(claims, width=width)
        assert max(len(line) for line in table.splitlines()) <= width
        assert " ".join(table.split()).count("sharper") == 2
        assert "2.8284" in table
    assert len(claims_table(claims, width=0).splitlines()) == 4   # no terminal: one line each


def test_progress_is_silent_in_a_pipe_or_a_log(tmp_path):
    """``phasemap tour > log 2>&1`` wrote a ticker twice a second and tqdm's cursor codes
    (2 862 updates), and ``simulate ... 2>&1 | cat`` glued the ticker to the table's
    header: the command line's progress shows only where stderr is a terminal (issue 41
    item 8).  The command line's switch, a wait of 1.6 s (past the ticker's one-second
    delay) and a bar, in a child whose stderr is a pipe; a library call that asks for
    progress=True still gets it."""
    code = ("import time\n"
            "from phasemap.core import progress\n"
            "with progress.enable():\n"
            "    with progress.activity('compiling'):\n"
            "        time.sleep(1.6)\n"
            "    with progress.bar(10, 'cells') as b:\n"
            "        time.sleep(1.2); b.update(10)\n"
            "print('done')\n"
            "with progress.enable(True, force=True):\n"
            "    with progress.activity('asked for'):\n"
            "        time.sleep(1.6)\n")
    e = {k: v for k, v in env(None).items() if k != "PHASEMAP_PROGRESS"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=e, timeout=120)
    assert done.returncode == 0 and done.stdout == "done\n", done.stderr
    assert "compiling" not in done.stderr and "cells" not in done.stderr, repr(done.stderr)
    assert "asked for" in done.stderr
    first = run("simulate", "hinge_pendulum", "phi=2.5", "omega=0", "delta=0.1",
                "--t-end", "20").stdout.splitlines()[0]
    assert first.startswith("t (s)"), first   # the table's header, alone on its line


def test_classify_names_what_it_needs_and_refuses_a_name_given_twice():
    """Issue 41 items 5, 6 and 12: ``classify`` without arguments said NAME=VALUE was
    required; ``phi=0.5 phi=0.6`` silently took 0.6; the help listed MODEL as the
    built-in names only."""
    r = quiet("classify")
    one_line_error(r, "classify needs MODEL, a built-in model (ladder, ")
    assert "NAME=VALUE pairs are optional" in r.stderr
    for command, tail in ((["classify", "ladder"], []),
                          (["simulate", "ladder"], ["--t-end", "0.1"])):
        r = quiet(*command, "phi=0.5", "phi=0.6", *tail)
        one_line_error(r, "phi is given twice (phi=0.6 after phi=0.5); give each name once")
    for command in ("classify", "atlas", "simulate", "threshold", "boundaries", "models"):
        text = " ".join(quiet(command, "--help").stdout.split())
        assert "or a declaration file (path/to/system.py, defining SYSTEM)" in text, command


def test_warm_compiles_each_kind_of_work_once_and_a_second_run_loads_it():
    """``phasemap warm MODEL``: a row per kind of work the model supports; the second run,
    in new processes, compiles nothing (every kernel comes from the cache)."""
    from phasemap.warm import kinds_of

    for attempt in range(2):
        r = run("warm", "hinge_pendulum", "--jobs", "2")
        assert r.returncode == 0, r.stderr
        rows = [line.split() for line in r.stdout.splitlines()[1:-1]]
        assert [row[1] for row in rows] == list(kinds_of("hinge_pendulum"))
        assert all(row[0] == "hinge_pendulum" for row in rows)
        assert r.stdout.splitlines()[-1].startswith("warm: 6 calls")
    assert all(float(row[3].rstrip("s")) == 0.0 for row in rows), r.stdout
    bad = run("warm", "nosuch")
    assert bad.returncode == 2 and "unknown model 'nosuch'" in bad.stderr


def test_timing_says_how_much_of_a_command_was_compiling():
    r = run("--timing", "classify", "ladder", "phi=0.3")
    assert r.returncode == 0, r.stderr
    last = r.stderr.strip().splitlines()[-1]
    m = re.fullmatch(r"phasemap: ([\d.]+) s in all, ([\d.]+) s of it compiling numba kernels "
                     r"in this process", last)
    assert m and float(m.group(2)) <= float(m.group(1)), last


def test_the_oscillators_are_mapped_and_classified_from_the_command_line(tmp_path):
    """A friction oscillator (no reduced model) takes the map commands: classify names
    its phases, models lists it, atlas maps its forcing's phase; a bad name is one line."""
    r = quiet("classify", "belt", "x=1.2", "xdot=0.2")
    assert r.returncode == 0, r.stderr
    assert "belt_slip_neg" in r.stdout and "stagnation = False" in r.stdout
    listing = quiet("models", "belt").stdout
    assert "(in full coordinates)" in listing and "F_belt" in listing
    out = tmp_path / "dh.nc"
    r = quiet("atlas", "den_hartog", "--axis", "t=0:7.85:5", "--axis", "x=-1:1:4",
              "--set", "xdot=0", "--layers", "stagnation,x_ddot", "-o", out)
    assert r.returncode == 0, r.stderr
    ds = phasemap.open_atlas(out)
    assert ds.x_ddot.dims == ("t", "x") and ds.x_ddot.attrs["units"] == "m s-2"
    one_line_error(quiet("classify", "belt", "y=0"), "unknown variable")
