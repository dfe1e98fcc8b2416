"""Long work from Python: estimate first, refuse what will not fit, show progress, stop on Ctrl-C.

The children here run phasemap as a user's script does; the scenes are
chosen so that the old behaviour (a fate map as one kernel call, a sample
timed in one call) would run for minutes where the new one stops at once.
"""

from __future__ import annotations

import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import phasemap
from phasemap.maps import blocks

ROOT = pathlib.Path(__file__).resolve().parents[1]

def env(**extra) -> dict:
    e = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH",
                                                                                "")]))
    e.update(extra)
    return e


def start(code: str, **extra) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", code], env=env(**extra), text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=1)


def wait_for(proc: subprocess.Popen, stream, text: str) -> str:
    seen = ""
    while text not in seen:
        ch = stream.read(1)
        assert ch, seen + proc.communicate()[1]
        seen += ch
    return seen


# ------------------------------------------------------------- estimate ---------
def test_the_estimate_gives_cells_bytes_memory_and_time():
    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 300),
                                           "f": np.linspace(0, 3, 200)},
                           layers=["n_solutions", "phi_ddot_slide_pos"])
    est = scene.estimate()
    assert est.cells == 60_000 and est.bytes == 60_000 * 9
    assert est.seconds > 0 and est.memory >= est.resident + est.bytes
    text = est.text(scene)
    assert "60,000 cells (300 phi x 200 f)" in text and "memory about" in text
    assert "time about" in text
    assert scene.estimate(timed=False).seconds is None


def test_a_scene_that_will_not_fit_in_memory_is_refused_before_any_work(monkeypatch):
    scene = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 40_000),
                                           "f": np.linspace(0, 3, 25_000)},
                           layers=["n_solutions", *[n for n in phasemap.layers_for("ladder")
                                                    if n.startswith("N_")][:12]])
    est = scene.estimate(timed=False)
    assert est.bytes == 10 ** 9 * (1 + 8 * 12)

    def no_work(*args, **kwargs):
        raise AssertionError("work started")

    monkeypatch.setattr(scene, "evaluate", no_work)
    with pytest.raises(ValueError) as err:
        scene.compute()
    message = str(err.value)
    assert "\n" not in message and "chunks=" in message and "phasemap atlas" in message
    assert "more memory" in message
    # a small scene is refused too where little memory is left
    small = phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, 1000),
                                           "f": np.linspace(0, 3, 1000)})
    monkeypatch.setattr(blocks, "available_memory", lambda: 1_000_000)
    with pytest.raises(ValueError, match="is available"):
        small.compute()


MEASURE = """
import numpy as np, phasemap
def scene(n):
    return phasemap.Scene("ladder", axes={"phi": np.linspace(0, 1.5, n),
                          "f": np.linspace(0, 3, n)},
                          layers=["n_solutions", "phi_ddot_slide_pos"])
scene(2).compute()   # compiled (compiling can take more memory than the work)
with open("/proc/self/clear_refs", "w") as fh:
    fh.write("5")    # the peak resident memory starts again from here
est = scene(N).estimate()
scene(N).compute()
with open("/proc/self/status") as fh:
    peak = [int(line.split()[1]) * 1024 for line in fh if line.startswith("VmHWM:")][0]
print(est.memory, peak)
"""


#: Runs the command line and prints its peak resident memory (bytes) after its stderr.
CLI_PEAK = """
import resource, subprocess, sys
r = subprocess.run([sys.executable, "-m", "phasemap.cli", *sys.argv[1:]], capture_output=True,
                   text=True)
print(r.stderr, r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024)
"""


@pytest.mark.slow
@pytest.mark.parametrize("side", [1, 2000])
def test_the_memory_estimate_is_near_the_measured_peak(side, tmp_path):
    """The estimate against the measured peak, kernels compiled: in Python with the whole
    result in memory, and on the command line block by block (its second run); a 1-cell
    map and 4 * 10^6 cells of one int8 and one float layer (36 MB)."""
    r = subprocess.run([sys.executable, "-c", MEASURE.replace("N", str(side))],
                       capture_output=True, text=True, env=env(), timeout=600)
    assert r.returncode == 0, r.stderr
    estimated, peak = map(int, r.stdout.split())
    assert 0.8 * peak <= estimated <= 1.25 * peak, (estimated, peak)
    for _ in range(2):
        r = subprocess.run([sys.executable, "-c", CLI_PEAK, "atlas", "ladder", "--axis",
                            f"phi=0:1.5:{side}", "--axis", f"f=0:3:{side}", "--layers",
                            "n_solutions,phi_ddot_slide_pos", "--overwrite", "-o",
                            str(tmp_path / "a.nc")], capture_output=True, text=True,
                           env=env(PHASEMAP_PROGRESS="never"), timeout=600)
    *err, code, peak = r.stdout.split()
    assert code == "0", r.stdout
    size, unit = re.search(r"memory about ([\d.]+) (MB|GB)", " ".join(err)).groups()
    estimated = float(size) * (1e6 if unit == "MB" else 1e9)
    # the command line's estimate counts the kernels and the netCDF writer at their
    # measured highs (blocks.KERNEL_BYTES, WRITER_BYTES: 125 and 65 MB) before it knows
    # whether the kernels load from the cache; at 36 MB of output those fixed costs are
    # most of the peak, which it overstates by 22 % here and 29 % in a CI replay (256 MB
    # measured, 331 MB estimated).  Over by a third at most; under by a fifth at most.
    assert 0.8 * int(peak) <= estimated <= 1.35 * int(peak), (estimated, peak)


