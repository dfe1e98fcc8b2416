"""Shared test helpers: external checkers (cfchecks, ncdump)."""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import io
import json
import os
import pathlib
import shutil
import subprocess
import sys
import time
import warnings

import pytest


def _test_kernels() -> None:
    """Compile the suite's kernels at LLVM -O1, into a numba cache of the tests' own.

    numba compilation is most of the suite's time on a fresh clone; at ``NUMBA_OPT=1``
    (numba's default is 3) the integrator and the phase-curve tracer compile in about
    two thirds of the CPU time (measured: the hinge tracer 40 s against 59 s, its
    integrator 18 s against 27 s; -O0 is slower than -O1 for these large functions).
    Without fast-math, LLVM's optimisation level does not change floating-point results,
    so every assertion tests the same numbers; speed is measured by ``benchmarks/``, which
    compile at numba's default.  numba's cache index does not record the level, so these
    kernels go to a folder of their own (``.numba-tests`` in the checkout, or under a
    ``NUMBA_CACHE_DIR`` you set) and never stand in for the optimised ones a program
    loads.  Child processes inherit both settings.  Set ``NUMBA_OPT`` yourself to test at
    another level (then the cache is yours to choose too)."""
    if "NUMBA_OPT" in os.environ or "numba" in sys.modules:
        return
    os.environ["NUMBA_OPT"] = "1"
    base = os.environ.get("NUMBA_CACHE_DIR")
    os.environ["NUMBA_CACHE_DIR"] = str(pathlib.Path(base) / "phasemap-tests-O1" if base
                                        else pathlib.Path(__file__).resolve().parents[1]
                                        / ".numba-tests")


_test_kernels()


def _fast_machine_code() -> None:
    """LLVM's code generator (instruction selection, register allocation) runs at -O0 for
    the suite's kernels, while its IR optimisation stays at ``NUMBA_OPT``.

    numba gives both the same level.  Code generation was the larger part of the suite's
    compile time: the declared ladder's phase-curve tracer took 123 s of CPU from cold
    (its point kernels included) against 80 s with this, its curves 10 % slower to run.
    The code generator keeps IEEE semantics at every level (nothing is fused or
    reassociated without fast-math, which phasemap never asks for), so the tests check
    the same numbers.  Only kernels compiled in this process are affected (a child
    process compiles at numba's setting); they go to the tests' own cache (see
    :func:`_test_kernels`).  ``PHASEMAP_TEST_CODEGEN=default`` turns this off."""
    if os.environ.get("PHASEMAP_TEST_CODEGEN") == "default":
        return
    from numba.core import codegen

    customize = getattr(codegen.JITCPUCodegen, "_customize_tm_options", None)
    if customize is None:  # a numba without this hook: its own code generation, slower
        warnings.warn("tests/conftest.py: numba.core.codegen.JITCPUCodegen has no "
                      "_customize_tm_options; machine code is generated at NUMBA_OPT")
        return

    def at_o0(self, options):
        customize(self, options)
        options["opt"] = 0

    codegen.JITCPUCodegen._customize_tm_options = at_o0


_fast_machine_code()


def _eager_compiles() -> None:
    """The suite runs machine code: ``PHASEMAP_JIT=eager`` (unless you set it), so that a
    test's first call compiles in its own process, as before the interpreter tier, and no
    background compile competes for the two cores at a moment no test chose.  The
    interpreted tier and the background compile are tested by ``tests/test_tiers.py``, which
    sets the mode per test; child processes inherit this setting."""
    os.environ.setdefault("PHASEMAP_JIT", "eager")


_eager_compiles()


def _deterministic_hypothesis() -> None:
    """Property tests draw the same examples on every run (``derandomize``): a fresh clone
    keeps no example database, so a random draw would make CI pass or fail by luck.  Set
    ``HYPOTHESIS_PROFILE=explore`` to draw new examples (as a search for bugs, not in CI)."""
    from hypothesis import settings

    settings.register_profile("ci", derandomize=True)
    settings.register_profile("explore", derandomize=False)
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


_deterministic_hypothesis()


def pytest_configure(config):
    """Under pytest-xdist, the groups run in the order :func:`pytest_collection_modifyitems`
    gives them: pytest-xdist 3.6+ reorders them by their number of tests instead
    (``--loadscope-reorder``, on by default), which put a one-test group of five minutes
    last, one worker running it alone (a CI replay)."""
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


#: Each test's seconds (setup, call and teardown, from a fresh clone, compilation
#: included) in a CI replay, for the tests of 2 s or more: the weights by which the
#: groups are scheduled.  Regenerate it from a run with ``-v --durations=0`` (only the
#: order of the groups depends on it).
DURATIONS = pathlib.Path(__file__).with_name("durations.json")


