"""Atlas files: netCDF round trip, encoding, atomic writes, summaries, CF compliance.

The atlases here are synthetic (random layers on made-up axes) so that these
tests exercise only :mod:`phasemap.atlas`, not the grid evaluator.
"""

from __future__ import annotations

import errno
import json
import os
import pathlib
import re
import subprocess
import sys
import threading
import time

import netCDF4
import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import cfchecks, require_tool

import phasemap
from phasemap.atlas import atomic, dataset, read, write
from phasemap.atlas.atomic import atomic_path
from phasemap.atlas.read import describe_atlas
from phasemap.atlas.write import cf_encoding, write_atlas

AXES = {  # name: (units, long_name, lower, upper)
    "phi": ("rad", "inclination angle", 0.0, 1.5),
    "f": ("1", "coefficient of friction", 0.0, 2.0),
    "omega": ("rad s-1", "angular velocity", -1.0, 1.0),
    "xdot": ("m s-1", "slider velocity", -2.0, 2.0),
}
FIXED = {"m": 1.0, "l": 1.0, "g": 9.81}
FLAGS = {  # name: (flag_values, flag_meanings, long_name)
    "n_solutions": ([0, 1, 2, 3, 4], "none unique two continuum three_or_more",
                    "number of solutions for the senior derivatives"),
    "stagnation": ([0, 1], "no yes", "stagnation: the stick branch is admissible"),
    "contact_lost": ([0, 1], "no yes", "a branch needs a one-sided contact to pull"),
    "singular": ([0, 1], "no yes", "the coefficient of the senior derivative vanishes"),
}
FLOATS = {  # name: (units, long_name)
    "phi_ddot_slide_pos": ("rad s-2", "angular acceleration, sliding in the positive direction"),
    "N_floor_stick": ("m s-2", "floor reaction per unit mass, sticking"),
    "coef_slide_neg": ("1", "coefficient of the senior derivative, sliding in the negative direction"),
}


