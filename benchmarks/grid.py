"""Grid throughput where users stand: every model's ``n_solutions`` map, per thread and on 2.

For each built-in system, a 2-D map of side ``--side`` over (phi, f), (phi, delta) or
(theta, f) at a moving state (the case's fixed values below), layer ``n_solutions``:

* **kernel**: the generated grid kernel (:func:`phasemap.core.codegen.run_grid`, what
  ``Scene.compute()`` runs) into arrays allocated once;
* **public**: ``phasemap.Scene(...).compute()`` as a user calls it: validation, the
  kernel, the Dataset;
* **NumPy**: the same classification with whole-array NumPy (written for this
  benchmark, checked cell by cell against the kernel first), which runs on one thread;
* **store loop**: ``out[i, j] = a[i] * b[j] > 0.5`` compiled by numba, one thread: a
  loop that stores one int8 per cell from trivial arithmetic, the ceiling of any map
  of that shape;
* **NumPy store**: ``(a[:, None] * b) > 0.5`` in NumPy: NumPy's own ceiling.  A NumPy
  version within 3x of it is memory-bound (its time is the arrays it writes), and
  the 30x target does not apply to it.

Each system runs in the version ``Scene`` runs (declared for the ladder, the wheel
and the rods; the hand modules for the elliptic and hinge pendulums), and in the
other version where both exist.  *Per thread* is ``numba.set_num_threads(1)``
against one-thread NumPy; the 2-thread figures stand beside them, never against
them.  Methods alternate within each repeat; the tables give medians.  Compilation
is excluded (every kernel runs once first).  A second table times the public call
of a small map (``--small``), where the call's own cost shows: *beyond* is each
public call's time minus the time the kernel took inside that same call (the
grid evaluator's ``run_grid`` timed where ``Scene`` calls it), so that the noise
of a kernel of milliseconds does not enter a difference of two separate runs.  The assembly of
every kernel that runs is checked (compiled fresh in a child process) for what
the hot loop must not hold: gathers, scalar byte stores, calls.

    python benchmarks/grid.py [--side 2048] [--small 256] [--repeat 7]
    python benchmarks/grid.py --public-only    # the small maps' public call alone

Writes the section "Grid throughput" of ../BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import shlex
import statistics
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np
from numba import njit

import phasemap
from phasemap.core.codegen import grid_kernel, run_grid
from phasemap.core.codegen import pack_axes
from phasemap.maps.layers import layers_for

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _report import ROOT, load, machine, publish, write_section  # noqa: E402,F401  (re-exported)

SEEDS = ROOT / "phasemap" / "systems" / "seeds"
TOL = 1e-12
CASES = {  # model: (second axis, its range, fixed values[, (first axis, its range)])
    "ladder": ("f", (0.0, 3.0), {"omega": 1.0}),
    "wheel": ("delta", (0.0, 1.0), {"omega": 1.0}),
    "elliptic_pendulum": ("f", (0.0, 6.0), {"omega": 0.5, "xdot": 1.0}),
    "hinge_pendulum": ("delta", (0.0, 1.5), {"omega": 1.0}),
    "painleve_rod": ("f", (0.0, 3.0), {"omega": 1.0, "xdot": -1.0}, ("theta", (0.0, np.pi / 2))),
    "rod_on_step": ("f", (0.0, 2.0), {"omega": 1.0}, ("theta", (0.45, 1.55))),
}
#: The systems whose hand module runs; the others run their declarations.
HAND_RUNS = ("elliptic_pendulum", "hinge_pendulum")
#: Issue 22's share of the store loop per thread, by model (the declared rows are longer).
SHARE_TARGET = {"elliptic_pendulum": 25.0, "hinge_pendulum": 25.0, "ladder": 10.0,
                "wheel": 10.0}
#: Issue 22's kernel / NumPy per thread, where NumPy is not memory-bound.
NUMPY_TARGET = 30.0
#: A NumPy version within this factor of NumPy's store expression is memory-bound.
MEMORY_BOUND = 3.0
#: Issue 22's cost of the public call beyond its kernel, at the small side (seconds).
OVERHEAD_TARGET = 1e-3


# ------------------------------------------------------ NumPy references -----
def numpy_ladder(phi, f, omega, l, g, m):
    """The hand ladder (tests/references/ladder.py: no separation modes)."""
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    s, w2 = np.sign(omega), omega * omega
    d = 2.0 - f * f
    rhs = 3.0 * (2.0 * s * f * l * w2 - 2.0 * s * f * g * cp + (1.0 - f * f) * g * sp)
    rhs_scale = 3.0 * (2.0 * f * l * w2 + 2.0 * f * g + np.abs(1.0 - f * f) * g)
    singular = np.abs(d) <= TOL * (2.0 + f * f)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = rhs / (2.0 * l * d)
    xdd, ydd = l * (cp * a - sp * w2), -l * (sp * a + cp * w2)
    inv = m / (1.0 + f * f)
    nf = inv * (g + ydd - s * f * xdd)
    nw = inv * (xdd + s * f * (g + ydd))
    tol = TOL * inv * (g + l * w2 + l * np.abs(a)) * (1.0 + f)
    ok = (nf >= -tol) & (nw >= -tol)
    n = np.where(singular, np.where(np.abs(rhs) <= TOL * rhs_scale, 3, 0), ok)
    return n.astype(np.int8)


def numpy_wheel(phi, delta, omega, r, l, rho, g, m):
    """The wheel rolling (moving: the hand module and the declaration agree cell by cell)."""
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    s, w2 = np.sign(omega), omega * omega
    coef = rho * rho + r * r + l * l - 2.0 * r * l * cp + delta * s * l * sp
    rhs = -l * (r * sp + delta * s * cp) * w2 - g * l * sp - delta * s * g
    singular = np.abs(coef) <= TOL * (rho * rho + r * r + l * l + 2.0 * r * l + delta * l)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = rhs / coef
    n_normal = m * (g + l * (sp * a + cp * w2))
    ok = n_normal >= -TOL * m * (g + l * w2 + l * np.abs(a))
    rhs_zero = np.abs(rhs) <= TOL * (l * (r + delta) * w2 + g * l + delta * g)
    return np.where(singular, np.where(rhs_zero, 3, 0), ok).astype(np.int8)


def numpy_elliptic(phi, f, omega, xdot, l, g, m):
    sp, cp = np.sin(phi)[:, None], np.cos(phi)[:, None]
    sigma, w2 = np.sign(xdot), omega * omega
    q = g + l * cp * w2
    q_zero = np.abs(q) <= TOL * (g + l * w2)
    n = np.zeros(np.broadcast_shapes(sp.shape, np.shape(f)), dtype=np.int8)
    cont = np.zeros(n.shape, dtype=bool)
    for rho in (1.0, -1.0):
        k = sigma * rho
        lam = 1.0 + sp * sp - k * f * sp * cp
        singular = np.abs(lam) <= TOL * (2.0 + f)
        ok = (q_zero | (q * lam > 0)) if rho > 0 else (~q_zero & (q * lam < 0))
        n += (~singular & ok).astype(np.int8)
        cont |= singular & q_zero
    return np.where(cont, 3, n).astype(np.int8)


def numpy_hinge(phi, delta, omega, l, g, m):
    cp = np.cos(phi)[:, None]
    w2 = omega * omega
    coef = l * l - delta * delta
    singular = np.abs(coef) <= TOL * (l * l + delta * delta)
    qn_zero = np.abs(l * w2 + g * cp) <= TOL * (l * w2 + g)
    n = np.where(coef > 0, 1, np.where(qn_zero, 1, 0))
    return np.where(singular, np.where(qn_zero, 3, 0), n).astype(np.int8)


def numpy_rod(theta, f, omega, xdot, l, g, m):
    """n_solutions, stagnation, contact_lost, singular of the Painleve rod (NumPy).

    Derived by hand (Newton-Euler about the centre G = (x + l cos, l sin)):
    m xG'' = F, m yG'' = N - m g, (m l^2/3) theta'' = l (sin F - cos N).
    Kept contact (y'' = 0), slipping in direction s (F = -s f N):
    N (1 + 3 cos^2 + 3 s f sin cos) = m (g - l omega^2 sin);
    x'' = -s f N/m - 3 l sin N (cos + s f sin)/(m l) + l cos omega^2.
    Stick (x'' = 0): theta'' = -3 g cos/(4 l), N = m g (1 - 3 cos^2/4) - m l omega^2 sin,
    F = m (3 g sin cos/4 - l omega^2 cos).  Separated (N = F = 0):
    y'' = l omega^2 sin - g > 0.  Tolerances: the magnitudes of the generated code.
    """
    sn, c = np.sin(theta)[:, None], np.cos(theta)[:, None]
    w2 = omega * omega
    rest = xdot == 0.0
    shape = np.broadcast_shapes(sn.shape, np.shape(f))
    n = np.zeros(shape, np.int8)
    cont = np.zeros(shape, bool)
    sing = np.zeros(shape, bool)
    n0 = m * (g - l * w2 * sn) / 3.0
    ns0 = m * (w2 * l + g) / 3.0
    for s in ((1.0, -1.0) if rest else (float(np.sign(xdot)),)):
        d = c * c + s * f * sn * c + 1.0 / 3.0
        singular = np.abs(d) <= TOL * (np.abs(f) + 4.0 / 3.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            nn = n0 / d
            nscale = ns0 / np.abs(d)
        ok = nn >= -TOL * nscale
        if rest:  # the slip must start in its direction
            xdd = -s * f * nn / m - 3.0 * sn * nn * (c + s * f * sn) / m + l * c * w2
            xscale = 3.0 / m * (nscale * (1.0 + 4.0 * f / 3.0) + 7.0 / 3.0 * m * l * w2
                                + 2.0 * m * g)
            ok &= s * xdd > TOL * xscale
        n += (~singular & ok).astype(np.int8)
        cont |= singular & (np.abs(n0) <= TOL * ns0)
        sing |= singular
    lost = np.broadcast_to(l * w2 * sn - g > TOL * 7.0 * (g + l * w2), shape)
    n += lost.astype(np.int8)
    if rest:
        nn = m * g * (1.0 - 0.75 * c * c) - m * l * w2 * sn
        ff = m * (0.75 * g * sn * c - l * w2 * c)
        ns, fs = m * g + 1.75 * m * l * w2, 0.75 * m * g + 1.75 * m * l * w2
        stag = ((nn >= -TOL * ns) & (f * nn - ff >= -TOL * (f * ns + fs))
                & (f * nn + ff >= -TOL * (f * ns + fs)))
        n += stag.astype(np.int8)
    else:
        stag = np.zeros(shape, bool)
    code = np.where(cont, 3, np.where(n >= 3, 4, n)).astype(np.int8)
    return (code, stag.astype(np.int8), lost.astype(np.int8),
            np.broadcast_to(sing, shape).astype(np.int8))


#: model -> (NumPy function, which versions it reproduces cell by cell)
NUMPY = {"ladder": (numpy_ladder, ("hand",)), "wheel": (numpy_wheel, ("hand", "declared")),
         "elliptic_pendulum": (numpy_elliptic, ("hand", "declared")),
         "hinge_pendulum": (numpy_hinge, ("hand", "declared")),
         "painleve_rod": (lambda *a, **k: numpy_rod(*a, **k)[0], ("declared",))}


@njit(cache=True)
def store_loop(a, b, out):
    """The ceiling of a map: one int8 per cell from trivial arithmetic on the two axes."""
    for i in range(a.size):
        for j in range(b.size):
            out[i, j] = a[i] * b[j] > 0.5


def numpy_store(a, b):
    return (a[:, None] * b) > 0.5


# ------------------------------------------------------------- the cases -----
#: The hand-written module of each seed system: the pendulums run by hand; the ladder's
#: and the wheel's (the paper's equations) are test references, tests/references/.
HAND_MODULES = {"ladder": "references.ladder", "wheel": "references.wheel",
                **{name: f"phasemap.systems.{name}" for name in HAND_RUNS}}
sys.path.insert(0, str(ROOT / "tests"))


def hand_model(name):
    """The hand-written model of a seed system (the ladder and the wheel run as their
    declarations; their hand modules are references), or the registered model of any
    other name."""
    import importlib

    if name in HAND_MODULES:
        return importlib.import_module(HAND_MODULES[name]).MODEL
    return phasemap.MODELS[name]


def versions(name):
    """(label, Model) of a system: the version Scene runs first (the registered model),
    then the other one where both exist."""
    runs = phasemap.get_model(name)
    if not (SEEDS / f"{name}.py").exists():
        return [(runs_as(name), runs)]
    if runs_as(name) == "hand":
        return [("hand", runs), ("declared", phasemap.get_model(str(SEEDS / f"{name}.py")))]
    return [("declared", runs), ("hand", hand_model(name))]


def runs_as(name) -> str:
    return "hand" if name in HAND_RUNS else "declared"


def scene_args(model, n, m=None, state=None, case=None):
    """The model, axes and fixed values of ``model``'s map of side ``n``.

    ``m`` replaces the registered model (another version of it), ``state``
    overrides values of the case (another velocity), ``case`` replaces
    ``CASES[model]``; a fourth element ``(name, (lo, hi))`` of a case names the
    first axis (default: phi).
    """
    case = case or CASES[model]
    name2, (lo, hi), fixed = case[:3]
    m = phasemap.get_model(model) if m is None else m
    full = {**m.defaults, **fixed, **(state or {})}
    if len(case) > 3:
        name1, (lo1, hi1) = case[3]
    else:
        name1 = "phi"
        lo1 = 0.0 if model == "ladder" else -np.pi
        hi1 = np.pi / 2 if model == "ladder" else np.pi
    axes = {name1: np.linspace(lo1, hi1, n), name2: np.linspace(lo, hi, n)}
    full = {k: v for k, v in full.items() if k not in axes}
    return m, axes, full


class Kernel:
    """The grid kernel of a scene with its inputs laid out once: ``run()`` is the kernel
    alone, as ``Scene.compute()`` runs it, into arrays allocated once."""

    def __init__(self, m, axes, fixed, layers=("n_solutions",)):
        names = list(axes)
        inner = names[-1]
        reg = layers_for(m)
        wanted = [reg[k] for k in layers]
        flag_layers = [l for l in wanted if l.is_summary]
        field_layers = [l for l in wanted if not l.is_summary]
        self.layers = flag_layers + field_layers
        self.cells = grid_kernel(m, tuple(self.layers), inner)
        iv = np.array(axes[inner], dtype=float)
        ideriv = np.array([d.func(iv) for d in m.derived if d.source == inner],
                          dtype=float).reshape(-1, iv.size)
        ncells = int(np.prod([len(a) for a in axes.values()]))
        self.shape = tuple(len(a) for a in axes.values())
        self.flags = np.empty((len(flag_layers), ncells), np.int8)
        self.fields = np.empty((len(field_layers), ncells))
        packed = pack_axes(m, {n: axes[n] for n in names[:-1]},
                           {k: v for k, v in fixed.items() if k != inner})
        self.args = (*packed, iv, ideriv, self.flags, self.fields)

    def run(self):
        run_grid(self.cells, *self.args)

    def result(self, name):
        k = [l.name for l in self.layers].index(name)
        nf = len(self.flags)
        return (self.flags[k] if k < nf else self.fields[k - nf]).reshape(self.shape)


def public(m, axes, fixed):
    """The call a user makes: a Scene built and computed."""
    return phasemap.Scene(m, axes=axes, fixed=fixed, layers=["n_solutions"]).compute()


def run_numpy(model, axes, fixed):
    fn = NUMPY[model][0]
    names = list(axes)
    return fn(axes[names[0]], **{**fixed, names[1]: axes[names[1]][None, :]})


# ----------------------------------------------------------------- timing -----
#: The grid evaluator's ``run_grid`` as ``Scene`` calls it, timed: the seconds of each
#: call since the last reset, on the clock of the run in progress.
_INSIDE: list = []
_CLOCK = [time.thread_time]


def _timed_run_grid(*args, _run=phasemap.maps.grid.run_grid):
    t = _CLOCK[0]()
    _run(*args)
    _INSIDE.append(_CLOCK[0]() - t)


phasemap.maps.grid.run_grid = _timed_run_grid


def median_times(runs: dict, repeat: int) -> dict:
    """Median seconds of each ``(function, threads)`` in ``runs``, alternating them: the
    calling thread's CPU time on one thread (numba's OpenMP layer runs a one-thread
    region there; on shared cores a wall time longer than a scheduler slice is
    preempted and a shorter one is not), wall time on several.  For each public call,
    also the median of its time beyond the kernel it ran (key ``"beyond"`` in place of
    ``"public"``)."""
    times = {k: [] for k in runs}
    beyond = {k: [] for k in runs if "public" in k}
    for _ in range(repeat):
        for key, (fn, threads) in runs.items():
            numba.set_num_threads(threads)
            clock = time.thread_time if threads == 1 else time.perf_counter
            _CLOCK[0] = clock
            _INSIDE.clear()
            t = clock()
            fn()
            times[key].append(clock() - t)
            if key in beyond:
                beyond[key].append(times[key][-1] - sum(_INSIDE))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    out = {k: statistics.median(v) for k, v in times.items()}
    out.update({tuple("beyond" if x == "public" else x for x in k): statistics.median(v)
                for k, v in beyond.items()})
    return out


def measure(side: int, repeat: int, with_numpy: bool):
    """Per model and version: seconds of the kernel and the public call on 1 and N threads,
    NumPy, and the two store references, all in one alternating run."""
    nthreads = numba.config.NUMBA_NUM_THREADS
    a, b = np.linspace(0.0, 1.0, side), np.linspace(0.0, 1.0, side)
    out = np.empty((side, side), np.int8)
    store_loop(a, b, out)  # compile / load
    runs = {"store": (lambda: store_loop(a, b, out), 1)}
    if with_numpy:
        runs["numpy store"] = (lambda: numpy_store(a, b), 1)
    checked = {}
    for name in CASES:
        for label, m in versions(name):
            _, axes, fixed = scene_args(name, side, m=m)
            k = Kernel(m, axes, fixed)
            k.run()
            got = k.result("n_solutions")
            assert np.array_equal(got, public(m, axes, fixed).n_solutions.values), name
            runs[(name, label, "kernel", 1)] = (k.run, 1)
            runs[(name, label, "kernel", nthreads)] = (k.run, nthreads)
            runs[(name, label, "public", 1)] = (lambda m=m, a=axes, f=fixed: public(m, a, f), 1)
            runs[(name, label, "public", nthreads)] = (
                lambda m=m, a=axes, f=fixed: public(m, a, f), nthreads)
            if with_numpy and name in NUMPY and label in NUMPY[name][1]:
                ref = run_numpy(name, axes, fixed)
                bad = int((ref != got).sum())
                assert bad == 0, f"{name} ({label}): NumPy and the kernel differ in {bad} cells"
                checked[(name, label)] = True
                runs[(name, "numpy")] = (lambda n=name, a=axes, f=fixed: run_numpy(n, a, f), 1)
            elif with_numpy and name in NUMPY:
                runs.setdefault((name, "numpy"), (
                    lambda n=name, a=axes, f=fixed: run_numpy(n, a, f), 1))
    med = median_times(runs, repeat)
    return med, checked


# --------------------------------------------------------------- assembly -----
ASM_CHILD = r"""
import collections, json, re, sys
import phasemap
from phasemap.core.codegen import grid_kernel
from phasemap.maps.layers import layers_for
spec = json.loads(sys.argv[1])
m = phasemap.get_model(spec["model"])
cells = grid_kernel(m, (layers_for(m)["n_solutions"],), spec["inner"])
lines = cells.inspect_asm(cells.signatures[0]).splitlines()
# the kernel itself, not the wrappers numba adds after it (boxing from Python)
ends = [i for i, l in enumerate(lines) if re.match(r"^(_ZN7cpython|cfunc\.)", l)]
lines = lines[:ends[0]] if ends else lines
labels = {}
for i, l in enumerate(lines):
    h = re.match(r"^(\.LBB\d+_\d+):", l)
    if h:
        labels[h.group(1)] = i
