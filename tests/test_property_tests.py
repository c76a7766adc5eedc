"""The property tests' own rules: an example a test cannot use is discarded with
``assume()`` (a ``return`` would count it as a pass), and what every property test
shares (no deadline, the health checks left off) lives in the profile of ``conftest.py``,
so that a test's ``@settings`` states at most its budget (``max_examples``)."""

from __future__ import annotations

import ast
from pathlib import Path

from hypothesis import HealthCheck, settings

TESTS = Path(__file__).parent


def _property_tests(folder):
    """``(path, function)`` of every test decorated with ``@given`` in `folder`."""
    for path in sorted(folder.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and any(
                    ast.unparse(d).startswith("given(") for d in node.decorator_list):
                yield path, node


def _own_nodes(function):
    """The nodes of `function`'s body, not those of the functions defined inside it."""
    todo = list(function.body)
    while todo:
        node = todo.pop()
        yield node
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            todo.extend(ast.iter_child_nodes(node))


def _early_returns(folder):
    """``path:line name`` of each ``return`` inside a property test of `folder`."""
    return [f"{path.name}:{node.lineno} {test.name}" for path, test in _property_tests(folder)
            for node in _own_nodes(test) if isinstance(node, ast.Return)]


def _restated_settings(folder):
    """``path:line`` of each ``settings(...)`` in `folder` that states more than a budget."""
    found = []
    for path in sorted(folder.glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and ast.unparse(node.func) == "settings"
                    and (node.args or {k.arg for k in node.keywords} - {"max_examples"})):
                found.append(f"{path.name}:{node.lineno}")
    return found


def test_no_property_test_returns_early():
    assert _early_returns(TESTS) == []


def test_a_property_test_states_at_most_its_budget():
    assert _restated_settings(TESTS) == []


def test_both_profiles_carry_what_every_property_test_shares():
    for name in ("diskpack", "ci"):
        profile = settings.get_profile(name)
        assert profile.deadline is None and profile.max_examples == 100
        assert {HealthCheck.too_slow, HealthCheck.function_scoped_fixture} <= set(
            profile.suppress_health_check)
    assert settings.get_profile("ci").derandomize
    assert settings.default.deadline is None   # one of them is loaded