def _skip_deep(config, items) -> None:
    """Tests marked ``deep`` (another random declaration whose kernels compile for minutes,
    beyond what the same test checks on fixed declarations in every run) are skipped, with
    the reason, unless ``-m`` names ``deep`` or ``PHASEMAP_DEEP_TESTS=1``: the README's
    test command, which CI runs, must end well inside CI's 30 minutes on a fresh clone."""
    if "deep" in (config.getoption("markexpr", "") or "") \
            or os.environ.get("PHASEMAP_DEEP_TESTS") == "1":
        return
    skip = pytest.mark.skip(reason="deep: run with -m deep or PHASEMAP_DEEP_TESTS=1")
    for item in items:
        if item.get_closest_marker("deep"):
            item.add_marker(skip)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist (``-n``, ``--dist loadgroup``), run each test module on one
    worker, so that a module's fixtures (its compiled kernels) are built once, and every
    study on the same worker, so that each study runs once (:func:`studies`).  A module
    whose tests only run phasemap in child processes shares nothing in-process: with
    ``XDIST_SPREAD = True`` its tests go to whichever worker is free.  A module that
    compiles the same kernels as another names that module's group in ``XDIST_GROUP``
    (e.g. ``"tests/test_phase_curve.py"``, or ``"studies"``): on two workers at once the
    same kernel would be compiled twice, each worker missing the other's numba cache.
    One test (a parametrized case) names its group with ``@pytest.mark.kernels_with(group)``.

    The groups are scheduled longest first (:data:`DURATIONS`; a test not listed counts
    0.4 s, about the mean of those under 2 s; ``@pytest.mark.early`` puts a group before
    the others), the greedy order that leaves the least time with one worker idle at the
    end."""
    _skip_deep(config, items)
    groups = {}
    for item in items:
        module = item.nodeid.split("::")[0]
        group = "studies" if pathlib.Path(module).name.startswith("test_study_") else module
        group = getattr(getattr(item, "module", None), "XDIST_GROUP", group)
        marked = item.get_closest_marker("kernels_with")
        group = marked.args[0] if marked else group
        if getattr(getattr(item, "module", None), "XDIST_SPREAD", False):
            groups[item.nodeid] = item.nodeid       # a unit of its own
            continue
        item.add_marker(pytest.mark.xdist_group(group))
        groups[item.nodeid] = group
    try:
        known = json.loads(DURATIONS.read_text())
    except (OSError, ValueError):
        known = {}
    weight, first = {}, {}
    for i, item in enumerate(items):
        g = groups[item.nodeid]
        weight[g] = weight.get(g, 0.0) + float(known.get(item.nodeid, 0.4))
        first.setdefault(g, i)
        if item.get_closest_marker("early"):
            weight[g] = weight.get(g, 0.0) + 1e6
    order = {item.nodeid: i for i, item in enumerate(items)}
    items.sort(key=lambda item: (-weight[groups[item.nodeid]], first[groups[item.nodeid]],
                                 order[item.nodeid]))


def _compile_log(folder: str):
    """numba compilations (cache misses, outermost only) per test, with their CPU time
    (steadier than wall time on a shared machine): which tests compile kernels that no
    other test needs.  On when PHASEMAP_TEST_LOG names a folder; each process writes
    its JSON-lines files there (tests/compile_report.py sums them)."""
    import numba.core.event as ev

    pathlib.Path(folder).mkdir(parents=True, exist_ok=True)

    class CompileLog(ev.Listener):
        path = pathlib.Path(folder) / f"compiles-{os.getpid()}.jsonl"
        test, depth, started = "collection", 0, 0.0

        def on_start(self, event):
            self.depth += 1
            if self.depth == 1:
                self.started = time.process_time()

        def on_end(self, event):
            self.depth -= 1
            if self.depth == 0:
                kernel = event.data["dispatcher"].py_func
                with open(self.path, "a") as log:
                    log.write(json.dumps({
                        "test": self.test, "seconds": round(time.process_time() - self.started, 2),
                        "kernel": f"{kernel.__module__}.{kernel.__qualname__}",
                        "args": str(event.data["args"])[:300]}) + "\n")

    log = CompileLog()
    ev.register("numba:compile", log)
    return log


_LOG = os.environ.get("PHASEMAP_TEST_LOG")
_COMPILE_LOG = _compile_log(_LOG) if _LOG else None


@pytest.hookimpl(hookwrapper=True, tryfirst=True)
def pytest_runtest_protocol(item, nextitem):
    """With PHASEMAP_TEST_LOG: each test's wall time and CPU time (this process and the
    children it waited for), setup and teardown included; CPU time is what a test costs
    on a quiet machine when the shared one is loaded."""
    if _COMPILE_LOG is None:
        yield
        return
    _COMPILE_LOG.test = item.nodeid
    cpu, wall = _cpu(), time.perf_counter()
    yield
    with open(pathlib.Path(_LOG) / f"tests-{os.getpid()}.jsonl", "a") as log:
        log.write(json.dumps({"test": item.nodeid, "cpu": round(_cpu() - cpu, 2),
                              "wall": round(time.perf_counter() - wall, 2)}) + "\n")


def _cpu() -> float:
    import resource

    return sum(resource.getrusage(who).ru_utime + resource.getrusage(who).ru_stime
               for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))


#: The study scripts, each run once per session in quick mode (:func:`studies`).
STUDIES = pathlib.Path(__file__).resolve().parents[1] / "studies"


@dataclasses.dataclass(frozen=True)
class StudyRun:
    """One quick run of a study: its claims, what it printed, its folder, the figures seen
    (:func:`figure_review.recording`) and how many figures the tour counts."""

    name: str
    claims: list
    printed: str
    out: pathlib.Path
    seen: dict

    @property
    def figures(self) -> int:
        # the tour's figures are the two-column ones; "_one_column" files are their narrow
        # layouts
        return sum(1 for p in self.out.glob("*.png") if not p.stem.endswith("_one_column"))


@pytest.fixture(scope="session")
def studies(tmp_path_factory):
    """``studies(name)``: the :class:`StudyRun` of ``studies/name.py --quick --size both``,
    in a temporary folder with every warning an error, run once per session whichever test
    asks first (the study modules and the README's tour counts share the runs)."""
    import figure_review

    runs: dict[str, StudyRun] = {}

    def run(name: str) -> StudyRun:
        if name not in runs:
            out = tmp_path_factory.mktemp(name)
            spec = importlib.util.spec_from_file_location(f"study_{name}",
                                                          STUDIES / f"{name}.py")
            module = importlib.util.module_from_spec(spec)
            printed = io.StringIO()
            with warnings.catch_warnings(), contextlib.redirect_stdout(printed), \
                    figure_review.recording() as seen:
                spec.loader.exec_module(module)  # inside: a study may bind save_figure
                warnings.simplefilter("error")
                claims = module.main(["--quick", "--out", str(out), "--size", "both"])
            runs[name] = StudyRun(name, claims, printed.getvalue(), out, seen)
            _keep_claims(name, claims)
        return runs[name]

    return run


def _keep_claims(name: str, claims) -> None:
    """With ``PHASEMAP_STUDY_CLAIMS=FOLDER`` (.ci/run sets it), each study's claims as
    ``FOLDER/NAME.json``: the documentation build that follows in the same job renders
    its claims tables from them (docs/claims.py) instead of running every study again."""
    folder = os.environ.get("PHASEMAP_STUDY_CLAIMS")
    if not folder:
        return
    path = pathlib.Path(folder) / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_suffix(f".{os.getpid()}.part")
    part.write_text(json.dumps([dataclasses.astuple(c) for c in claims]))
    os.replace(part, path)


def require_tool(name: str, install: str):
    """Skip a test locally when a command is missing; in CI (CI=true) fail instead."""
    if shutil.which(name) is None:
        message = f"{name} not installed ({install}): run .ci/system-deps"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


def cfchecks(path, folder) -> str:
    """Run cfchecks offline on ``path`` (as ``phasemap cfcheck`` does); return its report."""
    from phasemap.atlas.cfcheck import cfcheck

    require_tool("cfchecks", "pip install cfchecker; needs libudunits2-0")
    report, _ = cfcheck(path)
    assert "ERRORS detected" in report, report  # cfchecks ran to the end
    return report


def assert_atlas_round_trip(ds, folder, name: str = "atlas.nc") -> str:
    """Write ``ds`` with ``write_atlas``; it must read back identical and pass cfchecks cleanly."""
    import phasemap
    import xarray as xr

    path = phasemap.write_atlas(ds, folder / name)
    with xr.open_dataset(path) as back:
        back.load()
    xr.testing.assert_identical(back, ds)
    report = cfchecks(path, folder)
    assert "ERRORS detected: 0" in report and "WARNINGS given: 0" in report, report
    return report


@contextlib.contextmanager
def small_filesystem(folder: pathlib.Path, size: str, readonly: bool = False):
    """A real tmpfs of ``size`` mounted on ``folder`` (root only; skipped elsewhere)."""
    folder.mkdir()
    opts = f"size={size}" + (",ro" if readonly else "")
    mount = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(folder)],
                           capture_output=True, text=True)
    if mount.returncode != 0:
        message = f"cannot mount a tmpfs here: {mount.stderr.strip()}"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


@contextlib.contextmanager
def numba_arrays():
    """Counts the arrays numba's runtime allocates and frees inside the block (its
    statistics switched on for the block): yields a dict whose ``allocated`` and
    ``freed`` are filled when the block ends.  Garbage is collected on entry (so that
    arrays dropped before the block are not counted freed in it) and on exit (drop
    inside the block what holds numba's arrays, such as a Dataset, to count them
    freed)."""
    import gc

    from numba.core.runtime import _nrt_python as nrt

    counted = {}
    was = nrt.memsys_stats_enabled()
    nrt.memsys_enable_stats()
    try:
        gc.collect()
        before = nrt.memsys_get_stats_mi_alloc(), nrt.memsys_get_stats_mi_free()
        yield counted
        gc.collect()
        counted["allocated"] = nrt.memsys_get_stats_mi_alloc() - before[0]
        counted["freed"] = nrt.memsys_get_stats_mi_free() - before[1]
    finally:
        if not was:
            nrt.memsys_disable_stats()
