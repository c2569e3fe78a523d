"""The package's layout: data flows one way through the folders, and no module imports in a cycle.

Every module's imports are read with :mod:`ast` (module-level and inside functions alike). Each
top-level folder of the package is one step of the pipeline, in the order of :data:`LAYERS`; a
module may import from its own step and from earlier ones, never from a later one. The package
root holds only its face (``__init__``: the version) and the ``python -m`` entry.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pavement_mcmc"

#: the steps of the pipeline, in the order the data flows (see docs/ARCHITECTURE.md)
LAYERS = (
    "data",  # CSV + TOML -> Measurements, CaseConfig
    "synthetic",  # independent twin simulator: sees only the data format (no inverse crime)
    "solver",  # grid, coefficients -> nodal temperatures; adjoint
    "parameters",  # parameters and priors
    "physics",  # the model: parameters -> coefficients -> sensor predictions; extensions
    "posterior",  # priors + likelihood, problem assembly, MAP / Laplace
    "samplers",  # chains of the posterior
    "storage",  # chains on disk, resumable
    "diagnostics",  # pure functions on chains
    "runs",  # fit / resume / read back a run folder
    "batch",  # many fits on Dask: windows of a record, many sites
    "analysis",  # sensitivity, urban comparison
    "criticism",  # where the model fails, what is missing (numbers only)
    "plotting",  # figures (the only matplotlib user)
    "report",  # HTML
    "cli",  # the command line
)
ROOT_MODULES = {"__init__", "__main__"}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _is_package(path: Path) -> bool:
    return path.name == "__init__.py"


def _imports(path: Path) -> set[str]:
    """Fully qualified names of the package's modules (or packages) imported by ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    name = _module_name(path)
    pkg = name if _is_package(path) else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.split(".")[0] == "pavement_mcmc")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "pavement_mcmc":
                continue
            for alias in node.names:  # `from pkg import module` imports the module
                sub = f"{mod}.{alias.name}"
                out.add(sub if _exists(sub) else mod)
    return out


def _exists(module: str) -> bool:
    p = PACKAGE.parent.joinpath(*module.split("."))
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def _graph() -> dict[str, set[str]]:
    return {_module_name(p): _imports(p) for p in sorted(PACKAGE.rglob("*.py"))}


def _layer(module: str) -> int | None:
    parts = module.split(".")
    if len(parts) == 1:
        return None  # the package face
    top = parts[1]
    if top in ROOT_MODULES:
        return len(LAYERS) if top == "__main__" else -1
    return LAYERS.index(top)


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    out = []
    for mod, deps in graph.items():
        mine = _layer(mod)
        for dep in sorted(deps):
            theirs = _layer(dep)
            if theirs is None:  # `from pavement_mcmc import __version__`: the face, always allowed
                continue
            if mine is not None and theirs > mine:
                out.append(f"{mod} ({LAYERS[mine] if mine >= 0 else 'root'}) imports {dep} "
                           f"({LAYERS[theirs] if theirs < len(LAYERS) else '__main__'})")
    return out


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, comps = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
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
                comps.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return comps


def test_every_folder_is_a_declared_step():
    folders = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert folders == set(LAYERS), folders ^ set(LAYERS)
    loose = {p.stem for p in PACKAGE.glob("*.py")}
    assert loose <= ROOT_MODULES, f"modules at the package root: {sorted(loose - ROOT_MODULES)}"


def test_data_flows_one_way():
    bad = layer_violations(_graph())
    assert not bad, "imports against the flow:\n" + "\n".join(bad)


def test_no_import_cycles():
    found = cycles(_graph())
    assert not found, f"import cycles: {found}"


def test_package_face_imports_nothing_of_the_package():
    assert not _imports(PACKAGE / "__init__.py")


def test_no_module_over_the_size_guide():
    big = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
           if (n := len(p.read_text(encoding="utf-8").splitlines())) > 420}
    assert not big, f"modules over ~400 lines: {big}"


# the checker itself must catch what it is for
@pytest.mark.parametrize(
    ("graph", "n_bad"),
    [
        ({"pavement_mcmc.plotting.x": {"pavement_mcmc.criticism.y"}}, 0),
        ({"pavement_mcmc.criticism.y": {"pavement_mcmc.plotting.x"}}, 1),
        ({"pavement_mcmc.synthetic.s": {"pavement_mcmc.solver.forward"}}, 1),  # inverse crime
        ({"pavement_mcmc.physics.m": {"pavement_mcmc.posterior.p"}}, 1),
        ({"pavement_mcmc.cli.c": {"pavement_mcmc"}}, 0),
    ],
)
def test_layer_checker_on_toy_graphs(graph, n_bad):
    assert len(layer_violations(graph)) == n_bad


def test_cycle_checker_on_toy_graphs():
    g = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(g) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []
