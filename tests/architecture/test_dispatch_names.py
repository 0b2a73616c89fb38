"""No code outside a model's folder or an obstacle's module decides by its name or its code
(docs/architecture.md, "Where each thing lives").

A model is asked what it can do through its declaration (``cornerbif.model.Model``) and an
obstacle kind through its (``cornerbif.model.Obstacle``); the registries
(``cornerbif/registry.py``) are the only place that lists them.  This scan reads every module
of the package (its syntax tree, not its text, so messages and docstrings may name a model)
and fails on:

* a registered model's, obstacle's or figure kind's name compared with, or listed in a
  membership test against, an expression that holds one (``scene.obstacle``, ``w.model``,
  ``kind``, ``spec.name``, ``cfg.get("kind")``), matched in a ``match`` statement, or looked
  up in a registry or a table of them, outside ``models/<name>/``, ``obstacles/<name>.py`` or
  ``figures/<name>.py``;
* a dict written with two or more of one registry's names as its keys (a dispatch table),
  outside the owners of those names;
* an obstacle code (``SINE``, ``RECTIFIED_SINE``, ``TRIANGLE``, ``PROFILE``, or the packed
  slot ``OBSTACLE``) compared outside ``obstacles/dispatch.py``, the one switch over codes;
* a packed row's width compared with ``NPARAM`` outside ``models/flow/slots.py``
  (``wide_rows``).

The scan is shown to catch each kind of dispatch on planted snippets
(``test_the_scan_catches_dispatch``).
"""

import ast
import os

import pytest

from cornerbif import figures as figure_kinds
from cornerbif import obstacles as obstacle_kinds
from cornerbif import registry

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PKG = os.path.join(ROOT, "cornerbif")
CODE_NAMES = {"SINE", "RECTIFIED_SINE", "TRIANGLE", "PROFILE", "OBSTACLE"}


def _modules():
    for folder, _, files in os.walk(PKG):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                yield os.path.relpath(path, ROOT).replace(os.sep, "/"), path


