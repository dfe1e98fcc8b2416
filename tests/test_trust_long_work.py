"""Long and large work a user can trust (issue 10): one test per item at least.

Wrong results (chunked options, overflow, end labels), large work (size
checks, progress, Ctrl-C, output checks) and the smaller things a user trips
over (CLI, info, README numbers, offline cfchecks).
"""

from __future__ import annotations

import contextlib
import math
import re

import numpy as np
import pytest
import xarray as xr

from conftest import small_filesystem

import phasemap
from phasemap.model import MAX_MAGNITUDE, MIN_POSITIVE
from phasemap.models import MODELS


# ---------------------------------------------------- 1. chunked fate maps --
def test_chunked_fate_map_uses_the_integrator_options():
    scene = phasemap.Scene("hinge_pendulum", axes={"phi": [2.5, 3.0]}, fixed={"omega": 0.0},
                           layers=["fate", "t_final", "n_reversals", "t_rest", "phi_rest"],
                           options={"t_end": 0.5, "rtol": 1e-9})
    eager = scene.compute()
    assert np.all(eager.t_final.values == 0.5)  # still swinging at t_end
    lazy = scene.compute(chunks=1).compute()
    xr.testing.assert_identical(lazy.drop_attrs(), eager.drop_attrs())


# --------------------------------------------------------- 2. overflow -----
@pytest.mark.parametrize("model, values, words", [
    ("ladder", {"omega": 1e300}, "omega = 1e+300 is too large"),
    ("wheel", {"r": 1e155, "l": 0.5}, "r = 1e+155 is too large"),
    ("hinge_pendulum", {"l": 1e300}, "l = 1e+300 is too large"),
    ("hinge_pendulum", {"l": 1e-200}, "l = 1e-200 is too small"),
    ("elliptic_pendulum", {"m": 1e-160}, "m = 1e-160 is too small"),
])
def test_values_that_would_overflow_are_refused(model, values, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        phasemap.classify(model, **values)
    name, value = next(iter(values.items()))
    with pytest.raises(ValueError, match=re.escape(words.split(" is ")[0])):
        phasemap.Scene(model, axes={name: [1.0, value]}, fixed={k: v for k, v in values.items()
                                                               if k != name})


@pytest.mark.parametrize("model", sorted(MODELS))
def test_no_overflow_is_ever_counted_as_a_solution(model):
    """At random states with every value anywhere in its allowed range (1e-30 to 1e30),
    each admissible branch has finite accelerations and reactions."""
    m = MODELS[model]
    rng = np.random.default_rng(10)
    checked = 0
    for _ in range(1500):
        values = {}
        for var in m.state + m.params:
            kind = rng.integers(4)
            mag = 10.0 ** rng.uniform(-30, 30)
            x = 0.0 if kind == 0 else (MAX_MAGNITUDE if kind == 1 else mag)
            if var.lower >= 0:
                x = max(x, MIN_POSITIVE) if var.lower_open else x
                if var.upper < math.inf:
                    x = min(x, var.upper)
            elif rng.integers(2):
                x = -x
            values[var.name] = x
        if model == "wheel":
            values["l"] = min(values["l"], values["r"])
        if m.check is not None:  # a cross-variable domain (the rod on a step must touch it)
            try:
                m.check(values)
            except ValueError:
                continue
        c = phasemap.classify(m, **values)
        for b in c.branches:
            if b.status != phasemap.BranchStatus.ADMISSIBLE:
                continue  # a continuum has no values
            numbers = [*b.accelerations.values(), *b.reactions.values()]
            assert all(math.isfinite(x) for x in numbers), (repr(values), b)
            checked += 1
    assert checked > (100 if m.check is not None else 500)  # a check refuses most draws


# ------------------------------------------------------- 3. end labels -----
def test_ladder_lying_flat_leaves_the_domain_and_says_which_edge():
    ds = phasemap.simulate("ladder", t_end=10.0, phi=1.4, omega=1.0, f=1.0)
    assert ds.attrs["end_reason"] == "left_domain"
    assert float(ds.event_t[-1]) < 1.0 and float(ds.event_phi[-1]) == math.pi / 2
    assert "lies flat on the floor" in ds.attrs["end_message"]
    curve = phasemap.phase_curve("ladder", phi=1.4, omega=1.0, f=1.0)
    assert curve.attrs["end_reason"] == "left_domain"
    assert "lies flat" in curve.attrs["end_message"]
    fates = phasemap.Scene("ladder", axes={"phi": [1.4]}, fixed={"omega": 1.0, "f": 1.0},
                           layers=["fate"]).compute()
    assert int(fates.fate[0]) == phasemap.Event.LEFT_DOMAIN
    assert "left_domain" in fates.fate.attrs["flag_meanings"].split()


@pytest.mark.parametrize("excess", [1e-9, 1e-3])
def test_hinge_leaving_the_reaction_free_curve_has_no_solution(excess):
    """delta just above l, started exactly on l omega^2 + g cos phi = 0: the unique free
    motion leaves the curve at once into states with no solution."""
    phi, g = 2.0, 9.81
    omega = math.sqrt(-g * math.cos(phi))
    assert phasemap.classify("hinge_pendulum", phi=phi, omega=omega, delta=1 + excess
                             ).n_solutions == 1
    ds = phasemap.simulate("hinge_pendulum", t_end=1.0, phi=phi, omega=omega,
                           delta=1 + excess)
    assert ds.attrs["end_reason"] == "no_solution"
    assert float(ds.event_t[-1]) < 1e-6


def test_running_out_of_steps_has_its_own_name():
    ds = phasemap.simulate("hinge_pendulum", t_end=100.0, max_steps=50, phi=2.0, delta=0.01)
    assert ds.attrs["end_reason"] == "max_steps" and int(ds.attrs["n_steps"]) == 50
    events = phasemap.simulate("hinge_pendulum", t_end=100.0, max_events=2, phi=2.0,
                               delta=0.01)
    assert events.attrs["end_reason"] == "max_events"


# ------------------------------------------------ the command line, run -----
import os
import pathlib
import signal
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
PHASEMAP = [sys.executable, "-m", "phasemap.cli"]


def env(progress: str = "always") -> dict:
    e = dict(os.environ, PHASEMAP_PROGRESS=progress)
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT), e.get("PYTHONPATH", "")])
    return e


