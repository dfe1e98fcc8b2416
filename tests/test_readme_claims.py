"""The README's quick start and install extras, and the user guide's models table, say
what is true (issue 23 item 8); each check failed on the README before."""

from __future__ import annotations

import pathlib
import re
import tomllib

from phasemap import MODELS, cli
from phasemap.systems import OSCILLATORS
import math
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
#: the models table moved with the README's long sections to the user guide
CLASSES = (ROOT / "docs" / "guide" / "classes.md").read_text()


def test_the_models_table_lists_every_model_that_phasemap_models_lists():
    table = CLASSES.split("## The models", 1)[1].split("\n\n", 2)[1]
    rows = re.findall(r"^\| `([a-z_]+)` \|", table, flags=re.M)
    listed = re.findall(r"^([a-z_]+): ", cli._models(), flags=re.M)
    assert listed == list(MODELS) + list(OSCILLATORS)   # the oscillators in full coordinates
    assert rows == listed


def _quick_start(page: pathlib.Path) -> list[str]:
    block = page.read_text().split("## Quick start", 1)[1].split("```bash", 1)[1]
    return [line for line in block.split("```", 1)[0].splitlines() if line.strip()]


def test_the_quick_start_is_two_commands_and_ci_runs_the_second_as_written():
    """The README (and the docs' front page, which repeats it) hold exactly two commands,
    each making and entering the virtual environment, so either works first on a fresh
    machine; .ci/run runs the second character for character (issue 41 item 1)."""
    commands = _quick_start(ROOT / "README.md")
    assert _quick_start(ROOT / "docs" / "index.md") == commands
    assert len(commands) == 2
    first, second = commands
    assert first == ("python3 -m venv .venv && . .venv/bin/activate && "
                     "pip install . && phasemap tour")
    assert second.startswith("python3 -m venv .venv && . .venv/bin/activate && ")
    assert second.endswith("python -m pytest -q")
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert any(line.startswith(second + " ") or line == second for line in ci), second


def test_the_test_extra_installs_every_module_the_tests_import():
    """A fresh clone that installs only ``.[test]`` (the README's command) must pass: every
    third-party module a test imports is a dependency or in the test extra."""
    import ast
    import sys

    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = {re.split(r"[<>=\[ ]", r, maxsplit=1)[0].lower().replace("-", "_")
              for r in meta["dependencies"] + meta["optional-dependencies"]["test"]}
    # import names that differ from their distribution's, and what sympy brings along
    also = {"yaml": "pyyaml", "mpmath": "sympy", "cfchecker": "cfchecker", "netCDF4": "netcdf4",
            "PIL": "matplotlib", "numpydoc": "numpydoc", "docutils": "numpydoc"}
    # the tests' own modules, and the docs' scripts a test puts on its path
    local = ({p.stem for p in (ROOT / "tests").iterdir()} | {"phasemap"}
             | {p.stem for p in (ROOT / "docs").glob("*.py")})
    missing = set()
    for f in (ROOT / "tests").glob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.module
                     and not node.level else [])
            for name in names:
                root = name.split(".")[0]
                if root in sys.stdlib_module_names or root in local:
                    continue
                dist = also.get(root, root).lower().replace("-", "_")
                if dist not in wanted:
                    missing.add(f"{f.name}: {root}")
    assert not missing, sorted(missing)


def test_cfchecker_is_a_pip_extra():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert any(req.startswith("cfchecker") for req in extras["cf"])
    assert 'pip install ".[cf]"' in README


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
    # lambda_+ = 1 + sin^2 phi - f sin phi cos phi over phi, from its definition (not
    # from the minimum (3 - sqrt(1 + f^2))/2 that facts.py uses): at the threshold its
    # minimum touches 0, a relative 1e-6 below it stays above 0 (by ~1.3e-6) and above it
    # dips below.  The grid (step 3e-5) misses the minimum by at most 3 (1.6e-5)^2 ~ 1e-9.
    # (The check was a scan of the closed form itself in steps of 1e-3.)
    f_star = elliptic_threshold()
    assert f_star == pytest.approx(2 * math.sqrt(2), rel=1e-15)

    def lam_min(f):
        return np.min(1 + np.sin(phi) ** 2 - f * np.sin(phi) * np.cos(phi))
    assert lam_min(f_star) == pytest.approx(0.0, abs=1e-8)
    assert lam_min(f_star * (1 - 1e-6)) > 1e-7 and lam_min(f_star * (1 + 1e-6)) < -1e-7
