"""The house's plan, read from the code: the import graph, its rules, and its picture.

Every ``import`` of a phasemap module by another (at the top of a file or inside a
function: a deferred import is still an arrow) is an edge.  The parts are ranked, each
may import only from itself and the parts below it:

====  ==================  =====================================================
rank  part                what it holds
====  ==================  =====================================================
0     ``core``            the contract and the machinery that compiles it
1     ``declare``         declared systems: equations, modes, the code emitter
2     ``systems``         every system that runs, and the registry
3     ``atlas``           datasets and their netCDF files
4     ``motion``          the integrator, ``simulate``, phase curves, work-precision
5     ``maps``            one state, layers, grids, scenes and blocks
6     ``bifurcation``     the exact bifurcation set: boundaries and thresholds
7     ``plot``            figures
8     the front door      ``phasemap/*.py``: the API, the command line, the studies' kit
====  ==================  =====================================================

The rules (``tests/test_architecture.py`` holds the tree to them):

* no import runs from a lower part to a higher one;
* the module graph has no circle;
* no module imports a private name (``_x``) or a private module from another part;
* no file runs over :data:`MAX_LINES` lines unless :data:`LONG` names it and says why.

``python docs/architecture.py`` prints the parts' edges and any broken rule, and draws
``docs/architecture.png`` (the parts as bands, bottom to top, and every edge between
two parts); ARCHITECTURE.md shows it.
"""

from __future__ import annotations

import ast
import collections
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "phasemap"
PARTS = ("core", "declare", "systems", "atlas", "motion", "maps", "bifurcation", "plot",
         "front")
MAX_LINES = 800
#: Files allowed over MAX_LINES because they hold one concept each.
LONG: dict[str, str] = {
    "phasemap/bifurcation/_trace.py": "the compiled boundary tracer, one concept: its "
    "entry points, the march's named steps and the curve geometry they call are one "
    "cached compilation, and numba keys a cached function on its own file alone (a "
    "helper edited in another file would leave the entry points stale in the cache)",
    "phasemap/motion/hybrid/flow.py": "the compiled flow in full coordinates, one "
    "concept: a phase's accelerations, its events, its DOP853 steps, and the transition "
    "matrices and reactions built on them call one another as one cached compilation, and "
    "numba keys a cached function on its own file alone",
    "phasemap/motion/phase/tracer.py": "the numba pieces of one phase-curve stage and of a "
    "curve, which compile together",
}


def module_name(path: pathlib.Path) -> str:
    """``phasemap/core/model.py`` -> ``phasemap.core.model``."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def part(module: str) -> str:
    """The part a module belongs to (``front`` for the package's own files; the version
    string, which imports nothing, counts as ``core``)."""
    if module == "phasemap._version":
        return "core"
    bits = module.split(".")
    return bits[1] if len(bits) > 2 or (len(bits) == 2 and bits[1] in PARTS) else "front"


def modules() -> dict[str, pathlib.Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))
            if "__pycache__" not in p.parts}


def _typing_only(tree: ast.AST) -> set[int]:
    """The ids of the nodes under ``if TYPE_CHECKING:`` (annotations, never run)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            out.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    return out


def imports(known: dict[str, pathlib.Path]):
    """Yield ``(importer, imported module, names, line)`` for every phasemap import that
    runs (at the top of a file or in a function; not under ``if TYPE_CHECKING:``)."""
    for name, path in known.items():
        pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        tree = ast.parse(path.read_text(), str(path))
        skip = _typing_only(tree)
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] == "phasemap":
                        yield name, a.name, (), node.lineno
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    mod = ".".join(base + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                if mod.split(".")[0] != "phasemap":
                    continue
                plain = [a.name for a in node.names]
                submodules = [n for n in plain if f"{mod}.{n}" in known]
                for n in submodules:
                    yield name, f"{mod}.{n}", (), node.lineno
                rest = tuple(n for n in plain if n not in submodules)
                if rest:
                    yield name, mod, rest, node.lineno


def attribute_uses(known: dict[str, pathlib.Path]):
    """Yield ``(importer, module, attribute, line)`` for every ``alias._name`` where the
    alias is a phasemap module bound by an import."""
    for name, path in known.items():
        tree = ast.parse(path.read_text(), str(path))
        alias = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] == "phasemap" and a.asname:
                        alias[a.asname] = a.name
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for a in node.names:
                    if f"{node.module}.{a.name}" in known:
                        alias[a.asname or a.name] = f"{node.module}.{a.name}"
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in alias and node.attr.startswith("_")
                    and not node.attr.startswith("__")):
                yield name, alias[node.value.id], node.attr, node.lineno