def run(*args, cwd=None, progress="never"):
    return subprocess.run(PHASEMAP + [str(a) for a in args], capture_output=True, text=True,
                          cwd=cwd, timeout=300, env=env(progress))


def one_line_error(r, words):
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1 and lines[0].startswith("phasemap: error: "), r.stderr
    assert words in lines[0], lines[0]


# --------------------------------------------- 4. a huge grid is refused -----
def test_a_huge_grid_is_refused_before_any_work(tmp_path):
    r = run("atlas", "ladder", "--axis", "phi=0:1.5:1000000", "--axis", "f=0:3:1000000",
            "-o", tmp_path / "huge.nc")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    # refused for the disk (2 TB uncompressed) or, on a disk that large, for --yes
    assert ("free" in lines[0] and "typical" in lines[0]) or "--yes" in lines[0], lines[0]
    assert list(tmp_path.iterdir()) == []


def test_above_a_billion_cells_asks_for_yes(tmp_path):
    from phasemap import blocks

    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 40000),
                                           "f": np.linspace(0, 3, 40000)}, layers=["singular"])
    est = blocks.estimate(scene)
    assert est.cells == 1_600_000_000 > blocks.YES_CELLS
    assert est.bytes == est.cells and est.typical_bytes < est.bytes
    r = run("atlas", "ladder", "--axis", "phi=0:1.5:40000", "--axis", "f=0:3:40000",
            "--layers", "singular", "-o", tmp_path / "big.nc")
    if "free" in r.stderr:
        pytest.skip("this disk cannot hold the 80 MB the estimate asks for")
    one_line_error(r, "pass --yes to go ahead")
    assert list(tmp_path.iterdir()) == []


def test_the_estimate_is_printed_and_the_blocks_equal_the_eager_atlas(tmp_path):
    args = ["atlas", "hinge_pendulum", "--axis", "phi=3:-3:37", "--axis", "omega=-6:6:9",
            "--layers", "fate,t_final,phi_rest,n_solutions", "--option", "t_end=2"]
    r = run(*args, "--chunk-cells", "10", "-o", tmp_path / "blocks.nc")
    assert r.returncode == 0, r.stderr
    assert "333 cells (37 phi x 9 omega)" in r.stderr and "typical" in r.stderr
    assert "time about" in r.stderr
    scene = phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(3, -3, 37),
                                                   "omega": np.linspace(-6, 6, 9)},
                           layers=["fate", "t_final", "phi_rest", "n_solutions"],
                           options={"t_end": 2.0})
    eager = scene.compute()
    with xr.open_dataset(tmp_path / "blocks.nc") as ds:
        xr.testing.assert_identical(ds.drop_attrs(deep=False), eager.drop_attrs(deep=False))
        assert ds.attrs["phasemap_scene"] == eager.attrs["phasemap_scene"]


