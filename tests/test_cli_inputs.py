"""The command line meets a new user without a traceback (issue 23 item 7).

Each test failed on the code before: a BrokenPipeError traceback under
``| head``, cfchecks' traceback for a file that is not netCDF, the help's own
``--axis phi=0:1.5708:1024`` refused, no "did you mean", the whole layer list
on one line, values without units and a stick acceleration printed as 8.9e-16.
"""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from phasemap import cli

RUN = [sys.executable, "-m", "phasemap.cli"]


def run(*args, cwd=None):
    return subprocess.run([*RUN, *args], capture_output=True, text=True, cwd=cwd)


def test_a_closed_pipe_ends_quietly():
    """``phasemap classify ... | head`` with the reader gone before the output."""
    proc = subprocess.Popen([*RUN, "classify", "ladder", "phi=0.5", "omega=0"],
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
    import xarray as xr

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
    assert "phi_ddot=0 rad s-2," in stick and "N_floor=9.94539 N" in stick


@pytest.mark.parametrize("text, value", [("pi/2", math.pi / 2), ("-2*pi/3", -2 * math.pi / 3),
                                         ("1e-3", 1e-3)])
def test_values_are_read_with_pi(text, value):
    assert cli._parse_values([f"f={text}"]) == {"f": value}


def test_values_refuse_code():
    with pytest.raises(ValueError, match="is not a number"):
        cli._parse_values(["phi=__import__('os').getcwd()"])
