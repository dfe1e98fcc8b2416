"""core: the contract every system gives the rest, and the machinery that compiles it.

``model`` (the contract: ``Model``, ``Candidate``, ``Dynamics``), ``events`` (the events and
fates a motion can meet), ``numerics`` (tolerances, statuses, branch-free helpers),
``codegen`` (the per-point and per-grid kernels generated from a model's branch
functions), ``compile`` (per-model engine kernels from templates), ``cache`` (the kernel
cache and its bound), ``args`` (the argument checks every entry point shares),
``progress`` (bars and activity lines), ``interrupts`` (a signal during a compile is
raised where Python can raise it), ``compiletime`` (how long numba has compiled) and
``fasttyping`` (numba types each scalar operation once per process).
Nothing here imports from another part of phasemap.
"""
