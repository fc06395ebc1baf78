"""The package's layers: no import cycle; no library module imports the figures, the
command layer, the API objects or the CLI, and the figures none of the last three
(counting imports inside functions too)."""

import ast
from pathlib import Path

import trackdyn

PACKAGE = Path(trackdyn.__file__).parent

COMMAND_LAYER = ("trackdyn.cli", "trackdyn.__main__", "trackdyn.commands", "trackdyn.api")
"""Modules (and packages) that may read options, write files and draw figures: the commands
and the two front ends on them, the CLI and the API objects."""

PLOT_LAYER = ("trackdyn.plots",)
"""The figures: drawn from the library's results, for the commands and the API objects."""


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_names() -> dict[str, set[str]]:
    """Every dotted name each trackdyn module imports (``from a import b``: ``a``, ``a.b``)."""
    found = {}
    for path in PACKAGE.rglob("*.py"):
        names = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                names |= {f"{node.module}.{a.name}" for a in node.names} | {node.module}
            elif isinstance(node, ast.Import):
                names |= {a.name for a in node.names}
        found[module_name(path)] = names
    return found


def import_graph() -> dict[str, set[str]]:
    found = imported_names()
    graph = {}
    for name, imported in found.items():
        # the deepest trackdyn module each import names (a package's __init__ or a module)
        targets = {next((n for n in _prefixes(t) if n in found), "") for t in imported}
        graph[name] = {t for t in targets if t and t != name}
    return graph


def _prefixes(dotted: str):
    parts = dotted.split(".")
    return [".".join(parts[:i]) for i in range(len(parts), 0, -1)]


def find_cycle(graph):
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == "open":
                return stack[stack.index(nxt) :] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        state[node] = "done"
        stack.pop()
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def _within(name: str, packages) -> bool:
    return any(name == p or name.startswith(p + ".") for p in packages)


def forbidden(name: str) -> bool:
    """An import a library module must not make: the command layer, the CLI, plotting."""
    plotting = _within(name, ("matplotlib",)) or any("plots" in p for p in name.split("."))
    return plotting or _within(name, COMMAND_LAYER)


def layering_violations(imported: dict[str, set[str]]) -> list[str]:
    """``module -> name`` for each library module importing what `forbidden` names, and
    each plotting module importing the command layer."""
    found = []
    for m, names in imported.items():
        if _within(m, PLOT_LAYER):
            found += [f"{m} -> {n}" for n in names if _within(n, COMMAND_LAYER)]
        elif not _within(m, COMMAND_LAYER):
            found += [f"{m} -> {n}" for n in names if forbidden(n)]
    return sorted(found)


def test_the_checker_finds_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycle():
    graph = import_graph()
    assert find_cycle(graph) is None, " -> ".join(find_cycle(graph))


def test_the_checker_finds_a_library_module_reaching_up():
    imported = {
        "trackdyn.track.track": {"numpy", "trackdyn.errors"},
        "trackdyn.track.a": {"trackdyn.commands.run", "trackdyn.commands.run.Scenario"},
        "trackdyn.track.b": {"trackdyn.cli"},
        "trackdyn.track.c": {"matplotlib.pyplot"},
        "trackdyn.track.d": {"trackdyn.vehicle", "trackdyn.vehicle.plots"},
        "trackdyn.track.e": {"trackdyn.plots"},
        "trackdyn.commands.run": {"trackdyn.plots", "matplotlib"},
        "trackdyn.plots.run": {"matplotlib", "trackdyn.results", "trackdyn.commands.tables"},
        "trackdyn.plots": {"trackdyn.api"},
        "trackdyn.api": {"trackdyn.commands.run", "trackdyn.plots.run"},
        "trackdyn.cli": {"trackdyn.commands.run"},
        "trackdyn.__main__": {"trackdyn.cli"},
    }
    assert layering_violations(imported) == [
        "trackdyn.plots -> trackdyn.api",
        "trackdyn.plots.run -> trackdyn.commands.tables",
        "trackdyn.track.a -> trackdyn.commands.run",
        "trackdyn.track.a -> trackdyn.commands.run.Scenario",
        "trackdyn.track.b -> trackdyn.cli",
        "trackdyn.track.c -> matplotlib.pyplot",
        "trackdyn.track.d -> trackdyn.vehicle.plots",
        "trackdyn.track.e -> trackdyn.plots",
    ]
    assert not forbidden("trackdyn.commandsx") and forbidden("trackdyn.commands")


def test_library_modules_do_not_import_commands_cli_or_plots():
    imported = imported_names()
    assert layering_violations(imported) == []
