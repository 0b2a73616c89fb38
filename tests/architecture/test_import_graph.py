"""The package's imports form no cycle, counting what import statements alone do not show
(docs/architecture.md, "Layers").

Every import statement is counted, those deferred into functions included (read by grimp,
which import-linter uses; an import under ``if TYPE_CHECKING:`` never runs and is left out, as
the layers contract in pyproject.toml leaves it out).  To them are added the loads the
registries make by name (``importlib``): ``registry`` loads each model module,
``obstacles`` each obstacle kind, ``figures`` each figure kind.  The graph has no strongly
connected set of more than one module, and the scan is shown to find a cycle when one is
planted.
"""

import ast
import importlib
import os
import re

import grimp
import pytest

from cornerbif import figures, obstacles, registry


def _graph():
    g = grimp.build_graph("cornerbif", exclude_type_checking_imports=True, cache_dir=None)
    edges = {m: set(g.find_modules_directly_imported_by(m)) - {m} for m in g.modules}
    for loader, paths in (("cornerbif.registry", registry.MODEL_MODULES),
                          ("cornerbif.obstacles", obstacles.OBSTACLE_MODULES),
                          ("cornerbif.figures", figures.FIGURE_MODULES)):
        for path in paths:
            importlib.import_module(path)          # each named module exists
            edges[loader].add(path)
    return edges


def cycles(edges: dict) -> list:
    """The strongly connected sets of more than one module (Tarjan's algorithm, iterative)."""
    index, low, on, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in edges:
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
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
    return out


def test_no_import_cycle_counting_deferred_imports_and_registry_loads():
    found = cycles(_graph())
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


@pytest.mark.parametrize("planted", [
    ("cornerbif.model", "cornerbif.config"),                 # a declaration importing up
    ("cornerbif.plot_base", "cornerbif.figures"),            # a figure helper reaching a kind
])
def test_the_scan_finds_a_planted_cycle(planted):
    edges = _graph()
    edges[planted[0]].add(planted[1])
    found = cycles(edges)
    assert any(planted[0] in c and planted[1] in c for c in found), found


# --- deferred imports: each names its reason ------------------------------------------------
# what a module may defer: a library that is heavy to load (start-up time: ``cornerbif
# validate`` loads none of them) or optional; a module of the package that loads one of them
HEAVY = {"numba", "llvmlite", "h5py", "matplotlib", "scipy", "dask", "distributed", "PIL",
         "isal", "xarray"}
REASON = re.compile(r"#.*(start-up|optional)")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _module_files():
    pkg = os.path.join(ROOT, "cornerbif")
    for folder, _, files in os.walk(pkg):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                rel = os.path.relpath(path, ROOT).replace(os.sep, "/")
                name = rel[:-3].replace("/", ".")
                yield (name[:-9] if name.endswith(".__init__") else name), rel, path


def _absolute(node, name, rel):
    if node.level == 0:
        return node.module
    pkg = name.split(".") if rel.endswith("__init__.py") else name.split(".")[:-1]
    base = pkg[:len(pkg) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def heavy_modules() -> set:
    """The package's modules whose import (their top-level imports, transitively, and their
    packages') loads a heavy library."""
    tops = {}
    for name, rel, path in _module_files():
        deps = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
        for n in ast.parse(open(path, encoding="utf-8").read()).body:
            if isinstance(n, ast.Import):
                deps |= {a.name for a in n.names}
            elif isinstance(n, ast.ImportFrom):
                b = _absolute(n, name, rel)
                deps |= {b} | {f"{b}.{a.name}" for a in n.names}
        tops[name] = deps
    heavy, grown = set(), True
    while grown:
        grown = False
        for m, deps in tops.items():
            if m not in heavy and any(d.split(".")[0] in HEAVY or d in heavy for d in deps):
                heavy.add(m)
                grown = True
    return heavy


def deferred_imports():
    """(module file, line, imported module, its comment) of every import inside a function."""
    for name, rel, path in _module_files():
        src = open(path, encoding="utf-8").read()
        lines = src.splitlines()
        for fn in ast.walk(ast.parse(src)):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for n in ast.walk(fn):
                if isinstance(n, ast.Import):
                    targets = [a.name for a in n.names]
                elif isinstance(n, ast.ImportFrom):
                    b = _absolute(n, name, rel)
                    targets = [b] + [f"{b}.{a.name}" for a in n.names]
                else:
                    continue
                said, i = lines[n.lineno - 1], n.lineno - 2
                while i >= 0 and re.match(r"\s*(#|from |import )", lines[i]):
                    said += " " + lines[i]      # the block of imports and comments above
                    i -= 1
                yield rel, n.lineno, targets, said


def test_each_deferred_import_is_heavy_or_optional_and_says_so():
    """An import inside a function is there for start-up time (the module loads numba, h5py,
    matplotlib...: ``cornerbif validate`` and ``--help`` load none of them) or because the
    library is optional, and its line, or the comment above it, says which.  A light module
    is imported at the top."""
    heavy = heavy_modules()
    wrong = []
    for rel, line, targets, said in deferred_imports():
        loads = any(t.split(".")[0] in HEAVY or t in heavy for t in targets)
        if not REASON.search(said):
            wrong.append(f"{rel}:{line}: {targets[0]}: no reason given (start-up or optional)")
            continue
        if rel in ("cornerbif/__init__.py", "cornerbif/_entry.py"):
            continue    # lazy by design: the package's names; the entry's signal handlers first
        if not loads:
            wrong.append(f"{rel}:{line}: {targets[0]} is light: import it at the top")
    assert not wrong, "\n".join(wrong)
