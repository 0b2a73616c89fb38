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

import importlib

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
