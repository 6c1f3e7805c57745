"""The package's import graph, read with ``ast`` (every import, at module level or inside a function):
no cycles, and the value types in ``massprops/model/`` below everything that uses them."""

import ast
from pathlib import Path

import massprops

PACKAGE = Path(massprops.__file__).parent
# What massprops.model may import from: itself and the compiled core beneath it.
BELOW_MODEL = ("massprops.model", "massprops.core")


def _module_name(path):
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path, modules):
    """The massprops modules ``path`` imports (``from .x import y`` counts ``x.y`` when that is a module)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in modules:       # a name inside a module: the module
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def _graph():
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    return {name: _imports(path, paths) for name, path in paths.items()}


def _without_packages(graph):
    """Edges into a package's ``__init__`` stand for its re-exports; a package importing its own modules
    is not a cycle through them."""
    return {name: {t for t in targets if not name.startswith(t + ".")} for name, targets in graph.items()}


def _cycle(graph):
    """One import cycle as a list of modules, or None."""
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_the_walk_sees_imports():
    graph = _graph()
    assert "massprops.model.properties" in graph["massprops.model.combine"]
    assert "massprops.model.combine" in graph["massprops.robot.overlap"]
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycles():
    cycle = _cycle(_without_packages(_graph()))
    assert cycle is None, " -> ".join(cycle)


def test_model_imports_nothing_above_it():
    graph = _graph()
    model = [name for name in graph if name.startswith("massprops.model")]
    assert len(model) >= 10
    upward = {name: sorted(t for t in graph[name] if not t.startswith(BELOW_MODEL))
              for name in model}
    assert {name: targets for name, targets in upward.items() if targets} == {}


def test_reports_and_applications_stay_below_the_commands():
    graph = _graph()
    # Only the command line (and ``python -m massprops``) imports the command line.
    into_cli = sorted((name, t) for name, targets in graph.items() for t in targets
                      if t.startswith("massprops.cli") and not name.startswith(("massprops.cli", "massprops.__main__")))
    assert into_cli == []
    # Reports render results: they read no files through batch, view or the commands.
    report_up = sorted((name, t) for name, targets in graph.items() if name.startswith("massprops.report")
                       for t in targets if t.startswith(("massprops.cli", "massprops.batch", "massprops.view")))
    assert report_up == []
    # The robot application takes its maths from the model, not from the scene application.
    robot_on_scene = sorted((name, t) for name, targets in graph.items() if name.startswith("massprops.robot")
                            for t in targets if t.startswith("massprops.scene"))
    assert robot_on_scene == []


def test_only_the_checking_commands_use_validation():
    # validation/ holds the oracle, the reference solids and the regress/accuracy/compare tools: the
    # library (batch workers included) computes without it.
    users = sorted({name for name, targets in _graph().items() for t in targets
                    if t.startswith("massprops.validation") and not name.startswith("massprops.validation")})
    assert users and all(name.startswith("massprops.cli.") for name in users), users
