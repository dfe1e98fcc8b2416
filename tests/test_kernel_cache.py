"""The kernel cache (phasemap.core.cache): verified files, safe folders, full disks, one LRU bound.

Most tests run phasemap in a child process on a cache folder of their own, so
that a damaged, planted or full folder never touches the cache the rest of the
suite uses, and so that what a fresh process does (a cold ``load_module``) is
what is tested.  The child's numba cache is kept beside the generated files
(``NUMBA_CACHE_DIR`` unset), except where a test sets it.
"""

from __future__ import annotations

import contextlib
import hashlib
import multiprocessing
import os
import pathlib
import shutil
import subprocess
import sys
import time

import pytest

from conftest import small_filesystem

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: A generated module as phasemap writes them: numba-compiled, cached on disk.
TEXT = '''"""A probe module of the kernel cache."""
from numba import njit


@njit(cache=True)
def cells(x):
    return x + 41


SPEC = "probe"
'''
STEM = "probe_grid_0123456789abcdef"


def child_env(cache_dir, numba_dir=None, **env) -> dict:
    """The environment of a fresh Python with PHASEMAP_CACHE_DIR=``cache_dir``."""
    e = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR",
                                                         "PHASEMAP_CACHE_MAX_MB")}
    e.update(PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
             PHASEMAP_CACHE_DIR=str(cache_dir), **env)
    if numba_dir is not None:
        e["NUMBA_CACHE_DIR"] = str(numba_dir)
    return e


def child(code: str, cache_dir, numba_dir=None, *, args=(), timeout=300,
          **env) -> subprocess.CompletedProcess:
    """Run ``code`` (with ``args``) in a fresh Python with PHASEMAP_CACHE_DIR=``cache_dir``."""
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True,
                          text=True, env=child_env(cache_dir, numba_dir, **env),
                          timeout=timeout)


def load(stem: str = STEM) -> str:
    """Code that loads the probe module ``stem`` and prints what it computes."""
    return ("from phasemap.core.codegen import load_module\n"
            f"m = load_module({stem!r}, lambda: {TEXT!r})\n"
            "print(m.cells(1), m.SPEC, m.__file__)\n")


def loaded(r: subprocess.CompletedProcess) -> pathlib.Path:
    """The probe computed its answer; return the file it was loaded from."""
    assert r.returncode == 0, r.stderr
    answer, spec, path = r.stdout.split()
    assert (answer, spec) == ("42", "probe")
    assert "Traceback" not in r.stderr
    return pathlib.Path(path)


def lines(r: subprocess.CompletedProcess) -> list[str]:
    return r.stderr.strip().splitlines()


@pytest.fixture(scope="module")
def warm(tmp_path_factory) -> pathlib.Path:
    """A cache folder holding the probe module and its compiled numba files."""
    origin = tmp_path_factory.mktemp("origin")
    loaded(child(load(), origin))
    assert list((origin / "__pycache__").glob(f"{STEM}.cells-*.nbi"))
    return origin


def copy_of(warm: pathlib.Path, where: pathlib.Path) -> pathlib.Path:
    target = where / "cache"
    shutil.copytree(warm, target)
    return target


# ------------------------------------------------------------- verified files -----
def _hashed(body: str) -> bytes:
    from phasemap.core import cache

    return cache.hash_line(body.encode()) + body.encode()


