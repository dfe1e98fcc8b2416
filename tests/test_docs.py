"""The documentation runs as written: the README's examples, every code block of the
user guide, the docstring examples, and an API reference entry for every public name."""

from __future__ import annotations

import argparse
import doctest
import importlib
import inspect
import io
import os
import pathlib
import re
import shlex
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
GUIDE_PAGES = sorted((DOCS / "guide").glob("*.md")) + [DOCS / "index.md"]
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE

# fenced blocks: pycon (doctest), python (run; a first line "# NAME.py" also saves it as
# NAME.py), console ("$ command" lines run, the lines after each its expected output),
# text (synopses and formulas, not code); bash only for the front page's quick start
FENCE = re.compile(r"^(?P<fence>`{3,})(?P<lang>[^\s`]*)[^\n]*\n(?P<body>.*?)^(?P=fence)\s*$",
                   re.M | re.S)
LANGUAGES = {"pycon", "python", "console", "text", "bash"}


def test_readme_examples():
    result = doctest.testfile(str(ROOT / "README.md"), module_relative=False, optionflags=FLAGS)
    assert result.attempted >= 2 and result.failed == 0


def code_blocks(page: pathlib.Path):
    """(language, body, line) of each fenced block; MyST directives ({image}...) are skipped."""
    text = page.read_text()
    for m in FENCE.finditer(text):
        lang = m.group("lang")
        if lang.startswith("{"):
            continue
        yield lang, m.group("body"), text.count("\n", 0, m.start("body")) + 1


def _run_console(body: str, where: pathlib.Path, line: int, page: str) -> list[str]:
    failures = []
    checker = doctest.OutputChecker()
    steps = re.split(r"^\$ ", body, flags=re.M)[1:]
    for step in steps:
        command, _, expected = step.partition("\n")
        argv = shlex.split(command)
        if argv[0] == "phasemap":
            argv = [sys.executable, "-m", "phasemap.cli"] + argv[1:]
        elif argv[0] == "python":
            argv = [sys.executable] + argv[1:]
        else:
            failures.append(f"{page}:{line}: only phasemap and python commands run here: "
                            f"{command}")
            continue
        done = subprocess.run(argv, cwd=where, capture_output=True, text=True, timeout=600,
                              env={**os.environ, "PYTHONPATH": os.pathsep.join(
                                  [str(ROOT), os.environ.get("PYTHONPATH", "")])})
        if done.returncode != 0:
            failures.append(f"{page}:{line}: `{command}` exited {done.returncode}:\n"
                            f"{done.stderr[-2000:]}")
        elif expected.strip() and not checker.check_output(expected, done.stdout, FLAGS):
            failures.append(f"{page}:{line}: `{command}` printed\n{done.stdout}\n"
                            f"expected\n{expected}")
    return failures


def run_page(page: pathlib.Path, where: pathlib.Path) -> tuple[int, list[str]]:
    """Run every code block of ``page`` in order, in one namespace, in folder ``where``;
    return the number of blocks run and the failures."""
    name = str(page.relative_to(ROOT)) if page.is_relative_to(ROOT) else page.name
    globs: dict = {"__name__": "__docs__"}
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    parser = doctest.DocTestParser()
    failures: list[str] = []
    ran = 0
    old = os.getcwd()
    os.chdir(where)
    sys.path.insert(0, str(where))
    try:
        for lang, body, line in code_blocks(page):
            if lang not in LANGUAGES:
                failures.append(f"{name}:{line}: code block of unknown language {lang!r}")
            elif lang == "bash" and page.name != "index.md":
                failures.append(f"{name}:{line}: bash blocks do not run; use console")
            elif lang == "pycon":
                test = parser.get_doctest(body, globs, name, name, line - 1)
                out = io.StringIO()
                result = runner.run(test, out=out.write, clear_globs=False)
                globs.update(test.globs)  # a DocTest runs in a copy of the namespace
                failures += [out.getvalue()] if result.failed else []
                ran += 1
            elif lang == "python":
                first = body.splitlines()[0].strip()
                if re.fullmatch(r"# [\w]+\.py", first):
                    (where / first[2:]).write_text(body)
                exec(compile(body, f"{name}:{line}", "exec"), globs)
                ran += 1
            elif lang == "console":
                failures += _run_console(body, where, line, name)
                ran += 1
    finally:
        os.chdir(old)
        sys.path.remove(str(where))
        import matplotlib.pyplot as plt

        plt.close("all")
    return ran, failures


