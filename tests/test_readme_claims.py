"""The README's quick start and install extras, and the user guide's models table, say
what is true (issue 23 item 8); each check failed on the README before."""

from __future__ import annotations

import pathlib
import re
import tomllib

from phasemap import MODELS, cli

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
#: the models table moved with the README's long sections to the user guide
CLASSES = (ROOT / "docs" / "guide" / "classes.md").read_text()


def test_the_models_table_lists_every_model_that_phasemap_models_lists():
    table = CLASSES.split("## The models", 1)[1].split("\n\n", 2)[1]
    rows = re.findall(r"^\| `([a-z_]+)` \|", table, flags=re.M)
    listed = re.findall(r"^([a-z_]+): ", cli._models(), flags=re.M)
    assert listed == list(MODELS)
    assert rows == listed


def test_the_quick_start_makes_and_enters_a_virtual_environment():
    block = README.split("## Quick start", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    first, second = [line for line in block.splitlines() if line.strip()]
    assert first.startswith("python3 -m venv .venv && . .venv/bin/activate && pip install .")
    assert second.startswith(". .venv/bin/activate && ")


def test_cfchecker_is_a_pip_extra():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert any(req.startswith("cfchecker") for req in extras["cf"])
    assert 'pip install ".[cf]"' in README