@pytest.mark.slow
def test_the_memory_estimate_of_a_billion_cell_atlas_is_near_its_peak(tmp_path):
    """Issue 44: the writer's chunk index grows with the atlas; with the writer counted
    at 25 MB the estimate of 10^9 cells was 20 % below the measured peak (4 * 10^9: 24 %,
    2 * 10^10 as reported: 35 %).  One int8 layer, written block by block, kernels
    loaded (by a first run of 8^2 cells of the same scene, which compiles them)."""
    for n in (8, 31623):
        r = subprocess.run([sys.executable, "-c", CLI_PEAK, "atlas", "ladder", "--axis",
                            f"phi=0:1.5707963:{n}", "--axis", f"f=0:3:{n}", "--set",
                            "omega=1", "--yes", "--overwrite", "-o", str(tmp_path / "a.nc")],
                           capture_output=True, text=True,
                           env=env(PHASEMAP_PROGRESS="never"), timeout=900)
    *err, code, peak = r.stdout.split()
    assert code == "0", r.stdout
    size, unit = re.search(r"memory about ([\d.]+) (MB|GB)", " ".join(err)).groups()
    estimated = float(size) * (1e6 if unit == "MB" else 1e9)
    assert 0.85 * int(peak) <= estimated <= 1.25 * int(peak), (estimated, peak)


# ------------------------------------------------------------- progress ---------
# about 3 s of work with its kernels loaded (0.7 s at t_end = 300, less than the bar's
# one-second delay: the test passed only where the integrator had to compile first)
PROGRESS = """
import numpy as np, phasemap
phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, 29),
               "omega": np.linspace(-6, 6, 29)}, fixed={"delta": 0.0}, layers=["fate"],
               options={"t_end": 1500.0}).compute()
print("done")
"""


def test_long_python_work_shows_a_bar_only_in_an_interactive_session():
    import fcntl
    import pty
    import struct
    import termios

    main, sub = pty.openpty()   # stderr is a terminal: an interactive session
    fcntl.ioctl(sub, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    tty = subprocess.Popen([sys.executable, "-c", PROGRESS], env=env(PHASEMAP_PROGRESS=""),
                           stdout=subprocess.PIPE, stderr=sub, text=True)
    os.close(sub)
    shown = b""
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:
            break
        if not chunk:
            break
        shown += chunk
    tty.wait(timeout=600)
    os.close(main)
    assert tty.returncode == 0 and tty.stdout.read().strip() == "done"
    assert re.search(rb"hinge_pendulum atlas: +\d+%\|", shown), shown[-500:]
    piped = subprocess.run([sys.executable, "-c", PROGRESS], capture_output=True, text=True,
                           env=env(PHASEMAP_PROGRESS=""), timeout=600)
    assert piped.returncode == 0 and piped.stdout.strip() == "done"
    assert piped.stderr == ""   # silent where no one watches


# ------------------------------------------------------------- Ctrl-C -----------
def interrupt(proc: subprocess.Popen, after: float, doing: str) -> tuple[str, str]:
    """Send Ctrl-C ``after`` seconds; the child must end within 30 s (it has minutes of
    work left in one kernel call if it does not check between blocks)."""
    time.sleep(after)
    proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"still {doing} 30 s after Ctrl-C")


#: A fate map whose cells are long trajectories (no friction: the pendulum never rests;
#: about 0.2 s of integration per cell), so that one kernel call over it takes minutes.
CTRL_C = """
import numpy as np, phasemap
def scene(n):
    return phasemap.Scene("hinge_pendulum", axes={"phi": np.linspace(-3, 3, n),
                          "omega": np.linspace(-6, 6, n)}, fixed={"delta": 0.0},
                          layers=["fate"], options={"t_end": 2e4})
scene(1).compute()   # compiled
print("computing", flush=True)
scene(41).compute()
print("finished")
"""


@pytest.mark.slow
@pytest.mark.parametrize("attempt", range(3))
def test_ctrl_c_interrupts_a_fate_map_from_python(attempt):
    """One kernel call over these 1681 cells takes minutes; in blocks, KeyboardInterrupt
    arrives between two of them."""
    proc = start(CTRL_C)
    wait_for(proc, proc.stdout, "computing")
    out, err = interrupt(proc, 1.0 + attempt, "computing")   # the kernel is running
    assert "KeyboardInterrupt" in err and "finished" not in out, err[-2000:]


@pytest.mark.slow
def test_ctrl_c_stops_the_command_line_while_it_times_its_sample(tmp_path):
    args = ["atlas", "hinge_pendulum", "--axis", "phi=-3:3:41", "--axis", "omega=-6:6:41",
            "--set", "delta=0", "--layers", "fate", "--option", "t_end=4e4", "-o", "f.nc"]
    proc = subprocess.Popen([sys.executable, "-m", "phasemap.cli", *args], cwd=tmp_path,
                            env=env(PHASEMAP_PROGRESS="always"), text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, bufsize=1)
    wait_for(proc, proc.stderr, "sample cells")   # timing them: 0.4 s of work per cell
    _, err = interrupt(proc, 1.0, "timing its sample")
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "phasemap: interrupted; no partial file was left"
    assert list(tmp_path.iterdir()) == []


def test_an_activity_line_ticks_while_nothing_else_prints(capsys):
    from phasemap.core import progress

    # forced: capsys's stderr is no terminal, where the command line's ticker is silent
    with progress.enable(True, force=True), progress.activity("waiting"):
        time.sleep(2.2)   # a wait with no count, like numba compiling
        progress.status("still waiting")
        time.sleep(1.2)
    err = capsys.readouterr().err
    assert "waiting [00:01]" in err and "waiting: still waiting [00:03]" in err
