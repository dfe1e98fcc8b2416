"""The README's examples and the docstring examples run as written."""

from __future__ import annotations

import doctest
import pathlib
import subprocess
import sys

import pytest

import importlib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_readme_examples():
    result = doctest.testfile(str(ROOT / "README.md"), module_relative=False,
                              optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 8 and result.failed == 0


@pytest.mark.parametrize("module", ["phasemap._args", "phasemap.classify", "phasemap.scene",
                                    "phasemap.simulate", "phasemap.phase", "phasemap.plot",
                                    "phasemap.study", "phasemap.cache", "phasemap.blocks"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted >= 2 and result.failed == 0


def test_readme_quick_start_has_exactly_two_commands():
    text = (ROOT / "README.md").read_text()
    block = text.split("## Quick start", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    commands = [line for line in block.splitlines() if line.strip()]
    assert len(commands) == 2
    assert "pytest" in commands[1] and "pytest" in (ROOT / ".ci" / "run").read_text()


def test_cli_table_and_errors():
    run = [sys.executable, "-m", "phasemap.cli"]
    out = subprocess.run(run + ["table"], capture_output=True, text=True, check=True).stdout
    assert "0 none" in out and "2 two" in out and out.count("\n") >= 13
    assert "phasemap tour" in (ROOT / "README.md").read_text().split("```bash")[1].split("\n")[1]
    bad = subprocess.run(run + ["classify", "ladder", "phi=9"], capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.strip() == ("phasemap: error: ladder: phi = 9 is outside its domain "
                                  "[0, 1.5707963267948966] (angle of the bar from the vertical, rad)")
    assert "Traceback" not in bad.stderr


def test_import_phasemap_leaves_matplotlib_until_plot_is_used():
    code = ("import sys, phasemap; before = 'matplotlib' in sys.modules; "
            "from phasemap import plot; print(before, 'matplotlib' in sys.modules, "
            "plot is phasemap.plot, callable(phasemap.plot.plot))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "True", "True", "True"]
