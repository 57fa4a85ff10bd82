"""Every command stands alone: no app command module reaches another, by any import.

The modules are those of the independence contract in ``pyproject.toml``
(import-linter checks it in CI); this check walks the ``ast`` graph of
:mod:`tests.test_architecture`, which also sees imports inside functions
and under ``TYPE_CHECKING``, through every helper module in between.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.test_architecture import import_graph

tomllib = pytest.importorskip("tomllib")  # Python 3.11

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"
CONTRACT = "Every command stands alone: the app command modules are independent"


def command_modules() -> list[str]:
    """Return the modules of the independence contract."""
    config = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))
    (contract,) = [c for c in config["tool"]["importlinter"]["contracts"] if c["name"] == CONTRACT]
    assert contract["type"] == "independence"
    return list(contract["modules"])


def reached(graph: dict[str, set[str]], start: str) -> set[str]:
    """Return every module ``start`` imports, directly or through others."""
    seen: set[str] = set()
    todo = list(graph.get(start, ()))
    while todo:
        module = todo.pop()
        if module not in seen:
            seen.add(module)
            todo.extend(graph.get(module, ()))
    return seen


def test_every_subcommands_app_module_is_in_the_contract():
    commands = set(command_modules())
    behind = {  # the app modules the subcommands' CLI modules call
        module
        for name, imports in import_graph().items()
        if name.startswith("terrain_odom.cli.")
        for module in imports
        if module.startswith("terrain_odom.app.")
    }
    helpers = {
        "calibration",
        "inputs",
        "locate",
        "record",
        "run_folder",
        "tune",
        "evaluation_results",
    }
    assert behind - {f"terrain_odom.app.{h}" for h in helpers} <= commands
    assert {"terrain_odom.app.run", "terrain_odom.app.fit", "terrain_odom.app.evaluate"} <= behind


def test_no_command_module_reaches_another():
    graph = import_graph()
    commands = command_modules()
    assert len(commands) >= 10
    crossings = {c: sorted(reached(graph, c) & set(commands) - {c}) for c in commands}
    assert {c: r for c, r in crossings.items() if r} == {}


def test_the_check_sees_a_crossing_through_a_helper():
    graph = {"app.run": {"app.inputs"}, "app.inputs": {"app.fit"}, "app.fit": set()}
    assert reached(graph, "app.run") == {"app.inputs", "app.fit"}
