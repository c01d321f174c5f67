"""The registries of inkarm.plugins: built-ins loaded once whichever thread asks first, lazy
items imported at their first lookup, a failed built-in import retried, import paths."""

from __future__ import annotations

import threading
import time

import pytest

from inkarm.errors import InputError
from inkarm.plugins import Lazy, Registry, import_path


def test_two_threads_asking_at_once_both_see_the_built_ins():
    def slow_builtins():
        time.sleep(0.05)
        registry.register("a", 1)

    registry = Registry("law", slow_builtins)
    barrier, found = threading.Barrier(2), []

    def ask():
        barrier.wait()
        found.append(registry.get("a"))

    threads = [threading.Thread(target=ask) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert found == [1, 1]


def test_a_failed_builtin_import_is_retried_not_forgotten():
    calls = []

    def flaky():
        calls.append(1)
        if len(calls) == 1:
            raise ImportError("not yet")
        registry.register("a", 2)

    registry = Registry("law", flaky)
    with pytest.raises(ImportError):
        registry.get("a")
    assert registry.get("a") == 2 and len(calls) == 2


def test_a_lazy_item_is_imported_at_its_first_lookup_only():
    registry = Registry("backend")
    registry.register("json", Lazy("json:dumps"))
    assert registry.names() == ("json",)
    import json

    assert registry.get("json") is json.dumps


@pytest.mark.parametrize("path, message", [
    ("json", r"expected 'package\.module:Attribute'"),
    ("no_such_module_xyz:f", r"cannot import module 'no_such_module_xyz'"),
    ("json:no_such", r"module 'json' has no attribute 'no_such'"),
])
def test_import_paths_are_refused_by_name(path, message):
    with pytest.raises(InputError, match=message):
        import_path(path, key="controller.law")


def test_names_with_a_colon_are_refused():
    with pytest.raises(InputError, match=r"a law name must be non-empty and have no ':'"):
        Registry("law").register("a:b", 1)
