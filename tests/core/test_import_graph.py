"""The add-on's modules import one another in one direction: every module under addon/ is
parsed (not imported), every import of another add-on module, at module level or inside a
function, is an edge, and the graph must have no cycle. A module's import of a package that
contains it is not an edge (Python imports the parents first anyway), nor is an import under
``if TYPE_CHECKING:`` (for annotations only: it never runs)."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ADDON = ROOT / "addon"


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph(files: dict[str, Path]) -> dict[str, set[str]]:
    """{module: add-on modules it imports}, names relative to the repository root (imports
    under ``if TYPE_CHECKING:``, for annotations only, are not edges)."""
    graph = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges = set()
        for node in _runtime_imports(ast.parse(path.read_text(), filename=str(path))):
            targets = []
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                stem = ".".join(base + ([node.module] if node.module else []))
                targets = [stem] + [f"{stem}.{a.name}" for a in node.names]
            for target in targets:
                if target in files and target != name and not name.startswith(target + "."):
                    edges.add(target)
        graph[name] = edges
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    stack: list[str] = []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_no_import_cycle_in_the_addon():
    files = {module_name(p): p for p in sorted(ADDON.rglob("*.py"))}
    graph = import_graph(files)
    assert len(graph) > 20 and graph["addon.blender.engine"]  # the parser sees the imports
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))


def test_the_checker_finds_a_cycle_inside_a_function(tmp_path):
    pkg = tmp_path / "addon"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("def f():\n    from .a import g\n")
    files = {module_name(p, tmp_path): p for p in sorted(pkg.rglob("*.py"))}
    assert find_cycle(import_graph(files)) == ["addon.a", "addon.b", "addon.a"]


# The core's rooms, bottom floor first: a module imports from its own floor or those below.
FLOORS = ("system", "kernels", "formulas", "scene", "lighting", "render", "bakes", "files",
          "review")


def _room(module: str) -> str | None:
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[:2] == ["addon", "core"] else None


def _runtime_imports(tree: ast.AST) -> list[ast.ImportFrom]:
    """The relative imports of a module, those under ``if TYPE_CHECKING:`` left out."""
    found = []

    def visit(node):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            return
        if isinstance(node, ast.ImportFrom) and node.level:
            found.append(node)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def _edges(files: dict[str, Path]):
    """(module, imported add-on module, imported name, the name it is bound to) of every
    relative import."""
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in _runtime_imports(ast.parse(path.read_text(), filename=str(path))):
            base = package.split(".")
            base = base[:len(base) - node.level + 1]
            stem = ".".join(base + ([node.module] if node.module else []))
            for alias in node.names:
                target = f"{stem}.{alias.name}"
                yield (name, target if target in files else stem, alias.name,
                       alias.asname or alias.name)


def test_the_core_rooms_import_downwards_only():
    files = {module_name(p): p for p in sorted(ADDON.rglob("*.py"))}
    rooms = {_room(name) for name in files} - {None}
    assert rooms == set(FLOORS), "a room of core/ is missing from FLOORS (or gone)"
    upward = [f"{a} -> {b}" for a, b, *_ in _edges(files)
              if _room(a) and _room(b) and FLOORS.index(_room(b)) > FLOORS.index(_room(a))]
    assert not upward, upward


def test_no_module_imports_another_modules_private_name():
    files = {module_name(p): p for p in sorted(ADDON.rglob("*.py"))}
    private = [f"{a} imports {name} from {b}" for a, b, name, _ in _edges(files)
               if name.startswith("_") and not name.startswith("__") and b != a]
    modules = {}  # per module: the names it binds to other add-on modules
    for a, b, name, bound in _edges(files):
        if b.endswith("." + name) and b in files:
            modules.setdefault(a, set()).add(bound)
    for a, path in files.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in modules.get(a, ()) and node.attr.startswith("_")
                    and not node.attr.startswith("__")):
                private.append(f"{a} reads {node.value.id}.{node.attr}")
    assert not private, private


def test_every_package_is_in_the_distribution():
    """pyproject.toml lists every package of the add-on (a wheel built from it has them all)."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = {"bo2_lighting." + module_name(p.parent / "__init__.py")
                for p in ADDON.rglob("__init__.py")} | {"bo2_lighting"}
    assert packages == set(config["packages"])
    data = [ROOT / pkg.removeprefix("bo2_lighting.").replace(".", "/") / pattern
            for pkg, patterns in config["package-data"].items() for pattern in patterns]
    assert all(list(path.parent.glob(path.name)) for path in data), data