@pytest.mark.slow
@pytest.mark.parametrize("page", GUIDE_PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_guide_page_code_runs(page, tmp_path, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    ran, failures = run_page(page, tmp_path)
    assert not failures, "\n".join(failures)
    runnable = [lang for lang, _, _ in code_blocks(page) if lang not in ("text", "bash")]
    assert ran == len(runnable)


def test_guide_code_block_runner_catches_a_wrong_example(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```pycon\n>>> 1 + 1\n3\n```\n\n```console\n$ phasemap nonsense\n```\n"
                    "```python\n# made.py\nX = 1\n```\n```pycon\n>>> X\n1\n```\n")
    ran, failures = run_page(page, tmp_path)
    assert ran == 4 and len(failures) == 2
    assert "Expected:\n    3" in failures[0] and "exited 2" in failures[1]
    assert (tmp_path / "made.py").read_text() == "# made.py\nX = 1\n"


@pytest.mark.parametrize("module", ["phasemap.core.args", "phasemap.maps.classify", "phasemap.maps.scene",
                                    "phasemap.motion.simulate",
                                    "phasemap.motion.phase", "phasemap.plot", "phasemap.study",
                                    "phasemap.atlas.write", "phasemap.atlas.read",
                                    "phasemap.maps.layers", "phasemap.models", "phasemap.systems",
                                    "phasemap.systems.seeds.closed_forms",
                                    "phasemap.core.model", "phasemap.core.events", "phasemap.core.cache",
                                    "phasemap.core.memo", "phasemap.motion.impact",
                                    "phasemap.maps.blocks", "phasemap.declare.system",
                                    "phasemap.declare.api", "phasemap.declare.contacts",
                                    "phasemap.declare.law", "phasemap.declare.admissibility",
                                    "phasemap.warm", "phasemap.core.lazy",
                                    "phasemap.core.jit"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module))
    assert result.attempted >= 2 and result.failed == 0


def test_cli_table_and_errors():
    run = [sys.executable, "-m", "phasemap.cli"]
    out = subprocess.run(run + ["table"], capture_output=True, text=True, check=True).stdout
    assert "0 none" in out and "2 two" in out and out.count("\n") >= 13
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


def test_import_phasemap_and_classify_leave_xarray_until_a_dataset_is_made():
    """xarray (and pandas) are half of what import phasemap cost; a process that only
    classifies never imports them, and the accessor is registered whoever imports xarray
    later: the user's own import, or phasemap's first Dataset."""
    code = ("import sys, phasemap; c = phasemap.classify('ladder', phi=1.2, omega=0.0); "
            "print(c.n_solutions, 'xarray' in sys.modules, 'pandas' in sys.modules); "
            "import xarray as xr; ds = xr.Dataset(attrs={'phasemap_model': 'ladder'}); "
            "print(type(ds.phasemap).__name__, ds.phasemap.model.name)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["1", "False", "False", "PhasemapAccessor", "ladder"]
    code = ("import sys, phasemap; ds = phasemap.Scene('ladder', axes={'phi': [0.5, 1.0]}, "
            "fixed={'omega': 0.0}).compute(); print('xarray' in sys.modules, ds.phasemap.kind)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["True", "profile"]


def test_when_imported_runs_at_once_or_after_the_import(tmp_path, monkeypatch):
    """phasemap.core.lazy.when_imported: a module already imported calls back at once;
    one imported later calls back after its code has run, once, with its real loader."""
    from phasemap.core import lazy

    seen = []
    lazy.when_imported("json", lambda m: seen.append(("now", m.__name__)))
    (tmp_path / "pm_lazy_probe.py").write_text("VALUE = 42\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    lazy.when_imported("pm_lazy_probe", lambda m: seen.append(("later", m.VALUE)))
    assert seen == [("now", "json")]
    pm_lazy_probe = importlib.import_module("pm_lazy_probe")     # (a module of tmp_path's)
    assert seen == [("now", "json"), ("later", 42)]
    assert type(pm_lazy_probe.__loader__).__name__ == "SourceFileLoader"
    importlib.reload(pm_lazy_probe)
    assert seen == [("now", "json"), ("later", 42)]
    assert any(isinstance(f, lazy._Finder) for f in sys.meta_path) == bool(lazy._WAITING)


def documented_names(api: pathlib.Path = DOCS / "api") -> set[str]:
    """Every qualified name the API reference gives an entry: the autosummary lists
    (under their ``currentmodule``), ``.. data::``, ``.. automodule::`` and ``.. module::``."""
    names: set[str] = set()
    for page in sorted(api.glob("*.rst")):
        module, in_summary = "", False
        for line in page.read_text().splitlines():
            directive = re.match(r"\.\. ([\w:-]+)::\s*(\S*)", line)
            if directive:
                kind, arg = directive.groups()
                in_summary = kind == "autosummary"
                if kind in ("currentmodule", "module", "automodule"):
                    module = arg
                    names.add(arg)
                elif kind == "data":
                    names.add(f"{module}.{arg}")
            elif in_summary and re.match(r"   [A-Za-z_]\w*\s*$", line):
                names.add(f"{module}.{line.strip()}")
            elif line and not line.startswith(" "):
                in_summary = False
    return names


def public_names() -> set[str]:
    """The public API: ``__all__`` of phasemap, phasemap.declare and phasemap.plot, the
    accessor's class, and ``phasemap.plot`` itself (a module)."""
    names = {"phasemap.accessor.PhasemapAccessor"}
    for module in ("phasemap", "phasemap.declare", "phasemap.plot"):
        mod = importlib.import_module(module)
        for name in mod.__all__:
            obj = getattr(mod, name)
            names.add(obj.__name__ if inspect.ismodule(obj) else f"{module}.{name}")
    return names


def test_every_public_name_has_a_reference_entry():
    missing = public_names() - documented_names()
    assert not missing, f"public names without an entry in docs/api/*.rst: {sorted(missing)}"


def test_reference_check_sees_a_name_left_out(tmp_path):
    (tmp_path / "one.rst").write_text(
        ".. currentmodule:: phasemap\n\n.. autosummary::\n   :toctree: generated/\n\n"
        "   classify\n   Scene\n\nText\n\n   simulate\n\n.. data:: MODELS\n")
    assert documented_names(tmp_path) == {"phasemap", "phasemap.classify", "phasemap.Scene",
                                          "phasemap.MODELS"}
    assert "phasemap.simulate" in public_names() - documented_names(tmp_path)


def test_cli_reference_has_every_subcommand_and_argument():
    sys.path.insert(0, str(DOCS / "_ext"))
    try:
        cli = importlib.import_module("phasemap_cli")
    finally:
        sys.path.remove(str(DOCS / "_ext"))
    parser, subs, _ = cli.parser_and_subcommands()
    page = "\n".join(cli.cli_rst())
    assert ".. phasemap-cli::" in (DOCS / "cli.rst").read_text()
    assert len(subs) >= 8
    for name, sub in subs.items():
        assert f".. _cli-{name}:" in page and f"``phasemap {name}``" in page
        for action in sub._actions:
            if action.option_strings and action.help != argparse.SUPPRESS and \
                    not isinstance(action, argparse._HelpAction):
                assert action.option_strings[-1] in page, (name, action.option_strings)


def numpydoc_gaps(modules=("phasemap", "phasemap.declare")) -> list[str]:
    """Public names of ``modules`` whose docstrings fall short of numpydoc form: a function
    without Parameters, Returns, Raises and Examples sections, a class without Examples."""
    from numpydoc.docscrape import NumpyDocString

    gaps = []
    for module in modules:
        mod = importlib.import_module(module)
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isfunction(obj):
                wanted = ("Parameters", "Returns", "Raises", "Examples")
            elif inspect.isclass(obj):
                wanted = ("Examples",)
            else:
                continue
            doc = NumpyDocString(inspect.getdoc(obj) or "")
            gaps += [f"{module}.{name}: no {s}" for s in wanted if not doc[s]]
    return gaps


def test_public_api_docstrings_are_numpydoc():
    assert not numpydoc_gaps()


def test_the_docs_build_fills_the_studies_claims_tables(monkeypatch):
    """The studies page's tables were empty on the built site (issue 41 item 15): the
    build fills them from the studies themselves (here stand-ins), on the page it renders."""
    import types

    from phasemap import tour

    sys.path.insert(0, str(DOCS))
    try:
        import claims
    finally:
        sys.path.remove(str(DOCS))
    monkeypatch.delenv("PHASEMAP_STUDY_CLAIMS", raising=False)   # CI sets it
    row = types.SimpleNamespace(claim="a | b", paper="p", measured="m", verdict="agrees")
    monkeypatch.setattr(tour, "load", lambda path: types.SimpleNamespace(
        main=lambda argv: [row] if "--quick" in argv else []))
    page = (DOCS / "guide" / "studies.md").read_text()
    assert all(not rows for rows in claims.parse(page).values())   # empty in the repository
    tables = claims.parse(claims.filled(page))
    assert set(tables) == set(tour.ORDER)
    assert all(rows == [("a | b", "p", "m", "agrees")] for rows in tables.values())
    conf = (DOCS / "conf.py").read_text()
    assert 'app.connect("source-read", _claims_tables)' in conf


def test_the_docs_build_takes_the_claims_the_test_session_kept(monkeypatch, tmp_path):
    """In CI the test session keeps each study's claims (tests/conftest.py, with
    PHASEMAP_STUDY_CLAIMS) and the docs build renders those; a study without a kept file
    is run as before, and nothing is read where the variable is unset."""
    import types

    from conftest import _keep_claims
    from phasemap import tour
    from phasemap.study import Claim

    sys.path.insert(0, str(DOCS))
    try:
        import claims
    finally:
        sys.path.remove(str(DOCS))
    ran = []
    row = types.SimpleNamespace(claim="ran", paper="p", measured="m", verdict="agrees")
    monkeypatch.setattr(tour, "load", lambda path: ran.append(path.stem) or
                        types.SimpleNamespace(main=lambda argv: [row]))
    kept = [Claim("kept | one", "0.5", "0.500001", "agrees"), Claim("two", "x", "y", "finding")]
    monkeypatch.setenv("PHASEMAP_STUDY_CLAIMS", str(tmp_path / "claims"))
    _keep_claims("ladder", kept)
    assert claims.from_tests("ladder") == kept and claims.from_tests("wheel") is None
    tables = claims.parse(claims.filled((DOCS / "guide" / "studies.md").read_text()))
    assert tables["ladder"] == [("kept | one", "0.5", "0.500001", "agrees"),
                                ("two", "x", "y", "finding")]
    assert all(tables[n] == [("ran", "p", "m", "agrees")] for n in tour.ORDER if n != "ladder")
    assert sorted(ran) == sorted(n for n in tour.ORDER if n != "ladder")
    monkeypatch.delenv("PHASEMAP_STUDY_CLAIMS")
    assert claims.from_tests("ladder") is None


def test_ci_docs_without_the_docs_extra_says_so_in_one_line(tmp_path):
    """``bash .ci/docs`` without the docs extra printed importlib's traceback before its
    message (issue 41 item 9).  A ``python`` on PATH whose metadata check fails as a
    missing distribution does stands in for an environment without the extra."""
    shim = tmp_path / "python"
    shim.write_text("#!/bin/sh\n"
                    f"exec {sys.executable} -c \"import importlib.metadata as m; "
                    "m.version('phasemap-no-such-dist')\"\n")
    shim.chmod(0o755)
    done = subprocess.run(["bash", str(ROOT / ".ci" / "docs")], capture_output=True, text=True,
                          env={**os.environ, "PATH": f"{tmp_path}{os.pathsep}"
                                                     f"{os.environ['PATH']}"}, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        'CI: the docs extra is missing: pip install ".[docs]" first (.ci/run does)']
