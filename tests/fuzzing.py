"""A seeded fuzz of every public function and every command (issue 42).

Each case is a call that would answer, with one argument replaced by an awkward value
(NaN, inf, a subnormal, a huge or tiny number, a huge count, a wrong type, a bad path,
a malformed mapping).  The call must answer, or raise one ValueError or TypeError that
names the argument, within a time bound; never hang, crash or raise anything else, and
never answer with a NaN solution.  A command must exit 0, or exit 2 (bad input) or 1 (the
file system refused) with a last line that starts ``phasemap``, and never print a
traceback.

:func:`run` draws ``n`` cases with a seed and returns the :class:`Tally`.  The suite runs
a few hundred on the models whose kernels it compiles anyway
(``tests/test_fuzz.py``); ``benchmarks/fuzz.py`` runs thousands on every model and
records the counts in BENCHMARKS.md.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fractions
import io
import math
import pathlib
import random
import re
import time
import warnings

import numpy as np

import phasemap
from phasemap.core import compiletime  # counts numba's compiles (import phasemap installs it)

HUGE = 10**400

#: Values no argument expects, or that sit on the edge of every domain.
AWKWARD = [HUGE, -HUGE, 10**5000 + 1, 10**30, 2**63, math.nan, math.inf, -math.inf, 1e308,
           -1e-320, 5e-324, np.float32(0.5), np.float16(0.25), np.int8(1), np.uint64(2),
           np.int64(1), np.longdouble(0.3), np.float64(np.nan), np.array(0.2), np.array(1),
           np.datetime64("2020"), np.timedelta64(1, "s"), "a", "1.0", "", None, [0.1], [],
           (0.1, 0.2), [[0.1]], [0.1, [0.2]], True, np.bool_(True), 1 + 2j, np.complex64(1),
           b"x", {}, {"a": 1}, object(), fractions.Fraction(1, 3), 0.1, 1, -1, 0, 0.0,
           1e-300, -0.0, 1e-12, 1e12, np.array([0.1, 0.2]), np.array([], dtype=float),
           np.array(["x"])]

#: Words and numbers a command line may carry where another is expected.
AWKWARD_TOKENS = ["", "nan", "inf", "-inf", "1e400", "-1e-320", "1e308", "0", "-1", "x",
                  "pi/0", "1/0", "1:2", "0:1:0", "0:1:-5", "0:1:1e12", "0:1:2.5", "a=b",
                  "phi", "phi=", "=1", "phi=nan", "phi=1e400", "f=-1", "l=0", "--", "-",
                  "..", "/", "/proc/nope.nc", "\x00", "é", "0" * 400, "9" * 5000,
                  "phi=0:1:3", "--yes"]

#: Seconds a call may take, numba compiling nothing, before it counts as hung.
BOUND = 60.0
#: Seconds after which a call that has not returned (a first compile included) ends the
#: process with its stack: a hang, not a slow call.
WATCHDOG = 1800.0


@dataclasses.dataclass
class Tally:
    """What a run of the fuzz found: per entry point the calls that answered and those
    refused cleanly, every failure with its reproduction, and the slowest call."""

    answered: dict = dataclasses.field(default_factory=dict)
    refused: dict = dataclasses.field(default_factory=dict)
    failures: list = dataclasses.field(default_factory=list)
    slowest: tuple = (0.0, "")
    #: calls during which numba compiled (exempt from the time bound: a first call)
    compiling: int = 0

    @property
    def calls(self) -> int:
        return sum(self.answered.values()) + sum(self.refused.values())

    def entries(self) -> list[str]:
        return sorted(set(self.answered) | set(self.refused))


def describe(value) -> str:
    from phasemap.core.args import describe as text

    return text(value)


# ------------------------------------------------------------------ valid values -----

def _valid(var, rng: random.Random) -> float:
    """A value inside a variable's domain (its default, or a point of its bounds'
    interior, or a small multiple of the default where unbounded)."""
    lo, hi = var.lower, var.upper
    if math.isfinite(lo) and math.isfinite(hi):
        return lo + (hi - lo) * rng.uniform(0.05, 0.95)
    base = var.default if var.default else 1.0
    x = base * rng.uniform(0.5, 1.5)
    if math.isfinite(lo) and x <= lo:
        x = lo + abs(base)
    return x


def _values(m, rng, names=None) -> dict:
    """Values of ``names`` (default all) that the model accepts together (its own check
    of cross-variable domains: the wheel's l <= r, the rod's corner on its edge); the
    defaults where 50 draws all fail."""
    names = names or m.names
    for _ in range(50):
        values = {n: _valid(m.variables[n], rng) for n in names}
        if _accepted(m, values):
            return values
    return {n: m.defaults[n] for n in names}


def _accepted(m, *corners) -> bool:
    """Whether the model accepts every one of ``corners`` (mappings of values)."""
    try:
        for values in corners:
            m.complete(values)
    except ValueError:
        return False
    return True


def _axis_range(var, rng) -> tuple[float, float]:
    a, b = sorted((_valid(var, rng), _valid(var, rng)))
    return (a, b + 0.1) if b - a < 1e-3 else (a, b)


# -------------------------------------------------------------------- the cases -----

class Cases:
    """The fuzz's cases: each method returns ``(entry, argument, value, call)``, a call
    that would answer with ``argument`` replaced by ``value`` (or by a valid value when
    the case draws none)."""

    def __init__(self, rng: random.Random, models: list[str], folder: pathlib.Path,
                 atlas: pathlib.Path, heavy: bool, slices: list[str] | None = None):
        self.rng, self.models, self.folder, self.atlas, self.heavy = (rng, models, folder,
                                                                      atlas, heavy)
        # the models whose (state, parameter) slices boundaries and threshold take
        self.slices = slices or list(models)
        self.ds = phasemap.open_atlas(atlas).load()
        self.paths = self._files()

    def _files(self) -> list:
        """Paths a file argument may be given: missing, a folder, not netCDF, a netCDF
        file phasemap did not write, an empty file, the atlas itself."""
        f = self.folder
        (f / "text.nc").write_text("not netCDF")
        (f / "empty.nc").write_bytes(b"")
        (f / "folder.nc").mkdir(exist_ok=True)
        import netCDF4

        with netCDF4.Dataset(f / "foreign.nc", "w") as nc:
            nc.createDimension("x", 3)
            nc.createVariable("v", "f8", ("x",))[:] = [1.0, 2.0, 3.0]
        return [f / "missing.nc", f / "folder.nc", f / "text.nc", f / "empty.nc",
                f / "foreign.nc", str(self.atlas), self.atlas, "", "/", f]

    def pick(self, seq):
        return self.rng.choice(seq)

    def awkward(self, argument):
        """(argument, value): a value from :data:`AWKWARD`, or (rarely) the argument left
        valid, so that what answers is exercised too."""
        return argument, (self.pick(AWKWARD) if self.rng.random() < 0.9 else None)

    def place(self, arg, value, axes, fixed, x):
        """``(argument, axes, fixed)`` with ``value`` in the place ``arg`` names: the
        whole ``axes`` or ``fixed``, the axis ``x``, or one fixed value."""
        if arg == "axes":
            return arg, value, fixed
        if arg == "axis":
            return x, {**axes, x: value}, fixed
        if arg == "fixed":
            return arg, axes, value
        if not fixed:
            return "fixed", axes, value
        name = self.pick(sorted(fixed))
        return name, axes, {**fixed, name: value}

    def model(self):
        return phasemap.get_model(self.pick(self.models))

    # -- one state, the registry --------------------------------------------------
    def classify(self):
        m = self.model()
        values = _values(m, self.rng)
        name, value = self.awkward(self.pick([*m.names, "model", "nosuch"]))
        if name == "model":
            return "classify", "model", value, lambda: phasemap.classify(value, **values)
        if value is not None:
            values[name] = value
        return "classify", name, value, lambda: phasemap.classify(m.name, **values)

    def registry(self):
        name, value = self.awkward("model")
        fn = self.pick([phasemap.get_model, phasemap.layers_for])
        value = value if value is not None else self.pick(self.models)
        return fn.__name__, "model", value, lambda: fn(value)

    # -- maps ---------------------------------------------------------------------
    def scene(self):
        m = self.model()
        state = [v.name for v in m.state]
        x, y = self.rng.sample(state, 2) if len(state) > 1 else (state[0], m.params[0].name)
        n = self.rng.choice([1, 3, 8])
        for _ in range(50):  # a grid whose every corner the model accepts
            axes = {x: np.linspace(*_axis_range(m.variables[x], self.rng), n),
                    y: np.linspace(*_axis_range(m.variables[y], self.rng), 4)}
            fixed = {k: v for k, v in _values(m, self.rng).items() if k not in axes}
            if _accepted(m, *({**fixed, x: a, y: b} for a in axes[x][[0, -1]]
                              for b in axes[y][[0, -1]])):
                break
        layers = None
        options = None
        arg, value = self.awkward(self.pick(["axes", "axis", "fixed", "fixed value", "layers",
                                             "options", "option value", "chunks"]))
        if value is not None and arg in ("axes", "axis", "fixed", "fixed value"):
            arg, axes, fixed = self.place(arg, value, axes, fixed, x)
        elif value is not None:
            if arg == "layers":
                layers = value
            elif arg in ("options", "option value"):
                if m.dynamics is None:
                    arg, options = "options", value
                else:
                    arg = "options" if arg == "options" else self.pick(
                        ["t_end", "rtol", "atol", "max_step", "max_steps", "max_events",
                         "method"])
                    layers = ["fate"]
                    options = value if arg == "options" else {arg: value, "t_end": 0.5}
        chunks = value if arg == "chunks" else None
        compute = self.rng.random() < 0.5

        def call():
            scene = phasemap.Scene(m.name, axes=axes, fixed=fixed, layers=layers,
                                   options=options)
            scene.estimate(timed=False)
            if compute or chunks is not None:
                ds = scene.compute(chunks=chunks)
                return ds.load()
            return scene.size
        return "Scene", arg, value, call

    def from_spec(self):
        arg, value = self.awkward("spec")
        spec = value if value is not None else {"model": "ladder", "axes": {"phi": [0.1, 0.2]}}
        return "Scene.from_spec", "spec", value, lambda: phasemap.Scene.from_spec(spec)

    # -- motion -------------------------------------------------------------------
    def simulate(self):
        m = phasemap.get_model(self.pick([n for n in self.models
                                          if phasemap.get_model(n).dynamics is not None]))
        values = _values(m, self.rng)
        kw = {"t_end": self.rng.uniform(0.01, 1.0), "max_steps": 20000}
        arg, value = self.awkward(self.pick(
            [*m.names, "t_end", "rtol", "atol", "max_step", "max_steps", "max_events",
             "method", "t_eval", "impact_law", "restitution", "painleve", "zeno_speed"]))
        if value is not None:
            (values if arg in m.names else kw)[arg] = value
        return "simulate", arg, value, lambda: phasemap.simulate(m.name, **kw, **values)

    def phase_curve(self):
        ones = [n for n in self.models if (d := phasemap.get_model(n).dynamics) is not None
                and len(d.coordinates) == 1]
        m = phasemap.get_model(self.pick(ones))
        values = _values(m, self.rng)
        kw = {"max_stages": 4}
        arg, value = self.awkward(self.pick(
            [*m.names, "phi_range", "max_stages", "points_per_stage", "rtol"]))
        if value is not None:
            (values if arg in m.names else kw)[arg] = value
        return "phase_curve", arg, value, lambda: phasemap.phase_curve(m.name, **kw,
                                                                       **values)

    # -- the bifurcation set ------------------------------------------------------
    def _slice(self):
        m = phasemap.get_model(self.pick(self.slices))
        state = [v.name for v in m.state]
        p = "f" if "f" in m.names else "delta"
        x = state[0]
        for _ in range(50):  # a slice whose every corner the model accepts
            axes = {x: _axis_range(m.variables[x], self.rng),
                    p: tuple(sorted((self.rng.uniform(0.05, 1.0), self.rng.uniform(1.1, 2.0))))}
            fixed = {k: v for k, v in _values(m, self.rng).items() if k not in axes}
            if _accepted(m, *({**fixed, x: a, p: b} for a in axes[x] for b in axes[p])):
                break
        return m, x, p, axes, fixed

    def boundaries(self):
        m, x, p, axes, fixed = self._slice()
        kw = {"layer": self.pick(["n_solutions", "stagnation"]), "tol": 1e-8,
              "strict": False}
        arg, value = self.awkward(self.pick(["axes", "axis", "fixed", "fixed value",
                                             "layer", "tol", "conditions", "strict"]))
        if value is not None and arg in ("axes", "axis", "fixed", "fixed value"):
            arg, axes, fixed = self.place(arg, value, axes, fixed, x)
        elif value is not None:
            kw[arg] = value

        def call():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return phasemap.boundaries(m.name, axes, fixed, **kw)
        return "boundaries", arg, value, call

    def threshold(self):
        m, x, p, axes, fixed = self._slice()
        kw = {"layer": "n_solutions", "value": self.pick([0, 1, 2]),
              "over": {x: axes[x]}, "fixed": fixed, "side": self.pick(["min", "max"]),
              "tol": 1e-8}
        arg, value = self.awkward(self.pick(["param", "layer", "value", "over", "fixed",
                                             "side", "tol", "along"]))
        param = p
        if value is not None:
            if arg == "param":
                param = value
            elif arg == "along":
                kw.pop("over")
                kw["along"] = value
            else:
                kw[arg] = value
        return "threshold", arg, value, lambda: phasemap.threshold(m.name, param, **kw)

    # -- files and figures --------------------------------------------------------
    def files(self):
        entry = self.pick(["open_atlas", "describe_atlas", "write_atlas"])
        arg, value = self.awkward(self.pick(["path", "path", "ds", "complevel", "chunks"])
                                  if entry == "write_atlas" else "path")
        if arg == "path" and self.rng.random() < 0.6:
            value = self.pick(self.paths)
        if entry == "open_atlas":
            path = value if value is not None else self.atlas
            return entry, "path", value, lambda: phasemap.open_atlas(path).load()
        if entry == "describe_atlas":
            path = value if value is not None else self.atlas
            return entry, "path_or_ds", value, lambda: phasemap.describe_atlas(path)
        kw = {"ds": self.ds, "path": self.folder / f"out{self.rng.randrange(4)}.nc"}
        if value is not None or arg != "path":
            kw[arg] = value
        return entry, arg, value, lambda: phasemap.write_atlas(**kw)

    def figure(self):
        import matplotlib.pyplot as plt

        arg, value = self.awkward(self.pick(["ds", "layer", "size"]))
        kw = {"ds": self.ds}
        if value is not None:
            kw[arg] = value
        accessor = self.rng.random() < 0.5 and kw["ds"] is self.ds

        def call():
            try:
                if accessor:
                    return self.ds.phasemap.plot(**{k: v for k, v in kw.items() if k != "ds"})
                return phasemap.plot.plot(**kw)
            finally:
                plt.close("all")
        return ("Dataset.phasemap.plot" if accessor else "plot"), arg, value, call

    # -- the command line ---------------------------------------------------------
    def command(self):
        """``phasemap COMMAND ...`` in this process (``cli.main``), one token awkward."""
        m = self.model()
        vals = [f"{k}={v!r}" for k, v in _values(m, self.rng).items()
                if self.rng.random() < 0.3]
        out = str(self.folder / f"cli{self.rng.randrange(4)}.nc")
        x = m.state[0].name
        lo, hi = _axis_range(m.variables[x], self.rng)
        grammars = {
            "table": ["table"],
            "models": ["models", m.name],
            "classify": ["classify", m.name, *vals],
            "atlas": ["atlas", m.name, "--axis", f"{x}={lo}:{hi}:5", "-o", out, "--overwrite"],
            "info": ["info", str(self.atlas)],
            "cfcheck": ["cfcheck", str(self.atlas)],
            "cache": ["cache", "info"],
            "boundaries": ["boundaries", "ladder", "--axis", "phi=0.1:1.4", "--axis",
                           "f=0.1:1.5", "-o", out, "--overwrite"],
            "threshold": ["threshold", "ladder", "f", "--over", "phi=0.1:1.4"],
            "tour": ["tour", "--only", "nosuch", "--out", str(self.folder / "tour")],
        }
        if m.dynamics is not None:
            grammars["simulate"] = ["simulate", m.name, *vals, "--t-end", "0.2"]
        if self.heavy:
            grammars["plot"] = ["plot", str(self.atlas), "-o", str(self.folder / "fig")]
        name = self.pick(sorted(grammars))
        argv = list(grammars[name])
        token = self.pick(AWKWARD_TOKENS)
        where = self.rng.randrange(1, len(argv) + 1)
        if self.rng.random() < 0.5 and where < len(argv):
            argv[where] = token
        else:
            argv.insert(where, token)
        if name == "cache" and "clear" in argv:  # never empty the cache under the fuzz
            argv = ["cache", "info"]
        if name == "tour":  # a valid tour runs for minutes: never ask for one
            at = argv.index("--only") if "--only" in argv else -1
            if at < 0 or at + 1 >= len(argv) or argv[at + 1] != "nosuch":
                argv += ["--only", "nosuch"]
        return "phasemap " + name, "argv", argv, lambda: _command(argv)


def _command(argv):
    """Run ``phasemap argv`` in this process: (exit code, stdout, stderr)."""
    from phasemap import cli

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main([str(a) for a in argv])
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else 2
    return code, out.getvalue(), err.getvalue()


#: The cases and how often each is drawn (the figures and the bifurcation set take
#: longest: tens of milliseconds to a second a call).
WEIGHTS = {"classify": 30, "registry": 4, "scene": 16, "from_spec": 3, "simulate": 12,
           "phase_curve": 8, "boundaries": 3, "threshold": 3, "files": 10, "figure": 2,
           "command": 9}


# ---------------------------------------------------------------------- judging -----

def _judge(tally: Tally, entry: str, arg: str, value, call) -> None:
    """Run one case and record what it did."""
    text_value = repr(value) if entry.startswith("phasemap ") else describe(value)
    compiles = compiletime.count()
    t0 = time.perf_counter()
    problem = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = call()
    except (ValueError, TypeError) as err:
        text = str(err)
        module = type(err).__module__
        if not (module == "builtins" or module.startswith("phasemap")):
            problem = f"{type(err).__module__}.{type(err).__name__}: {text[:300]}"
        elif "Traceback" in text or "numba" in text.lower():
            problem = f"internal text: {text[:300]}"
        elif not _names(text, arg, value):
            problem = f"does not name {arg!r}: {type(err).__name__}: {text[:300]}"
        tally.refused[entry] = tally.refused.get(entry, 0) + 1
    except Exception as err:  # noqa: BLE001 - anything else is what the fuzz looks for
        problem = f"{type(err).__module__}.{type(err).__name__}: {str(err)[:300]}"
        tally.refused[entry] = tally.refused.get(entry, 0) + 1
    else:
        counts = tally.answered
        if entry.startswith("phasemap "):
            problem = _judge_command(result)
            if result[0] != 0:  # a command that refused (exit 1 or 2)
                counts = tally.refused
        elif isinstance(result, phasemap.Classification) and not all(
                math.isfinite(v) for b in result.branches
                for v in (*b.accelerations.values(), *b.reactions.values())):
            problem = "an admissible branch with a non-finite value"
        counts[entry] = counts.get(entry, 0) + 1
    took = time.perf_counter() - t0
    if compiletime.count() != compiles:
        tally.compiling += 1
    elif took > BOUND:
        problem = problem or f"took {took:.1f} s (bound {BOUND:g} s)"
    if took > tally.slowest[0] and compiletime.count() == compiles:
        tally.slowest = (took, f"{entry} {arg}={text_value}")
    if problem:
        tally.failures.append(f"{entry}({arg}={text_value}): {problem}")


def _names(text: str, arg: str, value) -> bool:
    """Whether a refusal names what was wrong: the argument, or (for a path, a mapping's
    key or a list) the value itself."""
    words = {arg, arg.replace("_", " ")}
    if any(re.search(rf"(?<![A-Za-z0-9_]){re.escape(w)}(?![A-Za-z0-9_])", text) for w in words):
        return True  # the name as a word: "f" is not named by "omega must be finite"
    if "outside the domain" in text:
        return True  # the model's own domain condition, with the values it read
    if value is None:
        return True  # a valid call refused for its own reasons (a class that never exists)
    if isinstance(value, (str, pathlib.Path)) and str(value) and str(value) in text:
        return True
    if isinstance(value, dict) and any(isinstance(k, str) and repr(k) in text for k in value):
        return True  # the key of a mapping that is not a name of the model
    return False


def _judge_command(result) -> str | None:
    code, out, err = result
    if "Traceback" in err or "Traceback" in out:
        return "a traceback: " + err[-300:]
    if code == 0:
        return None
    if code not in (1, 2):  # 2: bad input; 1: the file system refused
        return f"exit code {code}: {err[-300:]}"
    last = err.strip().splitlines()[-1] if err.strip() else ""
    if not last.startswith("phasemap"):
        return f"exit {code} without a one-line error: {err[-300:]!r}"
    return None


def run(n: int, seed: int, models: list[str], folder: pathlib.Path, atlas: pathlib.Path,
        heavy: bool = True, weights: dict | None = None, progress=None,
        slices: list[str] | None = None) -> Tally:
    """``n`` cases drawn with ``seed`` over ``models``, files in ``folder``; ``atlas`` a
    small map atlas of one of them.  ``heavy``: the figures and the ``plot`` command
    too.  ``slices``: the models whose slices ``boundaries`` and ``threshold`` trace
    (default: every one of ``models``).  A call that never returns is caught by
    ``faulthandler``: the process dumps its stack and exits after :data:`WATCHDOG`."""
    rng = random.Random(seed)
    cases = Cases(rng, models, folder, atlas, heavy, slices)
    weights = dict(weights or WEIGHTS)
    if not heavy:
        weights.pop("figure", None)
    tally = Tally()
    with contextlib.chdir(folder):  # a command given a bare word as its output writes here
        _cases(n, rng, cases, weights, tally, progress)
    return tally


def _cases(n, rng, cases, weights, tally, progress) -> None:
    import faulthandler

    kinds, w = zip(*weights.items())
    for i in range(n):
        kind = rng.choices(kinds, w)[0]
        entry, arg, value, call = getattr(cases, kind)()
        faulthandler.dump_traceback_later(WATCHDOG, exit=True)
        try:
            _judge(tally, entry, arg, value, call)
        finally:
            faulthandler.cancel_dump_traceback_later()
        if progress is not None:
            progress(i + 1, tally)
