"""Conditional expressions of generated code as calls of one small function, for numba's compile time.

numba turns each ``a if c else b`` into three basic blocks and a variable defined twice.
Its SSA reconstruction then rewrites every block of the function once for each such
variable, so its cost grows as (conditionals) x (blocks): the declared ladder's grid kernel
of every layer holds about 400 of them and spent a third of its compile time there.
:func:`selects` rewrites, in the text of a generated module, each conditional whose two
arms are side-effect free and cannot fail (names, constants, arithmetic, a constant index
of a name) into ``_select(c, a, b)``: one statement, no blocks.  :func:`select` is marked
for LLVM to inline, where it becomes the same ``select`` instruction (or branch) as the
conditional, so the machine code computes the same values; the interpreted twin
(:mod:`phasemap.core.interpret`) runs its Python, which evaluates both arms first, with
the twin's IEEE arithmetic, so that nothing an arm computes can raise there either.
A conditional with a call in an arm (a branch function computed only where it applies)
is left as it is: it is evaluated only where its condition holds.
"""

from __future__ import annotations

import ast
import threading

from numba import njit

__all__ = ["select", "selects"]


@njit(cache=True, forceinline=True, error_model="numpy")
def select(c, a, b):
    """``a if c else b``, for generated code (see the module)."""
    return a if c else b


_NAME = "_select"
_IMPORT = f"from phasemap.core.selects import select as {_NAME}"


def _harmless(node: ast.AST) -> bool:
    """An arm that may be evaluated where its condition fails: no call (but ``_select``'s),
    no subscript but a name's at a non-negative integer constant, nothing else that acts."""
    for sub in ast.walk(node):
        if isinstance(sub, ast.Call):
            if not (isinstance(sub.func, ast.Name) and sub.func.id == _NAME and not sub.keywords):
                return False
        elif isinstance(sub, ast.Subscript):
            index = sub.slice
            if not (isinstance(sub.value, ast.Name) and isinstance(index, ast.Constant)
                    and type(index.value) is int and index.value >= 0):
                return False
        elif not isinstance(sub, (ast.Name, ast.Constant, ast.BinOp, ast.UnaryOp, ast.BoolOp,
                                  ast.Compare, ast.Attribute, ast.Load, ast.operator,
                                  ast.unaryop, ast.boolop, ast.cmpop, ast.expr_context)):
            return False
    return True


class _Rewrite(ast.NodeTransformer):
    def __init__(self):
        self.count = 0   # conditionals rewritten

    def visit_IfExp(self, node: ast.IfExp) -> ast.AST:
        self.generic_visit(node)  # the inner ones first: an arm may become a _select call
        if _harmless(node.body) and _harmless(node.orelse):
            self.count += 1
            return ast.copy_location(ast.Call(func=ast.Name(_NAME, ast.Load()),
                                              args=[node.test, node.body, node.orelse],
                                              keywords=[]), node)
        return node


#: The deepest syntax tree :func:`selects` rewrites: Python's ``ast`` walks a tree by
#: recursion, so how deep it can go depends on the stack it starts from; a module deeper
#: than this (the corner block's contract, 317 levels) is left as written, whatever the
#: caller's stack, so that a module's text never depends on where it was generated.
DEEPEST = 250


def selects(text: str) -> str:
    """``text`` (a generated module) with its harmless conditionals as ``_select`` calls;
    ``text`` itself if it has none, or if its syntax tree is deeper than :data:`DEEPEST`.

    The rewrite runs in a thread of its own, from an empty stack: its result is the same
    from whatever depth it is called.

    >>> print(selects("def f(x, r):\\n    return r[0] if x > 0 else 0.0\\n"), end="")
    from phasemap.core.selects import select as _select
    <BLANKLINE>
    def f(x, r):
        return _select(x > 0, r[0], 0.0)
    """
    out: list = []

    def work():
        try:
            out.append((_rewritten(text), None))
        except BaseException as err:   # raised again in the caller's thread
            out.append((None, err))

    worker = threading.Thread(target=work, name="phasemap-selects", daemon=True)
    worker.start()
    worker.join()
    result, err = out[0]
    if err is not None:
        raise err
    return result


def _depth(tree: ast.AST) -> int:
    """The number of levels of ``tree``, counted without recursion."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, level = stack.pop()
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _rewritten(text: str) -> str:
    try:
        tree = ast.parse(text)
        if _depth(tree) > DEEPEST:
            return text
        rewrite = _Rewrite()
        tree = rewrite.visit(tree)
        if not rewrite.count:
            return text
        at = 0 if ast.get_docstring(tree, clean=False) is None else 1   # after the docstring
        tree.body.insert(at, ast.parse(_IMPORT).body[0])
        return ast.unparse(ast.fix_missing_locations(tree)) + "\n"
    except RecursionError:   # only with a recursion limit set far below Python's default
        return text
