"""A warm process maps without sympy, and a changed declaration is never loaded stale.

Assertions on modules and values, not on time (benchmarks/cold_start.py times it).
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import phasemap
from phasemap.declare import loader as _declared
from phasemap.systems import DECLARED

ROOT = Path(__file__).resolve().parents[1]

#: A small map of each model over its default axes (default layers), then the heavy
#: modules that were imported after it, and the map's bytes hashed, as JSON.
#: ``numba.np.linalg`` is imported by numba's registry refresh alone, which every
#: compilation runs and phasemap's loads from the cache skip (``cache._load_without_refresh``).
MAP_EVERY_MODEL = """
import hashlib, json, sys
import numpy as np
import phasemap
heavy = ("sympy", "dask", "matplotlib", "numba.np.linalg")
seen = {"import phasemap": [m for m in heavy if m in sys.modules]}
maps = {}
for name in phasemap.MODELS:
    m = phasemap.get_model(name)
    axes = {k: np.linspace(a, b, 8) for k, (a, b, _) in list(m.default_axes.items())[:2]}
    ds = phasemap.Scene(name, axes=axes).compute()
    seen[name] = [m for m in ("sympy", "dask.array", "matplotlib", "numba.np.linalg")
                  if m in sys.modules]
    maps[name] = hashlib.sha256(b"".join(ds[v].values.tobytes()
                                         for v in sorted(ds.data_vars))).hexdigest()
print(json.dumps([seen, maps]))
"""


def _run(code: str, *args, env=None) -> str:
    run = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                         cwd=ROOT, timeout=1800, env=env)
    assert run.returncode == 0, run.stderr
    return run.stdout.strip().splitlines()[-1]


@pytest.mark.slow
def test_a_warm_process_maps_every_built_in_model_without_sympy():
    """The first process fills the kernel cache; the second finds every declared model's
    manifest there and never builds a declaration: no sympy, no dask, no matplotlib.  It
    compiles nothing either, and loads numba's code without refreshing numba's registries
    (half a second of a cold start): the maps are those of a process that compiled them."""
    _, compiled = json.loads(_run(MAP_EVERY_MODEL))
    seen, loaded = json.loads(_run(MAP_EVERY_MODEL))
    assert set(seen) == {"import phasemap", *phasemap.MODELS}
    assert seen == {k: [] for k in seen}
    assert set(loaded) == set(phasemap.MODELS) and loaded == compiled


CLASSIFY = """
import json, sys
import phasemap
c = phasemap.classify(sys.argv[1], theta=0.6, omega=-1.0, xdot=-1.0, f=0.2)
print(json.dumps([c.n_solutions, [b.accelerations.get("theta_ddot") for b in c.branches],
                  "sympy" in sys.modules]))
"""


@pytest.mark.slow
def test_a_changed_declaration_is_derived_again_never_loaded_stale(tmp_path):
    """A declaration file's manifest is keyed on its bytes: after an edit that changes the
    physics (the rod's inertia) a warm process uses the new derivation.  The Painleve rod:
    the smallest built-in declaration (one contact), the quickest to derive and compile."""
    src = (ROOT / "phasemap" / "systems" / "painleve_rod.py").read_text()
    src = src.replace('"painleve_rod", "Painleve', '"edited_rod", "Painleve')
    assert "inertia=m * l**2 / 3" in src and "edited_rod" in src
    edited = src.replace("inertia=m * l**2 / 3", "inertia=m * l**2 / 12")
    path, twin = tmp_path / "edited_rod.py", tmp_path / "edited_rod_edited.py"
    path.write_text(src)
    twin.write_text(edited)
    expected = phasemap.classify(twin, theta=0.6, omega=-1.0, xdot=-1.0, f=0.2)  # with sympy
    # a cache of this test's own: a kept cache would hold the edited file's manifest from
    # an earlier run, and the edit would rightly load without sympy
    env = dict(os.environ, PHASEMAP_CACHE_DIR=str(tmp_path / "cache"))
    _run(CLASSIFY, str(path), env=env)                                 # fills the cache
    n, before, sympy = json.loads(_run(CLASSIFY, str(path), env=env))
    assert not sympy                                                   # from the manifest
    path.write_text(edited)
    n, after, sympy = json.loads(_run(CLASSIFY, str(path), env=env))
    assert sympy                                                       # derived again
    new = [b.accelerations.get("theta_ddot") for b in expected.branches]
    assert after == new and after != before and n == expected.n_solutions
    n, again, sympy = json.loads(_run(CLASSIFY, str(path), env=env))
    assert again == new and not sympy


def test_a_model_from_the_manifest_is_the_derived_model():
    """Every field but the closures (check) and the declaration round-trips through the
    manifest; the lazy declaration builds the System on use."""
    source = DECLARED["wheel"]
    S = _declared.system(source)
    derived = S.model
    data = json.loads(json.dumps(_declared.manifest(S, derived)))
    module = sys.modules["phasemap_kernel_" + data["module"]]
    rebuilt = _declared.build(data, module, S.check, _declared.Declaration(source))
    for f in dataclasses.fields(derived):
        if f.name not in ("check", "declaration"):
            assert getattr(rebuilt, f.name) == getattr(derived, f.name), f.name
    assert rebuilt.declaration.system is S and rebuilt.declaration.name == "wheel"
    assert data["check"] == "phasemap.systems.seeds.checks:centre_of_mass_inside_the_disc"
    try:
        rebuilt.check({"l": 2.0, "r": 1.0})
    except ValueError as e:
        assert "must not exceed r" in str(e)
    else:
        raise AssertionError("the wheel's domain check did not run")


def test_a_check_defined_in_the_declaration_file_keeps_the_slow_path(tmp_path):
    """A check the manifest cannot name (defined in the declaration file) writes no
    manifest: such a file is built in every process, as before, never half-loaded."""
    source = DECLARED["wheel"]
    S = _declared.system(source)

    def local(values):
        return None

    assert _declared.manifest(dataclasses.replace(S, check=local), S.model) is None
    path = tmp_path / "uses_open.py"
    path.write_text("import sympy\nSYSTEM = eval(open('x.txt').read())\n")
    assert _declared.key_of(path) is None
    path.write_text("import scipy\n")
    assert _declared.key_of(path) is None