def _strings(node):
    """The string constants a compared expression is or lists."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [e.value for e in node.elts if isinstance(e, ast.Constant)
                and isinstance(e.value, str)]
    return []


def _names(node):
    """The bare and dotted names an expression mentions (``P.SINE`` -> SINE)."""
    out = set()
    for n in ast.walk(node):
        if isinstance(n, ast.Name):
            out.add(n.id)
        elif isinstance(n, ast.Attribute):
            out.add(n.attr)
    return out


HOLDERS = ("obstacle", "model", "kind", "registry", "role", "figure")


def _carries(node) -> bool:
    """Whether an expression holds a model, obstacle or figure kind (by its names:
    ``scene.obstacle``, ``w.model``, ``OBSTACLES``, ``registry.get``, ``kind``, ``spec.name``,
    or a key it reads: ``cfg.get("kind")``): a string compared with it is a dispatch, a string
    compared with a table's keys is not (a cam piece's ``sine``)."""
    if any(any(w in n.lower() for w in HOLDERS) for n in _names(node)):
        return True
    for n in ast.walk(node):
        if isinstance(n, ast.Attribute) and n.attr == "name":
            return True
        if (isinstance(n, ast.Call) and n.args and isinstance(n.args[0], ast.Constant)
                and n.args[0].value in HOLDERS):
            return True
    return False


def _registries():
    return {"model": set(registry.names()), "obstacle": set(obstacle_kinds.registered()),
            "figure": set(figure_kinds.registered())}


def dispatch_in(source: str, owner_of) -> list:
    """(line, what) of every dispatch on a name or code in ``source``; ``owner_of(name)`` says
    whether the module may decide by ``name`` (its own model or obstacle)."""
    regs = _registries()
    every = set().union(*regs.values())
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            named = [v for s in sides for v in _strings(s)
                     if v in every and not owner_of(v)
                     and any(_carries(o) for o in sides if o is not s)]
            if named:
                found.append((node.lineno, f"compares with the name {named[0]!r}"))
            mentioned = set().union(*(_names(s) for s in sides))
            codes = mentioned & CODE_NAMES
            if codes and not owner_of("<codes>"):
                found.append((node.lineno, f"compares obstacle codes ({', '.join(sorted(codes))})"))
            if "NPARAM" in mentioned and not owner_of("<width>"):
                found.append((node.lineno, "compares a packed row's width with NPARAM"))
        elif isinstance(node, (ast.Subscript, ast.Call)):
            keys, holder = ((node.slice, node.value) if isinstance(node, ast.Subscript)
                            else (node.args[0] if node.args else None, node.func))
            named = [v for v in _strings(keys) if v in every
                     and not owner_of(v)] if keys is not None and _carries(holder) else []
            if named:
                found.append((node.lineno, f"looks up the name {named[0]!r}"))
        elif isinstance(node, ast.match_case):
            named = [p.value.value for p in ast.walk(node.pattern)
                     if isinstance(p, ast.MatchValue) and isinstance(p.value, ast.Constant)
                     and p.value.value in every and not owner_of(p.value.value)]
            if named:
                found.append((node.pattern.lineno, f"matches the name {named[0]!r}"))
        elif isinstance(node, ast.Dict):
            keys = [k.value for k in node.keys if isinstance(k, ast.Constant)]
            for names in regs.values():
                table = [k for k in keys if k in names and not owner_of(k)]
                if len(table) >= 2:
                    found.append((node.lineno, f"a table keyed by the names {table[0]!r}, "
                                  f"{table[1]!r}"))
    return found


def _owner(rel):
    """What the module ``rel`` (a path under the repository) may decide by."""
    parts = rel.split("/")

    def owns(name):
        if rel in ("cornerbif/registry.py", "cornerbif/obstacles/__init__.py",
                   "cornerbif/figures/__init__.py"):
            return True
        if name == "<codes>":
            return rel == "cornerbif/obstacles/dispatch.py"
        if name == "<width>":
            return rel == "cornerbif/models/flow/slots.py"
        if parts[1:3] == ["models", name]:
            return True
        return parts[1] in ("obstacles", "figures") and parts[-1] == f"{name}.py"
    return owns


def test_no_module_dispatches_on_a_name_or_a_code_it_does_not_own():
    found = []
    for rel, path in _modules():
        with open(path, encoding="utf-8") as fh:
            source = fh.read()
        found += [f"{rel}:{line}: {what}" for line, what in dispatch_in(source, _owner(rel))]
    assert not found, "dispatch on a name or code outside its owner:\n" + "\n".join(found)


@pytest.mark.parametrize("snippet,what", [
    ('if scene.obstacle == "profile":\n    pass\n', "compares with the name 'profile'"),
    ('ok = model in ("map2d", "flow")\n', "compares with the name 'map2d'"),
    ('x = OBSTACLES["triangle"]\n', "looks up the name 'triangle'"),
    ('m = registry.get("two_particle")\n', "looks up the name 'two_particle'"),
    ("if p[P.OBSTACLE] == P.PROFILE:\n    pass\n", "compares obstacle codes (OBSTACLE, PROFILE)"),
    ("wide = params.shape[1] > P.NPARAM\n", "compares a packed row's width with NPARAM"),
    ('if spec.name == "map2d":\n    pass\n', "compares with the name 'map2d'"),
    ('ok = cfg.get("kind", "diagram") == "diagram"\n', "compares with the name 'diagram'"),
    ('match m:\n    case "two_particle":\n        pass\n', "matches the name 'two_particle'"),
    ('draw = {"regions": f, "orbit": g}\n', "a table keyed by the names 'regions', 'orbit'"),
])
def test_the_scan_catches_dispatch(snippet, what):
    """Each kind of dispatch, planted in a module that owns nothing, is found; in its
    owner's module it is allowed."""
    found = dispatch_in(snippet, _owner("cornerbif/plot.py"))
    assert [w for _, w in found] == [what]
    if "NPARAM" in what:
        assert dispatch_in(snippet, _owner("cornerbif/models/flow/slots.py")) == []
    elif "codes" in what:
        assert dispatch_in(snippet, _owner("cornerbif/obstacles/dispatch.py")) == []
    else:
        name = what.split("'")[1]
        own = (f"cornerbif/obstacles/{name}.py" if name in obstacle_kinds.registered()
               else f"cornerbif/figures/{name}.py" if name in figure_kinds.registered()
               else f"cornerbif/models/{name}/model.py")
        assert [w for _, w in dispatch_in(snippet, _owner(own)) if name in w] == []
