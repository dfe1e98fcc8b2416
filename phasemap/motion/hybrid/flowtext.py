"""A declaration's full-coordinate functions rewritten for machine code: the text of the
module that :mod:`phasemap.motion.hybrid.flow` compiles.

:mod:`phasemap.declare.full` keeps sympy's ``lambdify`` functions of a declaration's free
system: ``pieces(q..., u..., params..., t)`` returns a list, one argument per coordinate.
A compiled kernel that serves every declaration cannot call those: it cannot unpack an
array into arguments, and a list is built on the heap.  This module rewrites each one
(with Python's :mod:`ast`, the printed expressions untouched) into a function of one
signature for all of them, ``f(out, y, p, t)``: ``y`` the state (coordinates, then
rates), ``p`` the parameters, the results written into ``out``.

* ``pieces_into``: ``[M (n*n), h (n), g (k), J (3k*n), bias (3k), mu (k)]``;
* ``domain_into``: the declared domain conditions (``n_domain``);
* ``surface_into``: each contact surface's tangential velocity, then its rate (2k; zeros
  where every surface is at rest);
* ``kinetic_into``: each contact's slip coefficient at its sliding speed, which ``out``
  holds on entry (left as it is where the declaration slips with the static one).

Each is plain Python over :mod:`math`: numba compiles it on its own, for the signature
:data:`phasemap.motion.hybrid.flow.FUNCTION`, and the kernels call its machine code at its
address; the same text run by Python is its interpreted twin.
"""

from __future__ import annotations

import ast

#: the functions, in the order the kernels take them
NAMES = ("pieces_into", "surface_into", "kinetic_into", "domain_into")
#: bumped when the rewritten module's layout changes
LAYOUT = 2


def text(source: str, n: int, k: int, n_params: int) -> str:
    """The rewritten module of a generated mechanics module's ``source`` (``n``
    coordinates, ``k`` contacts, ``n_params`` parameters)."""
    tree = ast.parse(source)
    fns = {f.name: f for f in tree.body if isinstance(f, ast.FunctionDef)}
    parts = [_rewrite(fns["pieces"], _args(2 * n, n_params, True))]
    parts.append(_rewrite(fns["domain"], _args(n, n_params, False), "domain_into"))
    if "surface" in fns:
        parts.append(_rewrite(fns["surface"], _args(0, n_params, True), "surface_into"))
    else:
        parts.append(_zeros("surface_into", 2 * k))
    kinetic = [fns[f"kinetic_{i}"] for i in range(k) if f"kinetic_{i}" in fns]
    parts.append(_kinetic(kinetic, _args(2 * n, n_params, False)) if len(kinetic) == k and k else _unchanged())
    body = "\n\n".join(ast.unparse(ast.fix_missing_locations(p)) for p in parts)
    return ("import math\nfrom math import *  # noqa\n\n" + body + "\n")


def _args(n_y: int, n_p: int, timed: bool):
    """Where each argument of a generated function comes from: ``("_y", i)``,
    ``("_p", i)`` or ``("_t", None)``."""
    return [("_y", i) for i in range(n_y)] + [("_p", i) for i in range(n_p)] + (
        [("_t", None)] if timed else [])


def _bind(names, where):
    """``name = _y[i]`` ... for each argument."""
    out = []
    for name, (arr, i) in zip(names, where):
        value = ast.Name(arr, ast.Load()) if i is None else ast.Subscript(
            ast.Name(arr, ast.Load()), ast.Constant(i), ast.Load())
        out.append(ast.Assign([ast.Name(name, ast.Store())], value))
    return out


def _store(i, value):
    return ast.Assign([ast.Subscript(ast.Name("_out", ast.Load()), ast.Constant(i),
                                     ast.Store())], value)


def _signature(name):
    return ast.FunctionDef(
        name=name, args=ast.arguments(
            posonlyargs=[], args=[ast.arg(a) for a in ("_out", "_y", "_p", "_t")],
            kwonlyargs=[], kw_defaults=[], defaults=[]), body=[], decorator_list=[])


def _rewrite(fn: ast.FunctionDef, where, name: str = "pieces_into") -> ast.FunctionDef:
    """``fn`` (its body: assignments, then ``return [e0, e1, ...]``) writing ``e_i`` into
    ``_out[i]``."""
    names = [a.arg for a in fn.args.args]
    if len(names) != len(where):
        raise ValueError(f"generated {fn.name}: {len(names)} arguments, {len(where)} expected")
    *stmts, ret = fn.body
    if not isinstance(ret, ast.Return) or not isinstance(ret.value, (ast.List, ast.Tuple)):
        raise ValueError(f"generated {fn.name} does not return a list")
    out = _signature(name)
    out.body = _bind(names, where) + stmts + [_store(i, e) for i, e in enumerate(
        ret.value.elts)]
    return out


def _zeros(name: str, size: int) -> ast.FunctionDef:
    out = _signature(name)
    out.body = [_store(i, ast.Constant(0.0)) for i in range(size)] or [ast.Pass()]
    return out


def _unchanged() -> ast.FunctionDef:
    out = _signature("kinetic_into")
    out.body = [ast.Pass()]
    return out


def _kinetic(fns, where) -> ast.FunctionDef:
    """One function for every contact's ``kinetic_i(q..., u..., params..., t, speed)``: the
    speed read from ``_out[i]``, the coefficient written there."""
    out = _signature("kinetic_into")
    body = []
    for i, fn in enumerate(fns):
        names = [a.arg for a in fn.args.args]
        *stmts, ret = fn.body
        if len(names) != len(where) + 2:       # q, u and the parameters, then t, speed
            raise ValueError(f"generated {fn.name}: {len(names)} arguments, "
                             f"{len(where) + 2} expected")
        body += _bind(names[:-2], where) + [
            ast.Assign([ast.Name(names[-2], ast.Store())], ast.Name("_t", ast.Load())),
            ast.Assign([ast.Name(names[-1], ast.Store())], ast.Subscript(
                ast.Name("_out", ast.Load()), ast.Constant(i), ast.Load()))]
        body += stmts + [_store(i, ret.value)]
    out.body = body
    return out