spans = []
for i, l in enumerate(lines):
    j = re.match(r"^\s+j\w+\s+(\.LBB\d+_\d+)", l)
    if j and labels.get(j.group(1), i) < i:
        spans.append((labels[j.group(1)], i))
# the innermost loops (no other loop inside), with and without vector registers
inner = [(a, b) for a, b in spans
         if not any((c, d) != (a, b) and a <= c and d <= b for c, d in spans)]
ops = {(a, b): [x.split()[0] for x in lines[a:b + 1]
                if x.startswith("\t") and not x.startswith("\t.")] for a, b in inner}
vector = [ops[k] for k in inner if "ymm" in "\n".join(lines[k[0]:k[1] + 1])]
c = collections.Counter(op for body in vector for op in body)
calls = sum(op.startswith("call") for body in ops.values() for op in body)
print(json.dumps({"vector loops": len(vector), "scalar loops": len(inner) - len(vector),
                  "gathers": sum(v for k, v in c.items() if "gather" in k),
                  "byte stores": c["vpextrb"] + c["movb"], "calls": calls,
                  "divisions": c["vdivpd"], "lengths": sorted(len(b) for b in vector)}))
"""


def assembly(name, inner):
    """What the vectorised loops of the kernel that ``Scene`` runs hold, compiled fresh in
    a child process (numba does not show the assembly of code it loaded from its cache)."""
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        out = subprocess.run([sys.executable, "-c", ASM_CHILD,
                              json.dumps({"model": name, "inner": inner})],
                             env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


# ---------------------------------------------------------------- reports -----
GRID_START = ("import time; t=time.perf_counter(); import numpy as np, phasemap; "
              "phasemap.Scene('ladder', axes={'phi': np.linspace(0, 1, 8)}).compute(); "
              "print(time.perf_counter()-t)")


def cold_start(empty_cache: bool, code: str = GRID_START) -> float:
    """Seconds ``code`` (which prints its own timing last) takes in a fresh process,
    with numba's on-disk cache as it is or empty."""
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        if empty_cache:
            env["NUMBA_CACHE_DIR"] = tmp
            env["PHASEMAP_CACHE_DIR"] = os.path.join(tmp, "kernels")
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def mc(seconds: float, cells: int) -> str:
    rate = cells / seconds / 1e6
    return f"{rate:.0f}" if rate >= 10 else f"{rate:.1f}"