def test_a_large_lazy_atlas_builds_no_task_per_block():
    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 1_000_000),
                                           "f": np.linspace(0, 3, 1_000_000)})
    lazy = scene.compute(chunks={"phi": 16, "f": 1_000_000})   # 62500 blocks
    graph = lazy.n_solutions.data.dask
    assert lazy.n_solutions.data.npartitions == 62_500
    assert not any(layer.is_materialized() for layer in graph.layers.values())


# ------------------------------------------------------ 5. progress -----------
def test_progress_goes_to_stderr_and_results_to_stdout(tmp_path):
    r = run("atlas", "ladder", "--axis", "phi=0:1.5:3000", "--axis", "f=0:3:3000",
            "--chunk-cells", "100000", "-o", tmp_path / "l.nc", progress="always")
    assert r.returncode == 0, r.stderr
    assert "cell" in r.stderr and "l.nc" in r.stderr   # the tqdm bar, named after the file
    assert r.stdout.strip().splitlines() == [
        f"wrote {tmp_path / 'l.nc'} (9000000 cells, layers n_solutions, stagnation)"]


def test_an_activity_line_ticks_while_nothing_else_prints(capsys):
    from phasemap import progress

    with progress.enable(), progress.activity("waiting"):
        time.sleep(2.2)   # a wait with no count, like numba compiling
        progress.status("still waiting")
        time.sleep(1.2)
    err = capsys.readouterr().err
    assert "waiting [00:01]" in err and "waiting: still waiting [00:03]" in err


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
                                                 "--overwrite to replace it"), loser[1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.nc"]
    with xr.open_dataset(tmp_path / "c.nc") as ds:
        assert ds.sizes == {"phi": 15, "omega": 15}


# ----------------------------------------- 7. output problems found first ----
def test_an_existing_file_needs_overwrite(tmp_path):
    target = tmp_path / "a.nc"
    target.write_bytes(b"precious")
    for args in (["atlas", "ladder", "--axis", "phi=0:1:5", "-o", target],
                 ["simulate", "ladder", "phi=1", "-o", target]):
        one_line_error(run(*args), f"{target} exists; pass --overwrite to replace it")
        assert target.read_bytes() == b"precious"
    assert run("atlas", "ladder", "--axis", "phi=0:1:5", "--overwrite", "-o", target
               ).returncode == 0
    with xr.open_dataset(target) as ds:
        assert ds.sizes["phi"] == 5


def test_a_read_only_destination_is_refused_before_work(tmp_path):
    with small_filesystem(tmp_path / "ro", "1m", readonly=True) as ro:
        r = run("atlas", "ladder", "--axis", "phi=0:1:5", "-o", ro / "a.nc")
        one_line_error(r, "Read-only file system")
        assert "time about" not in r.stderr   # refused before any work


def test_a_disk_without_room_is_refused_before_work(tmp_path):
    with small_filesystem(tmp_path / "small", "1m") as small:
        r = run("atlas", "ladder", "--axis", "phi=0:1.5:3000", "--axis", "f=0:3:3000",
                "--layers", "n_solutions,phi_ddot_slide_pos", "-o", small / "a.nc")
        one_line_error(r, "free")
        assert "time about" not in r.stderr and list(small.iterdir()) == []


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
    r = run("tour", "--quick", "--only", "nope", "--out", tmp_path / "o")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2
    assert lines[0].startswith("usage: phasemap tour") and "--quick" in r.stderr
    assert lines[-1] == ("phasemap: error: unknown study 'nope'; available: ladder, wheel, "
                         "elliptic_pendulum, hinge_pendulum, rod_on_step, overview")
    bad = run("tour", "--bogus")
    assert bad.returncode == 2 and bad.stderr.startswith("usage: phasemap tour")
    assert run("tour", "--quick", "--full").returncode == 2   # one or the other


# ------------------------------------------- 9. axes without repeats --------
def test_an_axis_that_repeats_a_value_is_refused(tmp_path):
    one_line_error(run("atlas", "ladder", "--axis", "phi=0.5:0.5:3", "-o", tmp_path / "a.nc"),
                   "START = STOP = 0.5 with COUNT 3 would repeat one value")
    assert run("atlas", "ladder", "--axis", "phi=0.5:0.5:1", "-o", tmp_path / "one.nc"
               ).returncode == 0
    r = run("atlas", "ladder", "--axis", "phi=1.5:0:4", "-o", tmp_path / "down.nc")
    assert r.returncode == 0, r.stderr
    with xr.open_dataset(tmp_path / "down.nc") as ds:
        assert list(ds.phi.values) == [1.5, 1.0, 0.5, 0.0]
    assert "descending" in run("atlas", "--help").stdout
    for axis, words in (([0.1, 0.1, 0.2], "repeats a value"),
                        ([0.1, 0.3, 0.2], "goes back and forth")):
        with pytest.raises(ValueError, match=words):
            phasemap.Scene("ladder", axes={"phi": axis})


# ------------------------------------------- 10. info on motions -------------
def test_info_describes_trajectories_and_phase_curves_as_what_they_are(tmp_path):
    r = run("simulate", "hinge_pendulum", "phi=2.5", "omega=0", "--t-end", "20",
            "-o", tmp_path / "swing.nc")
    assert r.returncode == 0, r.stderr
    ds = xr.open_dataset(tmp_path / "swing.nc")
    n_t, n_ev = ds.sizes["t"], ds.sizes["event"]
    ds.close()
    info = run("info", tmp_path / "swing.nc")
    assert info.returncode == 0, info.stderr
    text = info.stdout
    assert text.startswith("phasemap trajectory ") and "cells" not in text and "%" not in text
    assert f"saved     {n_t} states, t from 0 to " in text
    assert f"events    {n_ev}: start 1, reversal {n_ev - 2}, rest 1" in text
    assert "ended     rest: stopped in a stagnation zone" in text
    curve = phasemap.phase_curve("hinge_pendulum", phi=2.5, omega=0.0, delta=0.1)
    phasemap.write_atlas(curve, tmp_path / "curve.nc")
    text = run("info", tmp_path / "curve.nc").stdout
    assert text.startswith("phasemap phase curve ") and "cells" not in text
    assert f"{curve.sizes['point']} points of omega(phi) on {curve.sizes['stage']} stages" in text
    assert "stages end 6: reversal 5, rest 1" in text


# ------------------------------------------- 12. cfchecks offline ------------
def test_cfcheck_runs_offline_from_the_command_line(tmp_path):
    from conftest import require_tool

    require_tool("cfchecks", "pip install cfchecker; needs libudunits2-0")
    assert run("atlas", "wheel", "--axis", "phi=-3:3:8", "-o", tmp_path / "w.nc"
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


# ------------------------------------------- 11. README numbers from code ----
def test_readme_numbers_come_from_code():
    from phasemap.facts import elliptic_threshold, readme_facts, wheel_singular_delta

    readme = " ".join(" ".join(page.read_text() for page in [ROOT / "README.md", *sorted(
        (ROOT / "docs" / "guide").glob("*.md"))]).split())   # the README and the user guide
    for what, text in readme_facts().items():
        assert " ".join(text.split()) in readme, (what, text)
    # the closed forms behind them, checked independently
    r, l, rho = 1.0, 0.5, 0.5
    phi = np.linspace(-math.pi, math.pi, 200001)
    for delta in (wheel_singular_delta(r, l, rho) * (1 - 1e-6),
                  wheel_singular_delta(r, l, rho) * (1 + 1e-6)):
        bracket = rho ** 2 + r ** 2 + l ** 2 - 2 * r * l * np.cos(phi) + delta * l * np.sin(phi)
        assert (bracket.min() <= 0) == (delta > wheel_singular_delta(r, l, rho))
    assert wheel_singular_delta(r, l, rho) == pytest.approx(math.sqrt(1.25) / 0.5)
    f = np.linspace(0, 5, 5001)
    lam_min = (3 - np.sqrt(1 + f ** 2)) / 2
    assert f[np.argmax(lam_min <= 0)] == pytest.approx(elliptic_threshold(), abs=1e-3)
