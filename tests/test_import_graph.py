"""The package's modules import each other without a circle (docs/architecture.md): the graph of
module-level imports between terrasph's own modules, read from the source with ``ast`` (imports
inside functions and under ``if TYPE_CHECKING:`` run later or never, so they are not edges), is
acyclic, and so is the graph of every import, deferred ones too. A circle makes the import order
matter and hides which module is the base of which."""

from __future__ import annotations

import ast
import pathlib

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "python" / "terrasph"


def _module_name(path: pathlib.Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _module_level_imports(tree: ast.Module, module: str, is_package: bool) -> set[str]:
    """The modules a module imports when it is imported: its top-level statements (and those in
    top-level try/if blocks other than ``if TYPE_CHECKING:``), relative imports resolved."""
    found: set[str] = set()
    statements = list(tree.body)
    while statements:
        node = statements.pop()
        if isinstance(node, ast.If):
            if not _is_type_checking(node.test):
                statements.extend(node.body)
            statements.extend(node.orelse)
        elif isinstance(node, ast.Try):
            statements.extend([*node.body, *node.orelse, *node.finalbody, *(s for h in node.handlers for s in h.body)])
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")[: len(module.split(".")) - node.level + (1 if is_package else 0)]
                source = ".".join([*base, *([node.module] if node.module else [])])
            else:
                source = node.module or ""
            found.add(source)
            found.update(f"{source}.{alias.name}" for alias in node.names)  # `from package import module`
    return found


def _every_import(tree: ast.Module) -> set[str]:
    """The absolute imports anywhere in a module: in functions and under ``if TYPE_CHECKING:`` too."""
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def import_graph(deferred: bool = False) -> dict[str, set[str]]:
    """Each module of the package and the package modules it imports at module level (with
    `deferred`, anywhere). Importing ``a.b.c`` runs ``a`` and ``a.b`` first, so an edge to a module
    is an edge to its packages too."""
    paths = {_module_name(path): path for path in PACKAGE.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for module, path in paths.items():
        tree = ast.parse(path.read_text())
        imported = _every_import(tree) if deferred else _module_level_imports(tree, module, path.name == "__init__.py")
        edges = set()
        for name in imported:
            parts = name.split(".")
            edges.update(".".join(parts[:k]) for k in range(1, len(parts) + 1) if ".".join(parts[:k]) in paths)
        edges.discard(module)
        # a module's own packages are run before it: not an edge of its own making
        edges -= {".".join(module.split(".")[:k]) for k in range(1, module.count(".") + 1)}
        graph[module] = edges
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A circle of the graph as the list of its modules (first repeated last), or None."""
    state: dict[str, int] = {}  # 1: on the path, 2: done
    path: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = 1
        path.append(module)
        for other in sorted(graph.get(module, ())):
            if state.get(other) == 1:
                return [*path[path.index(other):], other]
            if other not in state and (cycle := visit(other)):
                return cycle
        state[module] = 2
        path.pop()
        return None

    for module in sorted(graph):
        if module not in state and (cycle := visit(module)):
            return cycle
    return None


def test_the_finder_sees_a_circle_and_a_package_edge() -> None:
    """The check itself: a circle through three modules is found; a chain is not."""
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    tree = ast.parse("from terrasph.x import y\nif TYPE_CHECKING:\n    import terrasph.z\ndef f():\n    import terrasph.w")
    assert _module_level_imports(tree, "terrasph.v", False) == {"terrasph.x", "terrasph.x.y"}


def test_the_package_imports_no_circle_even_in_deferred_imports() -> None:
    """An import inside a function can hide a circle that a module-level one would show: there is
    none of those either, anywhere in the package."""
    graph = import_graph(deferred=True)
    assert {"terrasph.terrain.interface", "terrasph.mjcf.model", "terrasph.scenes.leg_wheel"} <= set(graph)
    cycle = find_cycle(graph)
    assert cycle is None, "import circle through deferred imports: " + " -> ".join(cycle or [])


def test_the_package_has_no_import_circle() -> None:
    graph = import_graph()
    assert {"terrasph.terrain.sph_coupling", "terrasph.terrain.interface", "terrasph.robots.run"} <= set(graph)
    cycle = find_cycle(graph)
    assert cycle is None, "import circle: " + " -> ".join(cycle or [])


def test_the_architecture_map_names_every_module_and_core_file() -> None:
    """docs/architecture.md is the map of the code: every Python module of the package and every
    C++ source of the core, plugin and bindings is named in it (a module added without its place on
    the map fails here)."""
    root = pathlib.Path(__file__).resolve().parents[1]
    text = (root / "docs" / "architecture.md").read_text()
    package = root / "python" / "terrasph"
    modules = [p for p in package.rglob("*.py") if p.name != "__init__.py"]
    sources = [p for d in ("cpp/src", "cpp/plugin", "cpp/include/terrasph") for p in (root / d).glob("*.[ch]pp")]
    missing = [str(p.relative_to(root)) for p in [*modules, *sources] if p.name not in text and p.stem not in text]
    assert not missing, f"not on docs/architecture.md's map: {missing}"


def test_the_terrain_wing_stands_below_the_robots_and_the_scenes() -> None:
    """The layers of docs/architecture.md's terrain wing: the terrains (terrain/) and the MuJoCo
    plumbing (mjcf/) import nothing of robots/ or scenes/, and robots/ nothing of scenes/, deferred
    imports included: a scene uses a terrain, never the other way round."""
    graph = import_graph(deferred=True)
    above_the_wing = ("terrasph.robots", "terrasph.scenes")
    below = {"terrasph.terrain": above_the_wing, "terrasph.mjcf": above_the_wing, "terrasph.robots": ("terrasph.scenes",)}
    upward = sorted(f"{module} -> {other}" for module, edges in graph.items() for layer, above in below.items()
                    if module.startswith(layer) for other in edges if other.startswith(above))
    assert not upward, f"imports against the layers: {upward}"


def test_the_plain_scenes_and_the_rft_laws_load_without_mujoco() -> None:
    """terrasph.terrain's interface is imported on first use: the scene registry (whose SPH scenes
    use the planar RFT laws, terrasph.terrain.rft) loads no MuJoCo, and asking for attach does."""
    import subprocess
    import sys

    code = ("import sys, terrasph.scenes, terrasph.terrain.rft; print('mujoco' in sys.modules); "
            "from terrasph.terrain import attach; print('mujoco' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.split()
    assert out == ["False", "True"]
