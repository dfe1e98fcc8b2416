"""The house's rules, read from the code (docs/architecture.py, ARCHITECTURE.md).

Each check reads the imports of every module of phasemap as text (ast), so it costs
no compilation.  A failure names the file, the line and the rule.
"""

from __future__ import annotations

import importlib.util
import pathlib
import textwrap

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def plan():
    spec = importlib.util.spec_from_file_location("architecture", ROOT / "docs" / "architecture.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_house_keeps_its_rules(plan):
    """No upward import, no circle, no private name across parts, no oversized file."""
    bad = plan.violations()
    assert bad == [], "\n".join(bad)


def test_every_module_is_in_a_ranked_part(plan):
    parts = {plan.part(m) for m in plan.modules()}
    assert parts == set(plan.PARTS)


def test_long_files_are_still_long(plan):
    """An entry of LONG whose file has shrunk (or gone) is stale: the list stays true."""
    for rel in plan.LONG:
        path = ROOT / rel
        assert path.exists(), rel
        assert len(path.read_text().splitlines()) > plan.MAX_LINES, rel


def _write(root: pathlib.Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(textwrap.dedent(text))


def test_the_checker_sees_each_kind_of_break(plan, tmp_path, monkeypatch):
    """The rules can fail: a planted package with one break of each kind is caught."""
    _write(tmp_path, {
        "phasemap/__init__.py": "",
        "phasemap/core/__init__.py": "",
        "phasemap/core/a.py": "def f():\n    from phasemap.maps import b  # upward\n",
        "phasemap/maps/__init__.py": "",
        "phasemap/maps/b.py": "from phasemap.maps import c\nfrom phasemap.core.a import _hidden\n",
        "phasemap/maps/c.py": "from phasemap.maps import b\n",
        "phasemap/plot/__init__.py": "",
        "phasemap/plot/d.py": "from phasemap.core import a as A\nx = A._private\n"
                              + "y = 1\n" * (plan.MAX_LINES + 1),
        "phasemap/plot/e.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                              "    from phasemap.front import Z\n",
    })
    monkeypatch.setattr(plan, "ROOT", tmp_path)
    monkeypatch.setattr(plan, "PACKAGE", tmp_path / "phasemap")
    monkeypatch.setattr(plan, "LONG", {})
    text = "\n".join(plan.violations())
    assert "phasemap.core.a (core) imports phasemap.maps.b (maps), a higher part" in text
    assert "a circle: phasemap.core.a -> phasemap.maps.b -> phasemap.maps.c" in text
    assert "imports the private name phasemap.core.a._hidden of core" in text
    assert "uses the private name phasemap.core.a._private of core" in text
    assert f"phasemap/plot/d.py: {plan.MAX_LINES + 3} lines" in text
    assert "plot/e.py" not in text  # an annotation-only import is not an arrow


def test_the_suite_keeps_each_module_on_one_worker(request):
    """pytest-xdist's ``--dist loadgroup`` sends a group to one worker by appending the
    group to each test's node id (tests/conftest.py adds the groups).  pytest 9.2 keeps
    node ids where pytest-xdist 3.8 cannot append to them: every test lost its group, each
    module's kernels and every study ran on both workers (CI took 1 702 s), and no test
    failed.  pyproject.toml holds pytest below 9.2 for that; this
    test fails if the groups are lost again."""
    if not getattr(request.config.option, "loadgroup", False):
        pytest.skip("not run under pytest-xdist with --dist loadgroup")
    assert request.node.nodeid.endswith("@tests/test_architecture.py"), request.node.nodeid