def make_atlas(shape=(17, 11), seed=0) -> xr.Dataset:
    """A synthetic atlas over the first ``len(shape)`` axes of AXES."""
    rng = np.random.default_rng(seed)
    names = list(AXES)[: len(shape)]
    coords = {}
    for i, (name, n) in enumerate(zip(names, shape)):
        units, long_name, lo, hi = AXES[name]
        x = np.linspace(lo, hi, n)
        if i == 1 and n > 2:  # non-uniform: denser near the lower end
            x = lo + (hi - lo) * np.linspace(0.0, 1.0, n) ** 2
        coords[name] = (name, x, {"units": units, "long_name": long_name})
    data = {}
    for name, (values, meanings, long_name) in FLAGS.items():
        data[name] = (names, rng.choice(np.array(values, np.int8), size=shape),
                      {"long_name": long_name, "flag_values": np.array(values, np.int8),
                       "flag_meanings": meanings})
    for name, (units, long_name) in FLOATS.items():
        x = rng.normal(size=shape)
        x[rng.random(shape) < 0.3] = np.nan
        data[name] = (names, x, {"units": units, "long_name": long_name})
    scene = {"model": "ladder", "axes": {n: [float(c[1][0]), float(c[1][-1]), len(c[1])]
                                         for n, c in coords.items()},
             "fixed": FIXED, "layers": list(data)}
    attrs = {
        "Conventions": dataset.CONVENTIONS,
        "title": "ladder: solvability map",
        "source": "phasemap 0.1.0",
        "history": "2026-01-01T00:00:00Z phasemap scene compute",
        "phasemap_model": "ladder",
        "phasemap_version": "0.1.0",
        "phasemap_scene": json.dumps(scene),
        "date_created": "2026-01-01T00:00:00Z",
        **{f"phasemap_fixed_{k}": v for k, v in FIXED.items()},
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def read_back(path) -> xr.Dataset:
    with xr.open_dataset(path) as ds:
        return ds.load()


def snapshot(ds: xr.Dataset):
    return ds.copy(deep=True), {k: dict(v.encoding) for k, v in ds.variables.items()}


def folder_listing(path):
    return sorted(os.listdir(path))


# --------------------------------------------------------------------------- round trip


@pytest.mark.parametrize("shape", [(23,), (17, 11), (7, 6, 5), (5, 4, 3, 6)])
def test_round_trip_is_identical(tmp_path, shape):
    ds = make_atlas(shape)
    before, encodings = snapshot(ds)
    out = write_atlas(ds, tmp_path / "atlas.nc")
    assert out == tmp_path / "atlas.nc"
    back = read_back(out)
    xr.testing.assert_identical(back, ds)
    for name in FLAGS:
        assert back[name].dtype == np.int8
    # the caller's dataset is untouched, encoding included
    xr.testing.assert_identical(ds, before)
    assert {k: dict(v.encoding) for k, v in ds.variables.items()} == encodings


def test_round_trip_of_a_dask_backed_atlas(tmp_path):
    ds = make_atlas((40, 30)).chunk({"phi": 16, "f": 8})
    write_atlas(ds, tmp_path / "atlas.nc")
    xr.testing.assert_identical(read_back(tmp_path / "atlas.nc"), ds.compute())
    assert ds["n_solutions"].chunks is not None  # still lazy: the writer did not load it


def test_rewriting_an_opened_atlas_ignores_its_stale_encoding(tmp_path):
    write_atlas(make_atlas(), tmp_path / "a.nc", chunks={"phi": 3})
    with xr.open_dataset(tmp_path / "a.nc") as ds:
        write_atlas(ds, tmp_path / "b.nc")
        expected = ds.load()
    xr.testing.assert_identical(read_back(tmp_path / "b.nc"), expected)
    with netCDF4.Dataset(tmp_path / "b.nc") as nc:
        assert nc["n_solutions"].chunking() == [17, 11]


def test_missing_provenance_is_added_and_existing_kept(tmp_path):
    ds = make_atlas()
    for key in ("Conventions", "date_created", "history", "source", "phasemap_version"):
        del ds.attrs[key]
    ds["stagnation"].attrs["flag_values"] = [0, 1]  # a list: stored as int8 all the same
    write_atlas(ds, tmp_path / "atlas.nc")
    back = read_back(tmp_path / "atlas.nc")
    assert back.attrs["Conventions"] == dataset.CONVENTIONS
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", back.attrs["date_created"])
    assert "phasemap" in back.attrs["history"]
    assert back.attrs["phasemap_version"] == phasemap.__version__
    assert back.attrs["phasemap_model"] == "ladder"
    assert back["stagnation"].attrs["flag_values"].dtype == np.int8
    assert "Conventions" not in ds.attrs  # the caller's dataset is untouched


def test_attributes_netcdf_cannot_store_are_refused(tmp_path):
    ds = make_atlas()
    ds.attrs["interesting"] = True
    with pytest.raises(ValueError, match="interesting"):
        write_atlas(ds, tmp_path / "atlas.nc")
    ds = make_atlas()
    ds["N_floor_stick"].attrs["_FillValue"] = np.nan
    with pytest.raises(ValueError, match="encoding"):
        write_atlas(ds, tmp_path / "atlas.nc")
    assert folder_listing(tmp_path) == []


# --------------------------------------------------------------------------- encoding


def test_encoding_on_disk(tmp_path):
    write_atlas(make_atlas((7, 6, 5)), tmp_path / "atlas.nc", complevel=6)
    with netCDF4.Dataset(tmp_path / "atlas.nc") as nc:
        assert nc.data_model == "NETCDF4"
        for name in list(FLAGS) + list(FLOATS):
            v = nc[name]
            filters = v.filters()
            assert filters["zlib"] and filters["complevel"] == 6 and filters["shuffle"]
            assert v.chunking() == [7, 6, 5]
        for name in FLAGS:
            assert nc[name].dtype == np.int8
            assert "_FillValue" not in nc[name].ncattrs()
            assert "units" not in nc[name].ncattrs()
            assert nc[name].getncattr("flag_values").dtype == np.int8
        for name in FLOATS:
            assert nc[name].dtype == np.float64
            assert np.isnan(nc[name].getncattr("_FillValue"))
        for name in ("phi", "f", "omega"):
            assert "_FillValue" not in nc[name].ncattrs()
            assert nc[name].dtype == np.float64


def test_default_chunks_are_capped_and_explicit_chunks_win():
    import dask.array as da

    big = xr.Dataset(
        {"n_solutions": (("phi", "f"), da.zeros((3000, 2000), dtype=np.int8, chunks=(1024, 1024))),
         "coef": (("phi", "f"), da.zeros((3000, 2000), chunks=(3000, 2000)))},
        coords={"phi": np.arange(3000.0), "f": np.arange(2000.0)})
    enc = cf_encoding(big)
    assert enc["n_solutions"]["chunksizes"] == (1024, 1024)  # the dask chunk, exactly 1 MiB
    c = enc["coef"]["chunksizes"]
    assert np.prod(c) * 8 <= write.CHUNK_BYTES and c[0] <= 3000 and c[1] <= 2000
    assert enc["phi"] == {"_FillValue": None}
    assert cf_encoding(big, {"f": 5000})["coef"]["chunksizes"][1] == 2000  # clipped to the size
    with pytest.raises(ValueError, match="dimension"):
        cf_encoding(big, {"x": 4})
    with pytest.raises(ValueError, match="positive"):
        cf_encoding(big, {"f": 0})


@settings(max_examples=200, deadline=None)
@given(shape=st.lists(st.integers(1, 5000), min_size=1, max_size=4),
       itemsize=st.sampled_from([1, 8]))
def test_default_chunk_shape_fits(shape, itemsize):
    chunk = write.default_chunks(tuple(shape), itemsize)
    assert all(1 <= c <= n for c, n in zip(chunk, shape))
    assert np.prod(chunk, dtype=np.int64) * itemsize <= write.CHUNK_BYTES


# --------------------------------------------------------------------------- atomicity


def _failing_atlas(shape=(64, 32)):
    """A dask-backed atlas whose last block raises while it is being written."""
    import dask.array as da

    ds = make_atlas(shape)

    def boom(block, block_info=None):
        if block_info[0]["chunk-location"] == (1, 1):
            raise RuntimeError("evaluator failed midway")
        return block

    data = da.from_array(ds["N_floor_stick"].values, chunks=(32, 16))
    ds["N_floor_stick"] = (ds["N_floor_stick"].dims, data.map_blocks(boom, dtype=float),
                           ds["N_floor_stick"].attrs)
    return ds


#: Races with writer threads show in some runs only: each such test runs this many times.
REPEATS = 10


@pytest.mark.parametrize("attempt", range(REPEATS))
def test_a_failed_write_leaves_no_file_and_no_temporary(tmp_path, attempt):
    with pytest.raises(RuntimeError, match="midway"):
        write_atlas(_failing_atlas(), tmp_path / "atlas.nc")
    assert folder_listing(tmp_path) == []


@pytest.mark.parametrize("attempt", range(REPEATS))
def test_a_failed_write_keeps_the_existing_file(tmp_path, attempt):
    path = write_atlas(make_atlas(seed=1), tmp_path / "atlas.nc")
    original = path.read_bytes()
    with pytest.raises(RuntimeError, match="midway"):
        write_atlas(_failing_atlas(), path)
    assert folder_listing(tmp_path) == ["atlas.nc"]
    assert path.read_bytes() == original


def test_an_interrupted_write_keeps_the_existing_file(tmp_path, monkeypatch):
    path = write_atlas(make_atlas(seed=1), tmp_path / "atlas.nc")
    original = path.read_bytes()
    real = xr.Dataset.to_netcdf

    def partial_then_interrupt(self, target, *args, **kwargs):
        real(self, target, *args, **kwargs)
        os.truncate(target, os.path.getsize(target) // 2)  # as if cut off halfway
        raise KeyboardInterrupt

    monkeypatch.setattr(xr.Dataset, "to_netcdf", partial_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        write_atlas(make_atlas(seed=2), path)
    assert folder_listing(tmp_path) == ["atlas.nc"]
    assert path.read_bytes() == original


def _signalling_atlas(signum, times=1):
    """A dask-backed atlas whose second block sends ``signum`` to this process ``times`` times
    (from a writer thread, as a signal arrives while netCDF holds its locks)."""
    import signal

    import dask.array as da

    ds = make_atlas((64, 32))

    def send(block, block_info=None):
        if block_info[0]["chunk-location"] == (0, 1):
            for _ in range(times):
                signal.pthread_kill(threading.main_thread().ident, signum)
                time.sleep(0.05)
        return block

    data = da.from_array(ds["N_floor_stick"].values, chunks=(32, 16))
    ds["N_floor_stick"] = (ds["N_floor_stick"].dims, data.map_blocks(send, dtype=float),
                           ds["N_floor_stick"].attrs)
    return ds


@pytest.mark.parametrize("attempt", range(3))
@pytest.mark.parametrize("times", [1, 2])
def test_ctrl_c_during_a_dask_write_is_raised_at_a_safe_point(tmp_path, attempt, times):
    # a KeyboardInterrupt raised inside netCDF's locked sections left a lock held and
    # the file's close waiting forever; now it comes out of dask's loop or at the end
    import signal

    path = write_atlas(make_atlas(seed=1), tmp_path / "atlas.nc")
    original = path.read_bytes()
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        write_atlas(_signalling_atlas(signal.SIGINT, times), path)
    assert signal.getsignal(signal.SIGINT) is before
    assert folder_listing(tmp_path) == ["atlas.nc"]
    assert path.read_bytes() == original


def test_a_signal_deferred_in_an_eager_block_ends_it_and_a_handler_of_our_own_is_kept():
    import signal

    with pytest.raises(KeyboardInterrupt):
        with atomic.signals_deferred():
            signal.raise_signal(signal.SIGINT)
            done = True  # the block ran to its end: the signal waited
    assert done
    seen = []
    previous = signal.signal(signal.SIGINT, lambda *a: seen.append(a[0]))
    try:
        with atomic.signals_deferred():
            signal.raise_signal(signal.SIGINT)
        assert seen == [signal.SIGINT]  # the program's own handler ran, nothing was raised
    finally:
        signal.signal(signal.SIGINT, previous)


def test_atomic_path_for_a_chunked_writer(tmp_path):
    path = tmp_path / "atlas.nc"
    with atomic_path(path) as tmp:
        assert tmp.parent == tmp_path and tmp.exists() and not path.exists()
        with netCDF4.Dataset(tmp, "w") as nc:
            nc.createDimension("phi", 3)
            nc.createVariable("phi", "f8", ("phi",))[:] = [0.0, 1.0, 2.0]
    assert folder_listing(tmp_path) == ["atlas.nc"]
    umask = atomic._umask()
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
    with pytest.raises(ZeroDivisionError):
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"half an atlas")
            1 / 0
    assert folder_listing(tmp_path) == ["atlas.nc"]
    with netCDF4.Dataset(path) as nc:
        assert list(nc["phi"][:]) == [0.0, 1.0, 2.0]


def test_our_temporary_files_older_than_a_day_are_removed_when_writing_beside_them(tmp_path):
    day = atomic.STALE_PART_SECONDS
    old, fresh = ".phasemap.abcd1234.part", ".phasemap.efgh5678.part"
    others = [".notes.abcd1234.part", ".phasemap.short.part", "phasemap.abcd1234.part"]
    for name in [old, fresh, *others]:
        (tmp_path / name).write_bytes(b"left over")
    stamp = os.path.getmtime(tmp_path / old) - day - 60
    for name in [old, *others]:
        os.utime(tmp_path / name, (stamp, stamp))
    write_atlas(make_atlas(), tmp_path / "atlas.nc")
    assert folder_listing(tmp_path) == sorted(["atlas.nc", fresh, *others])


def test_a_long_legal_file_name_can_be_written(tmp_path):
    from phasemap.maps.blocks import check_output

    name = "a" * 238 + ".nc"   # 241 bytes: open() takes it; a temporary name must be short
    assert len(name.encode()) == 241
    with open(tmp_path / name, "wb"):
        pass
    os.unlink(tmp_path / name)
    check_output(tmp_path / name, overwrite=False)
    path = write_atlas(make_atlas(), tmp_path / name)
    assert folder_listing(tmp_path) == [name]
    xr.testing.assert_identical(read_back(path), make_atlas())


@pytest.mark.parametrize("how", ["renameat2", "link", "check and rename"])
def test_without_overwrite_a_file_that_appeared_meanwhile_is_kept(tmp_path, monkeypatch, how):
    """The last step is exclusive: another writer's file, created while ours was being
    written, is never replaced (renameat2's RENAME_NOREPLACE, else a hard link)."""
    def unsupported(*args):
        raise OSError(errno.EINVAL, "not supported here")

    if how != "renameat2":
        monkeypatch.setattr(atomic, "_renameat2_noreplace", unsupported)
    if how == "check and rename":
        monkeypatch.setattr(os, "link", lambda *args: unsupported())
    path = tmp_path / "atlas.nc"
    with pytest.raises(ValueError, match=r"exists; pass overwrite=True \(--overwrite"):
        with atomic_path(path, overwrite=False) as tmp:
            tmp.write_bytes(b"ours")
            path.write_bytes(b"theirs")   # another writer finished first
    assert path.read_bytes() == b"theirs" and folder_listing(tmp_path) == ["atlas.nc"]
    path.unlink()
    with atomic_path(path, overwrite=False) as tmp:
        tmp.write_bytes(b"ours")
    assert path.read_bytes() == b"ours" and folder_listing(tmp_path) == ["atlas.nc"]
    with pytest.raises(ValueError, match=r"exists; pass overwrite=True \(--overwrite"):
        write_atlas(_failing_atlas(), path, overwrite=False)   # refused before any work
    assert path.read_bytes() == b"ours"


#: A child that writes a slow dask-backed atlas (64 blocks of 0.2 s each: several seconds
#: even on two threads, so a signal sent from a starved parent on a loaded machine still
#: arrives mid-write; the signal ends it long before).
SLOW_WRITE = """
import sys, time
import dask.array as da, numpy as np, xarray as xr
import phasemap

def slow(block):
    time.sleep(0.2)
    return block

data = da.zeros((64, 64), chunks=(8, 8), dtype=np.int8).map_blocks(slow, dtype=np.int8)
ds = xr.Dataset({"n_solutions": (("phi", "f"), data, {"long_name": "solutions"})},
                coords={"phi": ("phi", np.linspace(0, 1, 64), {"units": "rad"}),
                        "f": ("f", np.linspace(0, 1, 64), {"units": "1"})},
                attrs={"phasemap_model": "ladder"})
phasemap.write_atlas(ds, sys.argv[1])
"""


@pytest.mark.slow
@pytest.mark.parametrize("attempt", range(2))
@pytest.mark.parametrize("signame", ["SIGTERM", "SIGHUP", "SIGINT"])
def test_a_signal_that_ends_the_process_leaves_no_temporary_file(tmp_path, signame, attempt):
    import signal
    import sys
    import time

    script = tmp_path / "slow_write.py"
    script.write_text(SLOW_WRITE)
    out = tmp_path / "out"
    out.mkdir()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(pathlib.Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")]))
    def default_disposition():  # a signal the test runner ignores is not ignored here
        signal.signal(getattr(signal, signame), signal.SIG_DFL)

    proc = subprocess.Popen([sys.executable, str(script), str(out / "atlas.nc")], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_disposition)
    deadline = time.monotonic() + 120
    while not list(out.glob("*.part")):   # the write is under way
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    time.sleep(0.3)
    sig = getattr(signal, signame)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode != 0, err
    if signame != "SIGINT":
        assert proc.returncode == 128 + sig and "Traceback" not in err, err
    assert folder_listing(out) == []


def test_a_missing_folder_is_a_value_error_before_any_work(tmp_path):
    missing = tmp_path / "no" / "such"
    with pytest.raises(ValueError, match=re.escape(str(missing))):
        write_atlas(_failing_atlas(), missing / "atlas.nc")  # the compute error never happens
    with pytest.raises(ValueError, match="does not exist"):
        with atomic_path(missing / "atlas.nc"):
            pass
    with pytest.raises(ValueError, match="is a folder"):
        write_atlas(make_atlas(), tmp_path)
    assert folder_listing(tmp_path) == []


# --------------------------------------------------------------------------- describe


def _class_counts(text: str, layer: str) -> dict[str, int]:
    """Parse the class lines under ``layer`` in describe_atlas's output."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"  {layer} ("))
    counts = {}
    for line in lines[start + 1:]:
        m = re.fullmatch(r"    (\S+)\s+(-?\d+)\s+(\d+)\s+([\d.]+)%", line)
        if not m:
            break
        counts[m[1]] = int(m[3])
    return counts


@pytest.mark.parametrize("shape", [(17, 11), (5, 4, 3, 6)])
def test_describe_counts_every_cell_once(tmp_path, shape):
    ds = make_atlas(shape)
    path = write_atlas(ds, tmp_path / "atlas.nc")
    text = describe_atlas(path)
    cells = int(np.prod(shape))
    assert f"cells     {cells} =" in text
    assert "model     ladder" in text and "phasemap 0.1.0, 2026-01-01T00:00:00Z" in text
    assert "uniform, step" in text and "non-uniform" in text
    assert re.search(r"^  g\s+=\s+9\.81$", text, re.M)
    for name, (values, meanings, _) in FLAGS.items():
        counts = _class_counts(text, name)
        assert list(counts) == meanings.split()
        assert sum(counts.values()) == cells
        expected = [int((ds[name].values == v).sum()) for v in values]
        assert list(counts.values()) == expected
    for name, (units, _) in FLOATS.items():
        finite = int(np.isfinite(ds[name].values).sum())
        assert f"  {name} (float64, {units}):" in text and f"defined on {finite} cells" in text
    assert describe_atlas(ds).splitlines()[1:] == text.splitlines()[1:]


def test_describe_counts_in_slabs(tmp_path, monkeypatch):
    monkeypatch.setattr(read, "_SLAB_BYTES", 40)  # a few rows at a time
    ds = make_atlas((17, 11))
    counts = _class_counts(describe_atlas(write_atlas(ds, tmp_path / "atlas.nc")), "n_solutions")
    assert list(counts.values()) == [int((ds["n_solutions"].values == v).sum()) for v in range(5)]


def test_describe_reports_values_outside_the_flags():
    ds = make_atlas((17, 11))
    ds["singular"][0, :3] = 7
    counts = _class_counts(describe_atlas(ds), "singular")
    assert counts["(unlisted)"] == 3 and sum(counts.values()) == 17 * 11


def test_describe_refuses_what_is_not_an_atlas(tmp_path):
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(tmp_path / "plain.nc")
    (tmp_path / "text.nc").write_text("not netCDF\n")
    for name, why in [("plain.nc", "not a phasemap atlas"), ("text.nc", "not a readable netCDF"),
                      ("missing.nc", "no such file")]:
        with pytest.raises(ValueError, match=why) as err:
            describe_atlas(tmp_path / name)
        assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="not a phasemap atlas"):
        describe_atlas(xr.Dataset({"a": ("x", np.arange(3.0))}))


# --------------------------------------------------------------------------- external tools


@pytest.mark.parametrize("shape", [(23,), (17, 11), (5, 4, 3, 6)])
def test_cfchecker_finds_no_errors_and_no_warnings(tmp_path, shape):
    path = write_atlas(make_atlas(shape), tmp_path / "atlas.nc")
    report = cfchecks(path, tmp_path)
    assert "ERRORS detected: 0" in report, report
    assert "WARNINGS given: 0" in report, report
    assert f"Checking against CF Version {dataset.CONVENTIONS}" in report, report


def test_ncdump_prints_the_header(tmp_path):
    require_tool("ncdump", "Debian netcdf-bin")
    path = write_atlas(make_atlas((5, 4, 3)), tmp_path / "atlas.nc")
    run = subprocess.run(["ncdump", "-h", str(path)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    header = run.stdout
    assert "byte n_solutions(phi, f, omega)" in header
    assert 'n_solutions:flag_meanings = "none unique two continuum three_or_more"' in header
    assert "n_solutions:flag_values = 0b, 1b, 2b, 3b, 4b" in header
    assert f':Conventions = "{dataset.CONVENTIONS}"' in header
    assert ':phasemap_model = "ladder"' in header


def _special_files(folder: pathlib.Path) -> dict[str, pathlib.Path]:
    """A FIFO, and where this process may make one (root), a character device that is a
    copy of /dev/null: names a writer must never replace (issue 44 item 3)."""
    import stat as st_

    made = {"fifo": folder / "pipe.nc"}
    os.mkfifo(made["fifo"])
    try:
        os.mknod(folder / "null.nc", 0o666 | st_.S_IFCHR, os.stat("/dev/null").st_rdev)
        made["device"] = folder / "null.nc"
    except (PermissionError, OSError):
        pass
    return made


def test_a_device_or_fifo_is_never_replaced_even_with_overwrite(tmp_path):
    import stat as st_

    special = _special_files(tmp_path)
    ds = xr.Dataset({"n": (("x",), np.arange(3, dtype=np.int8), {"long_name": "n"})})
    for kind, path in special.items():
        before = os.lstat(path).st_mode
        with pytest.raises(ValueError, match=f"it is a {'FIFO' if kind == 'fifo' else 'device'}"
                           ", which phasemap never replaces"):
            write_atlas(ds, path, overwrite=True)
        with pytest.raises(ValueError, match="never replaces"):
            with atomic_path(path, overwrite=True) as tmp:
                tmp.write_bytes(b"x")
        assert os.lstat(path).st_mode == before
        assert st_.S_ISFIFO(before) or st_.S_ISCHR(before)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in special.values())
    # a name that becomes a FIFO while the file is written is not replaced either
    late = tmp_path / "late.nc"
    with pytest.raises(ValueError, match="never replaces"):
        with atomic_path(late, overwrite=True) as tmp:
            tmp.write_bytes(b"x")
            os.mkfifo(late)
    assert st_.S_ISFIFO(os.lstat(late).st_mode)
    # a symbolic link is replaced as a name; its target is left alone
    target = tmp_path / "target.nc"
    target.write_bytes(b"precious")
    link = tmp_path / "link.nc"
    link.symlink_to(target)
    write_atlas(ds, link, overwrite=True)
    assert target.read_bytes() == b"precious" and not link.is_symlink()


def test_the_command_line_refuses_to_replace_a_fifo(tmp_path):
    special = _special_files(tmp_path)
    for path in special.values():
        for args in (["atlas", "ladder", "--axis", "phi=0:1:5", "--overwrite", "-o", path.name],
                     ["simulate", "ladder", "phi=1", "--overwrite", "-o", path.name]):
            done = subprocess.run([sys.executable, "-m", "phasemap.cli", *args], cwd=tmp_path,
                                  capture_output=True, text=True, timeout=600)
            assert done.returncode == 2, (args, done.stderr)
            assert done.stderr.strip().splitlines() == [
                f"phasemap: error: cannot write {path.name}: it is a "
                f"{'FIFO' if path == special['fifo'] else 'device'}, which phasemap never "
                "replaces; choose a file name"], done.stderr


def test_a_temporary_file_that_cannot_be_removed_is_named_not_denied(tmp_path, monkeypatch):
    """A folder made read-only while an atlas is written: the rename fails, and so does
    removing the temporary file; the message said 'no file was left' beside it.  (Root
    ignores a folder's permissions, so both failures are simulated.)"""
    ds = xr.Dataset({"n": (("x",), np.arange(3, dtype=np.int8), {"long_name": "n"})})
    path = tmp_path / "a.nc"

    def denied(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(os, "replace", denied)
    monkeypatch.setattr(pathlib.Path, "unlink", denied)
    with pytest.raises(atomic.WriteError) as caught:
        write_atlas(ds, path)
    (part,) = [p for p in tmp_path.iterdir() if p.name.endswith(".part")]
    message = str(caught.value)
    assert "\n" not in message and "no file was left" not in message
    assert message.endswith(f"its temporary file {part} could not be removed (Permission "
                            "denied): remove it by hand")
    monkeypatch.undo()
    with pytest.raises(atomic.WriteError, match="; no file was left$"):
        with atomic.no_partial_file(path) as tmp:
            raise OSError(errno.ENOSPC, "No space left on device")
    assert not path.exists() and not tmp.exists()
