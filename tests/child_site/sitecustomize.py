"""Python processes the test suite starts generate machine code as the suite does.

tests/conftest.py has numba's code generator (instruction selection, register
allocation) run at -O0 for the suite's kernels, which halves their compile, and puts
this folder first on ``PYTHONPATH``, which every child process inherits (the CLI, the
studies, the processes that race for a cache, the progress bar's terminal): Python imports
this module at start-up, and it applies the same setting when the child first imports
numba's code generator (not before: a child that never compiles never imports numba for
it).  A child compiled its kernels at numba's setting before, into the same cache, at
twice the CPU time.  ``PHASEMAP_TEST_CODEGEN=default`` turns both off.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import os
import sys


def at_o0(codegen) -> bool:
    """numba's ``JITCPUCodegen`` of module ``codegen`` generating machine code at -O0
    (its IR optimisation stays at ``NUMBA_OPT``); False where this numba has no hook."""
    customize = getattr(codegen.JITCPUCodegen, "_customize_tm_options", None)
    if customize is None:
        return False
    if getattr(customize, "phasemap_o0", False):
        return True

    def customize_at_o0(self, options):
        customize(self, options)
        options["opt"] = 0

    customize_at_o0.phasemap_o0 = True
    codegen.JITCPUCodegen._customize_tm_options = customize_at_o0
    return True


class _WhenImported(importlib.abc.MetaPathFinder):
    """Applies :func:`at_o0` as ``numba.core.codegen`` is first imported."""

    def find_spec(self, name, path, target=None):
        if name != "numba.core.codegen":
            return None
        sys.meta_path.remove(self)
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            at_o0(module)

        spec.loader.exec_module = exec_module
        return spec


if os.environ.get("PHASEMAP_TEST_CODEGEN") != "default" and "numba" not in sys.modules:
    sys.meta_path.insert(0, _WhenImported())