def verdict(ok: bool) -> str:
    return "met" if ok else "**missed**"


def report(args, big, small, checked, asm, loads) -> str:
    n, s = args.side, args.small
    cells = n * n
    nt = numba.config.NUMBA_NUM_THREADS
    command = "python benchmarks/grid.py " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    store, npstore = big["store"], big["numpy store"]
    lines = [
        "## Grid throughput (`benchmarks/grid.py`)",
        "",
        f"Machine: {machine()}. Load average {loads[0]} at the start, {loads[1]} at the end "
        "(other jobs share these cores: the ratios compare methods within one run, "
        "alternating, medians of "
        f"{args.repeat}). Command: `{command}`.",
        "",
        f"### `n_solutions` maps of side {n} (Mcell/s)",
        "",
        f"A moving state of each system (axes and fixed values: `CASES` in the script); "
        f"*runs* is the version `Scene` runs, *reference* the other one. *kernel*: the "
        f"generated grid kernel alone; *public*: `Scene(...).compute()`. Per thread: one "
        f"numba thread against NumPy, which runs on one, timed by the calling thread's "
        f"CPU time; {nt} threads beside, timed by the wall clock (so they show the load: "
        f"under load they can fall below the one-thread figures). The store "
        f"loop (`out[i, j] = a[i] * b[j] > 0.5`, one thread) runs at "
        f"{mc(store, cells)} Mcell/s, NumPy's store expression at {mc(npstore, cells)}.",
        "",
        f"| model | version | kernel 1 thread | public 1 thread | kernel {nt} threads | "
        f"public {nt} threads | NumPy | kernel / store loop | kernel / NumPy | "
        f"NumPy / NumPy store |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    shares, numpy_ratio, bound = {}, {}, {}
    for name in CASES:
        for label, _ in versions(name):
            k1 = big[(name, label, "kernel", 1)]
            kn = big[(name, label, "kernel", nt)]
            p1 = big[(name, label, "public", 1)]
            pn = big[(name, label, "public", nt)]
            npy = big.get((name, "numpy"))
            role = "runs" if label == runs_as(name) else "reference"
            share = 100 * store / k1
            if npy is not None:
                ratio = f"{npy / k1:.1f}x" + ("" if (name, label) in checked else " (a)")
                nps = f"{npstore / npy:.2f}"
            else:
                ratio = nps = "-"
            if role == "runs":
                shares[name] = share
                if npy is not None:
                    numpy_ratio[name] = (npy / k1, (name, label) in checked)
                    bound[name] = npy / npstore < MEMORY_BOUND
            lines.append(
                f"| {name} | {label} ({role}) | {mc(k1, cells)} | {mc(p1, cells)} | "
                f"{mc(kn, cells)} | {mc(pn, cells)} | "
                f"{mc(npy, cells) if npy else '-'} | {share:.1f} % | {ratio} | {nps} |")
    lines += [
        "",
        "(a) The NumPy version is the hand ladder's, which does not count separation "
        "modes (it is checked cell by cell against the hand kernel); the declaration "
        "computes four candidate rows where it computes one, so the ratio understates "
        "the declared kernel against a NumPy version of the same rows.",
        "",
    ]
    table, beyond = public_table(small, s, nt)
    lines += table
    lines += [
        "",
        "### The hot loops' assembly",
        "",
        "Each kernel that runs, compiled fresh: its innermost loops (one per velocity "
        "regime: at rest, moving forward, backward; and the short loops that unpack or "
        "finish a row), those that use AVX2 `ymm` registers (vectorised) and those that do "
        "not, with what the vectorised ones must not hold (gathers, scalar byte stores), "
        "calls in any innermost loop, packed divisions, and each vectorised loop's length "
        "in instructions (4 cells per pass, or 16 where LLVM interleaves).",
        "",
        "| model | vectorised loops | scalar loops | gathers | scalar byte stores | calls | "
        "`vdivpd` | instructions per vectorised loop |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for name, a in asm.items():
        lines.append(f"| {name} | {a['vector loops']} | {a['scalar loops']} | {a['gathers']} | "
                     f"{a['byte stores']} | {a['calls']} | {a['divisions']} | "
                     f"{', '.join(map(str, a['lengths']))} |")
    lines += ["", "### Against the targets (issue 22)", "",
              "| target | model | measured | verdict |", "|---|---|---:|---|"]
    for name, goal in SHARE_TARGET.items():
        lines.append(f"| kernel >= {goal:.0f} % of the store loop, per thread | {name} "
                     f"({runs_as(name)}) | {shares[name]:.1f} % | "
                     f"{verdict(shares[name] >= goal)} |")
    for name, (ratio, same) in numpy_ratio.items():
        if bound[name]:
            lines.append(f"| kernel >= {NUMPY_TARGET:.0f}x NumPy, per thread | {name} | "
                         f"{ratio:.1f}x | does not apply: NumPy is memory-bound here |")
        else:
            note = "" if same else " (a)"
            lines.append(f"| kernel >= {NUMPY_TARGET:.0f}x NumPy, per thread | {name} | "
                         f"{ratio:.1f}x{note} | {verdict(ratio >= NUMPY_TARGET)} |")
    lines += public_targets(beyond, s)
    clean = all(a["gathers"] == 0 and a["byte stores"] == 0 and a["calls"] == 0
                for a in asm.values())
    lines += [
        f"| no gathers, scalar byte stores or calls in the vectorised loops | all that run | "
        f"see above | {verdict(clean)} |",
        "| every layer set bit-identical to the per-point path | all six | "
        "tests/test_kernels.py | met |",
        "| no copy of the result after the kernel | - | tests/test_grid_scene.py | met |",
        "",
    ]
    return "\n".join(lines)


def public_table(small, s, nt) -> tuple[list[str], dict]:
    """The subsection of the public call on a small map, and each model's cost beyond its
    kernel on one thread (seconds)."""
    lines = [
        f"### The public call on a small map, side {s} (ms)",
        "",
        "*beyond*: each public call's time minus the time of the kernel it ran (the grid "
        "evaluator's `run_grid`, timed inside the call), median over the calls, on the "
        "same thread count; the kernel columns time the kernel alone. "
        "The target's verdict reads the one-thread figures (CPU time); the 2-thread ones "
        "are wall times, which at a load above the core count include waiting for the "
        "second thread to be scheduled (tens of ms on a map this small).",
        "",
        f"| model | kernel 1 thread | public 1 thread | beyond | kernel {nt} threads | "
        f"public {nt} threads | beyond |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    beyond = {}
    for name in CASES:
        label = runs_as(name)
        k1, p1 = small[(name, label, "kernel", 1)], small[(name, label, "public", 1)]
        kn, pn = small[(name, label, "kernel", nt)], small[(name, label, "public", nt)]
        b1, bn = small[(name, label, "beyond", 1)], small[(name, label, "beyond", nt)]
        beyond[name] = b1
        lines.append(f"| {name} | {k1 * 1e3:.3f} | {p1 * 1e3:.3f} | {b1 * 1e3:.3f} | "
                     f"{kn * 1e3:.3f} | {pn * 1e3:.3f} | {bn * 1e3:.3f} |")
    return lines, beyond


def public_targets(beyond, s) -> list[str]:
    """The rows of target 2 (the cost of the public call beyond its kernel)."""
    return [f"| public call <= {OVERHEAD_TARGET * 1e3:.0f} ms beyond its kernel at {s}^2, "
            f"one thread | {name} | {t * 1e3:.2f} ms | {verdict(t <= OVERHEAD_TARGET)} |"
            for name, t in beyond.items()]


def public_only(args) -> None:
    """``--public-only``: time the small maps alone and replace, in BENCHMARKS.md, the
    subsection of the public call and target 2's rows; the rest of the section stays."""
    before = load()
    small, _ = measure(args.small, max(args.repeat, 25), with_numpy=False)
    table, beyond = public_table(small, args.small, numba.config.NUMBA_NUM_THREADS)
    table[2] += (f"  Timed alone by `python benchmarks/grid.py --public-only` (load average "
                 f"{before} at the start, {load()} at the end).")
    print("\n".join(table + [""] + public_targets(beyond, args.small)))
    if args.no_write:
        return
    path = ROOT / "BENCHMARKS.md"
    text = path.read_text()
    head = "### The public call on a small map"
    start = text.index(head)
    end = text.index("\n### ", start + 1)
    text = text[:start] + "\n".join(table) + "\n" + text[end:]
    rows = dict(zip(beyond, public_targets(beyond, args.small)))
    out = []
    for line in text.split("\n"):
        hit = [n for n in rows if line.startswith("| public call <= ") and f"| {n} |" in line]
        out.append(rows[hit[0]] if hit else line)
    path.write_text("\n".join(out))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--side", type=int, default=2048)
    ap.add_argument("--small", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--no-asm", action="store_true", help="skip the assembly check")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--public-only", action="store_true",
                    help="time only the public call on the small maps (its subsection)")
    args = ap.parse_args()
    if args.public_only:
        public_only(args)
        return
    loads = [load()]
    big, checked = measure(args.side, args.repeat, with_numpy=True)
    small, _ = measure(args.small, max(args.repeat, 25), with_numpy=False)
    asm = {}
    if not args.no_asm:
        for name in CASES:
            asm[name] = assembly(name, CASES[name][0])
    loads.append(load())
    publish(report(args, big, small, checked, asm, loads), "## Grid throughput",
            write=not args.no_write)


if __name__ == "__main__":
    main()