def graph() -> dict[str, set[str]]:
    """Module -> the phasemap modules it imports."""
    known = modules()
    edges: dict[str, set[str]] = collections.defaultdict(set)
    for a, b, _, _ in imports(known):
        if a != b:
            edges[a].add(b)
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in list(edges):
        if v not in index:
            visit(v)
    return out


def _private(module: str) -> bool:
    return any(bit.startswith("_") and bit not in ("__init__", "_version")
               for bit in module.split(".")[1:])


def violations() -> list[str]:
    """Every broken rule, one line each (empty when the house is in order)."""
    known = modules()
    out = []
    rank = {p: i for i, p in enumerate(PARTS)}
    for a, b, names, line in imports(known):
        pa, pb = part(a), part(b)
        where = f"{known[a].relative_to(ROOT)}:{line}"
        if b == "phasemap" and pa != "front":
            out.append(f"{where}: {a} imports the package's front door")
            continue
        if rank[pb] > rank[pa]:
            out.append(f"{where}: {a} ({pa}) imports {b} ({pb}), a higher part")
        if pa != pb:
            if _private(b):
                out.append(f"{where}: {a} imports the private module {b} of {pb}")
            for n in names:
                if n.startswith("_") and not n.startswith("__"):
                    out.append(f"{where}: {a} imports the private name {b}.{n} of {pb}")
    for a, b, attr, line in attribute_uses(known):
        if part(a) != part(b):
            out.append(f"{known[a].relative_to(ROOT)}:{line}: {a} uses the private name "
                       f"{b}.{attr} of {part(b)}")
    for comp in cycles(graph()):
        out.append("a circle: " + " -> ".join(comp))
    for name, path in known.items():
        n = len(path.read_text().splitlines())
        rel = str(path.relative_to(ROOT))
        if n > MAX_LINES and rel not in LONG:
            out.append(f"{rel}: {n} lines (over {MAX_LINES}, and not in LONG)")
    return out


def part_edges() -> collections.Counter:
    """(importing part, imported part) -> number of module edges."""
    c = collections.Counter()
    for a, targets in graph().items():
        for b in targets:
            if part(a) != part(b):
                c[part(a), part(b)] += 1
    return c


def draw(path: pathlib.Path) -> None:
    """The parts as bands from ``core`` (bottom) to the front door (top), each with
    its modules, and an arrow per pair of parts that import, labelled with the count."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    known = modules()
    members = collections.defaultdict(list)
    for m in known:
        members[part(m)].append(m.split(".", 2)[-1] if part(m) != "front" else
                                (m.split(".", 1)[-1] if "." in m else "__init__"))
    fig, ax = plt.subplots(figsize=(10.4, 10.5))
    ax.set_xlim(0, 12.4)
    ax.set_ylim(-0.5, len(PARTS) - 0.3)
    ax.axis("off")
    xs = {}
    for i, p in enumerate(PARTS):
        x = 1.2 + 0.9 * (i % 3)
        xs[p] = x
        ax.add_patch(plt.Rectangle((0.05, i - 0.42), 12.3, 0.84, color="0.93", zorder=0))
        ax.text(x, i, p, ha="center", va="center", fontsize=11, weight="bold",
                bbox=dict(boxstyle="round", fc="white", ec="0.3"), zorder=3)
        names = sorted({n.split(".")[0] for n in members[p]} - {p, "__init__"})
        ax.text(4.1, i, ", ".join(names), ha="left", va="center", fontsize=7.5, wrap=True,
                color="0.25")
    rank = {p: i for i, p in enumerate(PARTS)}
    for (a, b), n in sorted(part_edges().items()):
        ya, yb = rank[a], rank[b]
        ax.annotate("", xy=(xs[b], yb + 0.22), xytext=(xs[a], ya - 0.22),
                    arrowprops=dict(arrowstyle="->", lw=0.5 + 0.15 * min(n, 12),
                                    color="tab:red" if yb > ya else "0.45",
                                    connectionstyle="arc3,rad=0.12"), zorder=2)
    ax.set_title("phasemap: its parts, lowest at the bottom; an arrow is an import "
                 "(width: how many modules)", fontsize=10)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def main() -> int:
    for (a, b), n in sorted(part_edges().items(), key=lambda kv: (PARTS.index(kv[0][0]),
                                                                  PARTS.index(kv[0][1]))):
        print(f"{a:12s} -> {b:12s} {n:3d}")
    bad = violations()
    for line in bad:
        print(line)
    draw(ROOT / "docs" / "architecture.png")
    print("drew docs/architecture.png")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
