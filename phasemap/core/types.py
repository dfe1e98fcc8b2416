"""The numba types the compiled drivers share, defined once.

The grid evaluator (:mod:`phasemap.core.codegen`), the integrator
(:mod:`phasemap.motion.integrate`) and the bifurcation tracer
(:mod:`phasemap.bifurcation._trace`) declare their kernels' signatures with these:
C-contiguous arrays of float64, int64, int8 and boolean by dimension.
"""

from __future__ import annotations

from numba import types

F1 = types.Array(types.float64, 1, "C")
F2 = types.Array(types.float64, 2, "C")
F3 = types.Array(types.float64, 3, "C")
I1 = types.Array(types.int64, 1, "C")
I2 = types.Array(types.int64, 2, "C")
#: int8 statuses and classes, 2-D and 3-D.
S2 = types.Array(types.int8, 2, "C")
S3 = types.Array(types.int8, 3, "C")
B1 = types.Array(types.boolean, 1, "C")
B2 = types.Array(types.boolean, 2, "C")