DAMAGE = {
    "intact": lambda raw: raw,
    "empty": lambda raw: b"",
    "truncated": lambda raw: raw[: len(raw) * 2 // 3],
    "garbage": lambda raw: bytes(range(256)) * 3,
    "syntax error": lambda raw: b"def cells(:\n",
    "missing attribute": lambda raw: b'SPEC = "probe"\n',
    "bad code under a good hash": lambda raw: _hashed("def cells(:\n"),
}


@pytest.mark.slow
@pytest.mark.parametrize("damage", list(DAMAGE))
def test_a_damaged_module_is_generated_again_once_with_one_line(warm, tmp_path, damage):
    root = copy_of(warm, tmp_path)
    path = root / f"{STEM}.py"
    path.write_bytes(DAMAGE[damage](path.read_bytes()))
    r = child(load(), root)
    assert loaded(r) == path
    if damage == "intact":
        assert r.stderr == ""   # the copy loads as it is, numba's files included
        return
    assert len(lines(r)) == 1 and "damaged" in r.stderr and str(path) in r.stderr, r.stderr
    assert path.read_text() == _hashed(TEXT).decode()   # repaired for good
    assert not list(root.glob(".*.tmp"))


@pytest.mark.parametrize("rewriter", ["", " rewritten-by 0123456789abcdef"])
def test_a_module_another_version_of_the_rewriter_wrote_is_generated_again(warm, tmp_path,
                                                                            rewriter):
    # the file's name hashes the text before phasemap.core.selects rewrites it: a file an
    # older phasemap wrote (no rewriter on its hash line, or another one) has the name of
    # today's and must not be loaded as today's, or the files named from its bytes differ
    root = copy_of(warm, tmp_path)
    path = root / f"{STEM}.py"
    body = path.read_bytes().partition(b"\n")[2]
    old = f"# phasemap-sha256 {hashlib.sha256(body).hexdigest()}{rewriter}\n".encode()
    path.write_bytes(old + body)
    other = root / "probe_grid_fedcba9876543210.py"    # a second such file: one line for both
    shutil.copy(path, other)
    body = other.read_bytes().partition(b"\n")[2]
    other.write_bytes(f"# phasemap-sha256 {hashlib.sha256(body).hexdigest()}\n".encode() + body)
    r = child(load() + load("probe_grid_fedcba9876543210"), root)
    assert r.returncode == 0, r.stderr
    assert [pathlib.Path(line.split()[2]) for line in r.stdout.splitlines()] == [path, other]
    assert len(lines(r)) == 1 and "another version of phasemap" in r.stderr, r.stderr
    assert str(root) in r.stderr
    assert path.read_bytes() == _hashed(TEXT)   # written again, with today's line
    assert child(load(), root).stderr == ""


@pytest.mark.parametrize("which", ["index", "data"])
def test_a_damaged_numba_file_is_compiled_again_with_one_line(warm, tmp_path, which):
    root = copy_of(warm, tmp_path)
    pattern = f"{STEM}.cells-*.nbi" if which == "index" else f"{STEM}.cells-*.nbc"
    for f in (root / "__pycache__").glob(pattern):
        f.write_bytes(b"\x80\x04garbage, not a pickle" * 10)
    r = child(load(), root)
    loaded(r)
    assert len(lines(r)) == 1 and "numba's cache" in r.stderr and "damaged" in r.stderr, \
        r.stderr
    assert child(load(), root).stderr == ""   # saved again, loads cleanly


def _function_files(index: pathlib.Path) -> list[pathlib.Path]:
    """numba's index and data files of one function, then phasemap's hash file of them (as
    phasemap.core.cache._numba_files lists them)."""
    base = index.name[:-len(".nbi")]
    return [index, *sorted(index.parent.glob(f"{base}.*.nbc")), index.with_suffix(".nbh")]


def test_a_damaged_system_module_and_contract_leave_classify_working(tmp_path):
    """The issue's case: classify('ladder') must survive its generated files going bad."""
    import phasemap
    from phasemap.core import cache, tiers

    model = phasemap.MODELS["ladder"]
    with tiers.forced("eager"):   # the contract's machine code saved by this phasemap (a
        phasemap.classify(model, phi=0.5, omega=0.0, f=0.3)   # kept cache may hold older)
    declared = pathlib.Path(sys.modules[model.candidates[0].func.py_func.__module__].__file__)
    contract = pathlib.Path(model.contract.__file__)
    root = tmp_path / "cache"
    (root / "__pycache__").mkdir(parents=True)
    code = ("import phasemap\n"
            "c = phasemap.classify('ladder', phi=0.5, omega=0.0, f=0.3)\n"
            "print(c.n_solutions, c.stagnation)\n")
    # the contract's compiled code, copied valid: under each function's lock, as a loading
    # process reads it (the other test process may be saving it at that moment), and
    # checked; where it is not what this phasemap saved, a first process of the test's own
    # fills the cache instead (it compiles)
    folder = cache._numba_folder(cache.folder())
    indexes = sorted(folder.glob(f"{contract.stem}.*.nbi"))
    with contextlib.ExitStack() as locks:
        for index in indexes:
            locks.enter_context(cache._locked(index, exclusive=False))
        for f in folder.glob(f"{contract.stem}.*"):
            if f.suffix != ".nbl":
                shutil.copy(f, root / "__pycache__")
    copied = [root / "__pycache__" / i.name for i in indexes]
    if not copied or any(cache._unverified(_function_files(i)) for i in copied):
        shutil.rmtree(root)
        first = child(code, root, PHASEMAP_JIT="eager")
        assert first.returncode == 0 and first.stdout.split() == ["1", "True"], first.stderr
    for f, damage in ((declared, DAMAGE["truncated"]), (contract, DAMAGE["garbage"])):
        source = root / f.name if (root / f.name).exists() else f
        (root / f.name).write_bytes(damage(source.read_bytes()))
    r = child(code, root)
    assert r.returncode == 0 and r.stdout.split() == ["1", "True"], r.stderr
    assert len(lines(r)) == 2 and all("damaged" in line for line in lines(r)), r.stderr


# ------------------------------------------------------------- safe folders -------
def test_an_unusable_cache_folder_falls_back_to_a_private_one_and_says_so_once(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    two = load() + load("probe_grid_fedcba9876543210")
    r = child(two, blocker / "kernels", TMPDIR=str(tmp))
    assert r.returncode == 0, r.stderr
    fallback = tmp / f"phasemap-kernels-{os.getuid()}"
    assert r.stdout.split()[2] == str(fallback / f"{STEM}.py")
    assert fallback.stat().st_mode & 0o777 == 0o700
    assert len(lines(r)) == 1 and "cannot use" in r.stderr and str(fallback) in r.stderr


@pytest.mark.parametrize("owner", ["another user", "us, writable by others"])
def test_a_planted_fallback_folder_is_refused_and_its_code_never_runs(tmp_path, owner,
                                                                      request):
    tmp = tmp_path / "tmp"
    planted = tmp / f"phasemap-kernels-{os.getuid()}"
    planted.mkdir(parents=True)
    marker = tmp_path / "planted-code-ran"
    (planted / f"{STEM}.py").write_text(f"open({str(marker)!r}, 'w').close()\n"
                                        "def cells(x):\n    return 42 + x - 1\nSPEC = 'probe'\n")
    os.chmod(planted, 0o777)
    if owner == "another user":
        os.chown(planted, *request.getfixturevalue("other_user"))
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    r = child(load(), blocker / "kernels", TMPDIR=str(tmp))
    path = loaded(r)
    assert not marker.exists()
    assert planted not in path.parents
    words = "owned by another user" if owner == "another user" else "writable by others"
    assert len(lines(r)) == 1 and words in r.stderr and "private" in r.stderr, r.stderr
    assert sorted(p.name for p in tmp.iterdir()) == [planted.name]   # the private one is gone


def fill(folder: pathlib.Path) -> None:
    """Fill the file system of ``folder`` with a file named ballast."""
    with contextlib.suppress(OSError), open(folder / "ballast", "wb") as fh:
        while True:
            fh.write(b"\0" * 4096)
            fh.flush()


def test_a_full_disk_under_the_cache_computes_in_a_private_folder(tmp_path):
    with small_filesystem(tmp_path / "disk", "1m") as disk:
        full = disk / "kernels"
        full.mkdir()
        fill(full)
        tmp = tmp_path / "tmp"
        tmp.mkdir()
        r = child(load(), full, TMPDIR=str(tmp))
        path = loaded(r)
        assert full not in path.parents
        assert len(lines(r)) == 1 and "No space left" in r.stderr, r.stderr
        assert [p.name for p in full.rglob("*") if p.is_file()] == ["ballast"]   # no .tmp
        assert list(tmp.iterdir()) == []


def test_numba_files_that_cannot_be_saved_are_skipped_with_one_line(tmp_path):
    with small_filesystem(tmp_path / "full", "1m") as full:
        fill(full)
        r = child(load(), tmp_path / "cache", numba_dir=full)
        loaded(r)
        assert len(lines(r)) == 1 and "cannot save" in r.stderr, r.stderr


# ------------------------------------------------------------- one LRU bound ------
def _entry(folder: pathlib.Path, name: str, size: int, age: float) -> pathlib.Path:
    folder.mkdir(parents=True, exist_ok=True)
    f = folder / name
    f.write_bytes(b"x" * size)
    t = time.time() - age
    os.utime(f, (t, t))
    return f


@pytest.fixture()
def fake_cache(tmp_path, monkeypatch):
    """A cache of known entries; numba's files under a NUMBA_CACHE_DIR of its own, and a
    stand-in for phasemap's package folder (so that the real compiled files stay)."""
    from numba.core import config

    from phasemap.core import cache

    root, package = tmp_path / "cache", tmp_path / "package"
    package.mkdir()
    monkeypatch.setenv("PHASEMAP_CACHE_DIR", str(root))
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.setattr(cache, "_PACKAGE", package)
    generated = cache._numba_folder(root)
    compiled = cache._numba_folder(package)
    assert str(tmp_path / "numba") in str(generated) and generated != compiled
    for k in range(6):   # grid kernels, oldest first, 3 files of 1000 bytes each
        stem = f"ladder_grid_phi_{k:016x}"
        _entry(root, f"{stem}.py", 1000, 600 - 100 * k)
        _entry(generated, f"{stem}.cells-18.py311.nbi", 1000, 600 - 100 * k)
        _entry(generated, f"{stem}.cells-18.py311.1.nbc", 1000, 600 - 100 * k)
    _entry(root, "wheel_declared_00000000000000aa.py", 1000, 50)
    for k in range(3):   # integrator kernels compiled per model
        _entry(compiled, f"integrate.integrate_dopri5_ladder_{k:012x}-352.py311.nbi",
               1000, 550 - 200 * k)
    keep = _entry(compiled, "integrate.cpython-311.pyc", 5000, 1000)   # not numba's
    return root, generated, compiled, keep


def test_one_lru_bound_covers_generated_modules_numba_files_and_integrators(fake_cache):
    from phasemap.core import cache

    root, generated, compiled, keep = fake_cache
    # a compile that failed leaves its lock file alone: no function
    _entry(compiled, "integrate.integrate_dopri5_wheel_00000000000f-352.py311.nbk", 0, 10)
    before = cache.info()
    assert before.counts == {"grid": 6, "declared": 1, "compiled": 3}
    assert before.size == 6 * 3000 + 1000 + 3 * 1000
    cache.prune(bound=12_000)
    left = {p.name for folder in (root, generated, compiled) for p in folder.iterdir()}
    # oldest first: grid 0 (600 s), integrator 0 (550 s), grid 1, grid 2, integrator 1 ...
    gone = [f"ladder_grid_phi_{k:016x}" for k in (0, 1, 2)] + \
        [f"integrate.integrate_dopri5_ladder_{0:012x}"]
    assert not [n for n in left if any(n.startswith(g) for g in gone)]
    assert cache.info().size == 22_000 - 10_000 <= 12_000
    assert any(n.startswith("ladder_grid_phi_0000000000000003") for n in left)
    assert "wheel_declared_00000000000000aa.py" in left
    assert keep.exists()   # Python's own files are not the cache's


def test_clearing_removes_every_entry_and_nothing_else(fake_cache):
    from phasemap.core import cache

    root, generated, compiled, keep = fake_cache
    files, freed = cache.clear()
    assert (files, freed) == (6 * 3 + 1 + 3, 22_000)
    assert [p for f in (root, generated, compiled) for p in f.iterdir()] == [keep]
    assert keep.exists() and cache.info().size == 0


def _prune_rounds(barrier, rounds: int) -> None:
    from phasemap.core import cache

    for _ in range(rounds):
        barrier.wait()
        cache.prune(bound=0)
        barrier.wait()


def test_processes_pruning_one_cache_at_once_never_crash(fake_cache):
    """Four processes prune a cache of many stale entries at the same moment, 12 times:
    files vanish under each other's feet, and no process may fail."""
    from phasemap.core import cache

    root, generated, compiled, _ = fake_cache
    ctx = multiprocessing.get_context("fork")
    rounds, n = 12, 4
    barrier = ctx.Barrier(n + 1)
    procs = [ctx.Process(target=_prune_rounds, args=(barrier, rounds)) for _ in range(n)]
    for p in procs:
        p.start()
    for r in range(rounds):
        for k in range(100):
            stem = f"ladder_grid_f_{r:04x}{k:012x}"
            _entry(root, f"{stem}.py", 10, 1000)
            _entry(generated, f"{stem}.cells-18.py311.nbi", 10, 1000)
            _entry(compiled, f"integrate.rhs_ladder_{r:04x}{k:08x}-40.py311.nbi", 10, 1000)
        barrier.wait()
        barrier.wait()
    for p in procs:
        p.join(timeout=120)
    assert [p.exitcode for p in procs] == [0] * n
    assert cache.info().size == 0


# ------------------------------------------------------------- the command line ---
def test_cache_info_and_clear_from_the_command_line(tmp_path, monkeypatch, capsys):
    """With NUMBA_CACHE_DIR set, numba's files are found there, bounded and cleared."""
    from numba.core import config

    from phasemap.cli import main

    root, numba_dir = tmp_path / "cache", tmp_path / "numba"
    stems = [f"probe_{kind}_{k:016x}" for k, kind in enumerate(["declared", "contract", "grid"])]
    r = child("".join(load(s) for s in stems), root, numba_dir)
    assert r.returncode == 0, r.stderr
    numba_files = list(numba_dir.rglob("probe_*.nb*"))
    assert len(numba_files) >= 2 * len(stems)
    # a bound of about one entry: each new module prunes the older ones, numba's files too
    one = sum(p.stat().st_size for p in [root / f"{stems[0]}.py",
                                        *numba_dir.rglob(f"{stems[0]}.*")])
    more = [f"probe_grid_{k:016x}" for k in range(10, 12)]
    r = child("".join(load(s) for s in more), root, numba_dir,
              PHASEMAP_CACHE_MAX_MB=str(1.5 * one / 1e6))
    assert r.returncode == 0, r.stderr
    left = {p.name.split(".")[0] for p in [*root.glob("*.py"), *numba_dir.rglob("probe_*.nb*")]}
    assert left == set(more)   # no orphans of the pruned entries

    monkeypatch.setenv("PHASEMAP_CACHE_DIR", str(root))
    monkeypatch.setattr(config, "CACHE_DIR", str(numba_dir))
    assert main(["cache", "info"]) == 0
    text = capsys.readouterr().out
    assert f"phasemap kernel cache {root}" in text and str(numba_dir) in text
    assert "2  grid kernels" in text and "declared" not in text
    assert "(PHASEMAP_CACHE_MAX_MB)" in text
    assert main(["cache", "clear"]) == 0
    assert capsys.readouterr().out.startswith("removed ")
    assert list(root.glob("*.py")) == [] and list(numba_dir.rglob("*.nb*")) == []


@pytest.mark.parametrize("text, bound", [("", 500 * 10 ** 6), ("0", 0), ("1.5", 1_500_000),
                                         ("inf", None), ("1e300", None)])
def test_the_cache_bound_reads_megabytes_and_inf_for_none(monkeypatch, text, bound):
    from phasemap.core import cache

    monkeypatch.setenv("PHASEMAP_CACHE_MAX_MB", text)
    assert cache.limit() == (cache.UNBOUNDED if bound is None else bound)
    if bound is None:
        assert "with no bound" in cache.info().text()


@pytest.mark.parametrize("text", ["-5", "-inf", "nan", "lots", "-0.001"])
def test_a_cache_bound_that_is_no_size_is_refused_in_one_line(monkeypatch, text):
    from phasemap.core import cache

    monkeypatch.setenv("PHASEMAP_CACHE_MAX_MB", text)
    with pytest.raises(ValueError, match=r"^PHASEMAP_CACHE_MAX_MB must be a number of "
                                         r"megabytes, 0 or more \(inf for no bound\), got "):
        cache.limit()


# ------------------------------------------------ trust: what another user may write (issue 44)
def _needs_root():
    if os.getuid() != 0:
        pytest.skip("making a file another user's needs root")


@pytest.fixture(scope="module")
def other_user():
    """A second account, made for these tests and removed after them: ``(uid, gid)``.
    The attacks of issue 44 came from another user's processes; these tests run code as
    that user (``subprocess.run(..., user=uid)``) or give it files."""
    import pwd

    if os.getuid() != 0:
        pytest.skip("making another account needs root")
    if shutil.which("useradd") is None or shutil.which("userdel") is None:
        pytest.skip("no useradd/userdel here to make another account")
    name = f"pm-other-{os.getpid()}"
    made = subprocess.run(["useradd", "--system", "--no-create-home", "--shell",
                           "/usr/sbin/nologin", name], capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip(f"useradd could not make an account: {made.stderr.strip()}")
    try:
        entry = pwd.getpwnam(name)
        yield entry.pw_uid, entry.pw_gid
    finally:
        gone = subprocess.run(["userdel", name], capture_output=True, text=True)
        if gone.returncode != 0:
            import warnings

            warnings.warn(f"userdel {name} failed: {gone.stderr.strip()}")


def as_user(who, script: str, data: bytes = b"") -> None:
    """Run the shell ``script`` as the account ``who`` (``(uid, gid)``), ``data`` on its
    standard input (a shell: this interpreter may sit where the account cannot read)."""
    uid, gid = who
    done = subprocess.run(["/bin/sh", "-c", script], user=uid, group=gid, extra_groups=[],
                          input=data, capture_output=True, timeout=60, cwd="/",
                          env={"PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr.decode(errors="replace")


EVIL_PICKLE = b"cos\nsystem\n(S'touch {marker}'\ntR."  # pickle protocol 0: os.system(...)


def test_a_flipped_bit_in_compiled_code_is_found_and_compiled_again_with_one_line(warm,
                                                                                 tmp_path):
    """One flipped bit in a cached ``.nbc`` once gave 569 of 30 000 cells the wrong class
    with no message (or SIGSEGV, and the damaged entry was reused forever)."""
    root = copy_of(warm, tmp_path)
    (data,) = (root / "__pycache__").glob(f"{STEM}.cells-*.nbc")
    raw = bytearray(data.read_bytes())
    raw[len(raw) // 2] ^= 0x10
    data.write_bytes(bytes(raw))
    r = child(load(), root)
    loaded(r)
    assert len(lines(r)) == 1 and "was damaged (they do not match the hashes phasemap " \
        "saved)" in r.stderr, r.stderr
    assert child(load(), root).stderr == ""   # compiled, saved and hashed again


def test_compiled_code_saved_against_other_shared_code_is_compiled_again(warm, tmp_path):
    """numba checks a cached function against its own file alone: saved before an edit of
    the shared compiled code it compiled in (core/calls.py, say), its machine code would
    be loaded stale.  The hash file records that code's hash, and a function saved
    against another is compiled again, with one line."""
    root = copy_of(warm, tmp_path)
    (index,) = (root / "__pycache__").glob(f"{STEM}.cells-*.nbi")
    hashes = index.with_suffix(".nbh")
    text = hashes.read_text().splitlines(keepends=True)
    assert text[-1].endswith("  phasemap's shared compiled code\n")
    hashes.write_text("".join(text[:-1]) + "0" * 64 + "  phasemap's shared compiled code\n")
    r = child(load(), root)
    loaded(r)
    assert len(lines(r)) == 1 and "is out of date (phasemap's shared compiled code has " \
        "changed since they were saved)" in r.stderr, r.stderr
    assert hashes.read_text().splitlines(keepends=True)[-1] == text[-1]
    assert child(load(), root).stderr == ""   # compiled, saved and hashed again


def test_every_module_of_core_with_compiled_code_is_shared():
    """Every module of core/ that compiles code (an njit function or an intrinsic) is in
    cache.SHARED, whose hash every cached function's hash file records."""
    import ast

    from phasemap.core import cache

    def compiles(tree) -> bool:
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                f = node.func
                name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
                if name in ("njit", "intrinsic", "jit"):
                    return True
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for d in node.decorator_list:
                    d = d.func if isinstance(d, ast.Call) else d
                    name = d.attr if isinstance(d, ast.Attribute) else getattr(d, "id", "")
                    if name in ("njit", "intrinsic", "jit"):
                        return True
        return False

    core = pathlib.Path(cache.__file__).parent
    found = {p.stem for p in core.glob("*.py") if compiles(ast.parse(p.read_text()))}
    assert found and found <= set(cache.SHARED), sorted(found - set(cache.SHARED))


@pytest.mark.parametrize("which", ["index", "hash file", "folder"])
def test_numba_files_another_user_owns_are_never_unpickled(warm, tmp_path, which, other_user):
    """A pickle planted as numba's index (where anyone can compute the name, in a shared
    NUMBA_CACHE_DIR) would run its code on the next load: a file or folder of another
    user's is never read, and never removed; the function is compiled instead."""
    _needs_root()
    root = copy_of(warm, tmp_path)
    numba = root / "__pycache__"
    marker = tmp_path / "planted-code-ran"
    (index,) = numba.glob(f"{STEM}.cells-*.nbi")
    index.write_bytes(EVIL_PICKLE.replace(b"{marker}", str(marker).encode()))
    target = {"index": index, "hash file": index.with_suffix(".nbh"), "folder": numba}[which]
    uid, gid = other_user
    os.chown(target, uid, gid)
    r = child(load(), root)
    loaded(r)
    assert not marker.exists()
    assert len(lines(r)) == 1 and "not loading numba's cache" in r.stderr and \
        f"owned by another user (uid {uid})" in r.stderr, r.stderr
    assert target.exists() and os.stat(target).st_uid == uid


def test_a_shared_world_writable_numba_cache_dir_keeps_each_users_files_apart(tmp_path,
                                                                              other_user):
    """NUMBA_CACHE_DIR shared like /tmp (mode 1777): another user, in a process of their
    own, creates the folder numba will use for the cache's functions before we ever run,
    and plants an index there; we never unpickle it."""
    import tempfile

    root = tmp_path / "cache"
    marker = tmp_path / "planted-code-ran"
    scout = tmp_path / "scout"   # where numba puts the index, learnt from a run of ours
    scout.mkdir()
    loaded(child(load(), root, numba_dir=scout))
    (index,) = scout.rglob(f"{STEM}.cells-*.nbi")
    relative = index.relative_to(scout)
    shared = pathlib.Path(tempfile.mkdtemp(prefix="phasemap-shared-"))  # others reach /tmp
    try:
        os.chmod(shared, 0o1777)
        evil = EVIL_PICKLE.replace(b"{marker}", str(marker).encode())
        planted = shared / relative
        as_user(other_user, f"umask 0 && mkdir -p '{planted.parent}' && cat > '{planted}'",
                evil)
        assert os.stat(planted).st_uid == other_user[0]
        r = child(load(), root, numba_dir=shared)
        loaded(r)
        assert not marker.exists()
        said = lines(r)
        assert said and all("owned by another user" in line for line in said), r.stderr
        assert planted.read_bytes() == evil   # never read, never removed
    finally:
        shutil.rmtree(shared, ignore_errors=True)


@pytest.mark.parametrize("mode", [0o775, 0o777])
def test_a_cache_folder_its_group_can_write_is_refused(tmp_path, mode):
    root = tmp_path / "cache"
    root.mkdir()
    os.chmod(root, mode)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    r = child(load(), root, TMPDIR=str(tmp))
    path = loaded(r)
    assert root not in path.parents
    assert len(lines(r)) == 1 and f"writable by others (mode {mode:o})" in r.stderr, r.stderr


def test_numba_files_of_ours_that_others_could_write_are_compiled_again(warm, tmp_path):
    root = copy_of(warm, tmp_path)
    (data,) = (root / "__pycache__").glob(f"{STEM}.cells-*.nbc")
    os.chmod(data, 0o666)
    r = child(load(), root)
    loaded(r)
    assert len(lines(r)) == 1 and "writable by others (mode 666)" in r.stderr, r.stderr
    assert child(load(), root).stderr == ""
    for f in (root / "__pycache__").iterdir():
        assert not f.stat().st_mode & 0o022, f


def test_under_umask_000_nothing_the_cache_saves_is_writable_by_others(tmp_path):
    root = tmp_path / "cache"
    code = "import os; os.umask(0)\n" + load()
    loaded(child(code, root))
    saved = [root, *root.rglob("*")]
    assert any(p.suffix == ".nbc" for p in saved) and any(p.suffix == ".nbh" for p in saved)
    for p in saved:
        assert not p.stat().st_mode & 0o022, (p, oct(p.stat().st_mode))
    r = child(code, root)
    assert loaded(r) and r.stderr == ""   # and it loads, hashes and all


def test_info_clear_and_the_bound_see_the_numba_files_of_every_subpackage(fake_cache):
    """numba keeps a folder per source folder: the integrators' (integrate/), the phase
    tracers' and the hand systems' (systems/) files were missed by ``cache info``, ``cache
    clear`` and the bound (2.8 MB left after a clear, reported as 0 B)."""
    from phasemap.core import cache

    root, generated, compiled, keep = fake_cache
    sub = cache._PACKAGE / "systems"
    sub.mkdir()
    (sub / "hinge_pendulum.py").write_text("")
    numba_sub = cache._numba_folder(sub)
    assert numba_sub not in (generated, compiled)
    _entry(numba_sub, "hinge_pendulum.turn-66.py311.nbi", 1000, 10)
    _entry(numba_sub, "hinge_pendulum.turn-66.py311.1.nbc", 1000, 10)
    _entry(numba_sub, "hinge_pendulum.turn-66.py311.nbh", 100, 10)
    assert numba_sub in cache.info().numba_folders
    assert cache.info().size == 22_000 + 2_100
    files, freed = cache.clear()
    assert (files, freed) == (6 * 3 + 1 + 3 + 3, 24_100)
    assert list(numba_sub.iterdir()) == [] and keep.exists()


def test_processes_needing_one_function_at_once_compile_it_once(tmp_path):
    """Three processes call one uncompiled function at the same moment (a clock they all
    wait for): one compiles it, the others wait for it and load its machine code (numba
    counts a miss in one process and a hit in each other), and every answer is right.  Each
    compiled it side by side before, as the workers of a dask cluster sharing one cache
    would.  Two rounds from a cold folder (the old code failed the first)."""
    code = ("import sys, time\n"
            "from phasemap.core.codegen import load_module\n"
            f"m = load_module({STEM!r}, lambda: {TEXT!r})\n"
            "time.sleep(max(0.0, float(sys.argv[1]) - time.time()))\n"
            "print(m.cells(1), sum(m.cells.stats.cache_misses.values()),\n"
            "      sum(m.cells.stats.cache_hits.values()))\n")
    for round_ in range(2):
        root = tmp_path / f"cache{round_}"
        start = time.time() + 3.0      # (after every process has imported phasemap)
        procs = [subprocess.Popen([sys.executable, "-c", code, repr(start)],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                  env=child_env(root))
                 for _ in range(3)]
        answers = []
        for p in procs:
            out, err = p.communicate(timeout=300)
            assert p.returncode == 0 and err == "", err
            answers.append(out.split())
        assert sorted(answers) == [["42", "0", "1"]] * 2 + [["42", "1", "0"]], answers


def test_a_function_compiled_inside_its_own_compile_does_not_wait_for_itself(tmp_path):
    """A recursive function meets itself with other argument types while it compiles (a
    literal count, then the int): its compile lock is this process's already, and the
    nested compile must not wait for it (it waited the ten minutes of COMPILE_WAIT)."""
    text = ('from numba import njit\n\n\n@njit(cache=True)\ndef rec(x, n):\n'
            '    if n <= 0:\n        return x\n    return rec(x, n - 1) + 1\n\n\n'
            '@njit(cache=True)\ndef cells(x):\n    return rec(x, 3) + rec(1.5, 2)\n\n\n'
            'SPEC = "probe"\n')
    code = ("from phasemap.core.codegen import load_module\n"
            f"m = load_module({STEM!r}, lambda: {text!r})\n"
            "print(m.cells(1), len(m.rec.signatures))\n")
    r = child(code, tmp_path, timeout=120)
    assert r.returncode == 0 and r.stdout.split() == ["7.5", "4"], r.stderr


def test_a_saved_function_loads_while_another_process_holds_its_compile_lock(warm):
    """Machine code already in the cache is loaded without waiting for the compile lock
    (another process may be compiling another signature of the function): with the lock
    held here, a process that needs the saved probe answers at once, not after the
    ten minutes of COMPILE_WAIT."""
    import fcntl

    (index,) = (warm / "__pycache__").glob(f"{STEM}.cells-*.nbi")
    fd = os.open(index.with_suffix(".nbk"), os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        r = child(load(), warm, timeout=60)
        assert loaded(r) and r.stderr == ""
    finally:
        os.close(fd)


FORK = """
import fcntl, os, sys, time, types
from phasemap.core import compilelock as cl
index = sys.argv[1]
cache = types.SimpleNamespace(_cache_file=types.SimpleNamespace(_index_path=index))
fd = cl._HELD[index] = cl.lock(cache)
ready, told = os.pipe()
child = os.fork()
if child == 0:                 # a child forked mid-compile lives on (its fork hooks have run)
    os.write(told, b"x")
    time.sleep(30)
    os._exit(0)
os.read(ready, 1)
cl._HELD.pop(index)
os.close(fd)                   # the compile ends: the lock must be free for others
other = os.open(index[:-len(".nbi")] + ".nbk", os.O_RDWR)
try:
    fcntl.flock(other, fcntl.LOCK_EX | fcntl.LOCK_NB)
    print("free")
except BlockingIOError:
    print("held by the child")
os.kill(child, 9)
os.waitpid(child, 0)
"""


def test_a_process_forked_mid_compile_does_not_keep_the_compile_lock(tmp_path):
    """An flock belongs to the open file, which a fork shares: a child forked while its
    parent compiled held the lock for its whole life, and every process needing the
    function waited COMPILE_WAIT.  The child closes its copy at once."""
    index = tmp_path / "probe.cells-3.py311.nbi"
    r = child(FORK, tmp_path, args=[str(index)], timeout=120)
    assert r.returncode == 0 and r.stdout.split() == ["free"], (r.stdout, r.stderr)


def test_processes_compiling_one_function_at_once_say_nothing(tmp_path):
    """Two xdist workers compiling one kernel at once: one read an index whose hash the
    other had not written yet, called it damaged on stderr and removed it.  The numba files
    of a function are now saved under an exclusive lock and loaded under a shared one.
    Four processes, three rounds from a cold folder."""
    code = "import time; time.sleep(0.2)\n" + load()
    for round_ in range(3):
        root = tmp_path / f"cache{round_}"
        procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, env=child_env(root))
                 for _ in range(4)]
        for p in procs:
            out, err = p.communicate(timeout=300)
            assert p.returncode == 0 and out.split()[:2] == ["42", "probe"], err
            assert err == "", err
        assert child(load(), root).stderr == ""
