"""docs/architecture.md matches the code: it lists every module of the package, and its
layers are the import-linter contract that CI checks (pyproject.toml)."""

import ast
import os
import re
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PACKAGE = os.path.join(ROOT, "cornerbif")
DOC = os.path.join(ROOT, "docs", "architecture.md")


def _modules():
    for folder, _, files in os.walk(PACKAGE):
        for f in files:
            if f.endswith(".py") and f != "__init__.py":
                yield os.path.relpath(os.path.join(folder, f), PACKAGE).replace(os.sep, "/")


def listed(text: str, module: str) -> bool:
    """Whether the document names ``module`` (a path under cornerbif/): by its path, or by its
    file name in the row of its folder (``cornerbif/models/flow/`` ... ``kernel.py``)."""
    if f"cornerbif/{module}" in text or f"`{module}`" in text:
        return True
    folder, _, name = module.rpartition("/")
    for line in text.splitlines():
        if line.startswith("|") and (f"`cornerbif/{folder}/`" in line if folder
                                     else line.startswith("| `cornerbif/")):
            if f"`{name}`" in line or f" `{name}`" in line or f"{name}`" in line:
                return True
    return False


def test_every_module_is_listed_in_the_architecture():
    text = open(DOC, encoding="utf-8").read()
    missing = [m for m in sorted(_modules()) if not listed(text, m)]
    assert not missing, f"docs/architecture.md does not list: {', '.join(missing)}"


def test_a_module_missing_from_the_page_is_found():
    text = open(DOC, encoding="utf-8").read()
    assert listed(text, "models/flow/orbit.py") and listed(text, "plot_data.py")
    assert not listed(text, "models/flow/nothing_here.py")
    assert not listed(text.replace("`orbit.py`", "`orbits.py`"), "models/two_particle/orbit.py")


def test_the_layers_on_the_page_are_the_contract():
    text = open(DOC, encoding="utf-8").read()
    section = text.split("## Layers", 1)[1]
    block = re.search(r"```\n(.*?)\n```", section, re.S).group(1).splitlines()
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        contracts = tomllib.load(fh)["tool"]["importlinter"]["contracts"]
    layers = next(c for c in contracts if c["type"] == "layers")["layers"]
    assert block == layers


# outside the layers, on purpose: the package's lazy public names (imported by nothing inside
# it), and the obstacle registry, a package whose kind modules are each in a layer (import-linter
# takes no layer that contains others); both are in the cycle scan of test_import_graph.py
UNLAYERED = {"cornerbif", "cornerbif.obstacles"}


def test_every_module_is_in_a_layer():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as fh:
        contracts = tomllib.load(fh)["tool"]["importlinter"]["contracts"]
    layers = next(c for c in contracts if c["type"] == "layers")["layers"]
    layered = {m.strip() for line in layers for m in re.split(r"[|:]", line)}
    loose = []
    for folder, _, files in os.walk(PACKAGE):
        for f in files:
            path = os.path.join(folder, f)
            if not f.endswith(".py"):
                continue
            rel = os.path.relpath(path, ROOT)[:-3].replace(os.sep, ".")
            name = rel[: -len(".__init__")] if f == "__init__.py" else rel
            body = ast.parse(open(path, encoding="utf-8").read()).body
            if f == "__init__.py" and all(isinstance(n, ast.Expr) for n in body):
                continue        # a package marker: its docstring alone
            parts = name.split(".")
            if name in UNLAYERED or any(".".join(parts[:k]) in layered
                                        for k in range(1, len(parts) + 1)):
                continue
            loose.append(name)
    assert not loose, f"modules in no layer of the contract: {', '.join(sorted(loose))}"
