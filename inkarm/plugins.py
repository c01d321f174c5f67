"""Registries of the things a user may add to inkarm, and the ``inkarm.plugins`` entry points.

One :class:`Registry` per kind: control laws, watchdogs, inks, robots, backends and stroke
kinds (:data:`KINDS`). Built-ins register themselves when their module is imported; anything
else is reached two ways:

* by import path: ``"package.module:Class"`` anywhere a scenario names a registered thing
  (``[controller] law = "mylab.laws:Impedance"``), imported when first named;
* by an installed package's entry point in the group ``inkarm.plugins``, named
  ``"<kind>.<name>"`` (``law.gravity_pd = "mylab.laws:GravityPD"``): the registry of that kind
  loads its entry points the first time a name it does not know is asked for.

This module imports nothing of inkarm but its errors, so every room may register into it.
"""

from __future__ import annotations

import importlib
import inspect
import threading
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from inkarm.errors import InputError, closest, unknown_name

GROUP = "inkarm.plugins"
KINDS = ("law", "watchdog", "ink", "robot", "backend", "stroke_kind")


@dataclass(frozen=True)
class Lazy:
    """A registered item still to be imported from ``"package.module:Attribute"``."""

    path: str


class Registry:
    """Named things of one kind (``kind``), with the entry points of :data:`GROUP` named
    ``"<kind>.<name>"`` and import paths ``"package.module:Attribute"`` as fallbacks.

    Args:
        kind: One of :data:`KINDS`; names the kind in messages.
        loader: Imports the module(s) whose import registers the built-ins (run once, at the
            first lookup), so that a lookup never depends on what happened to be imported.
    """

    def __init__(self, kind: str, loader: Callable[[], None] | None = None):
        self.kind = kind
        self._items: dict[str, Any] = {}
        self._loader = loader
        self._entry_points_loaded = False
        self._plugged: set[str] = set()  # the names an entry point added
        self._lock = threading.RLock()  # (a registry is filled once, whichever thread asks)

    def register(self, name: str, item: Any = None):
        """Add ``item`` as ``name`` (replacing one of the same name); as a decorator when
        ``item`` is left out. Returns the item. An item given as :class:`Lazy` is imported at
        its first lookup (a built-in whose module is heavy: the simulator's backend). A thing
        registered in code lives in the process that registered it: a sweep's or an
        ensemble's worker processes know it only by an import path or an entry point."""
        if item is None:
            return lambda thing: self.register(name, thing)
        if not name or ":" in name:
            raise InputError(f"a {self.kind} name must be non-empty and have no ':', got "
                             f"{name!r}", key=self.kind, value=name)
        with self._lock:
            self._items[name] = item
            self._plugged.discard(name)
        return item

    def _builtins(self) -> None:
        if self._loader is None:
            return
        with self._lock:
            if self._loader is not None:
                self._loader()
                self._loader = None  # (only once it has worked: a failed import is retried)

    def _entry_points(self) -> None:
        """List the installed plug-ins of this kind, without importing them: one that fails to
        load is refused when it is asked for, not when another name is."""
        if self._entry_points_loaded:
            return
        prefix = f"{self.kind}."
        with self._lock:
            if self._entry_points_loaded:
                return
            for point in metadata.entry_points(group=GROUP):
                if not point.name.startswith(prefix):
                    continue
                name = point.name[len(prefix):]
                if name in self._items:
                    warnings.warn(f"the {self.kind} plug-in {point.name!r} ({point.value}) is "
                                  f"not used: {name!r} is taken (a built-in or another "
                                  f"plug-in's)", UserWarning, stacklevel=3)
                    continue
                self._items[name] = point
                self._plugged.add(name)
            self._entry_points_loaded = True

    def names(self) -> tuple[str, ...]:
        """The registered names, built-ins and installed plug-ins."""
        self._builtins()
        self._entry_points()
        return tuple(self._items)

    def get(self, name: str, key: str | None = None) -> Any:
        """The item called ``name``, or imported from ``"package.module:Attribute"``; an
        :class:`InputError` naming ``key`` and the closest valid name otherwise."""
        self._builtins()
        if name in self._items:
            return self._resolved(name)
        if ":" in name:
            return import_path(name, key or self.kind)
        self._entry_points()
        if name not in self._items:
            raise unknown_name(self.kind, name, tuple(self._items), key=key or self.kind)
        return self._resolved(name)

    def _resolved(self, name: str) -> Any:
        item = self._items[name]
        if isinstance(item, Lazy):
            item = self._items[name] = import_path(item.path, key=self.kind)
        elif isinstance(item, metadata.EntryPoint):
            try:
                loaded = item.load()
            except Exception as e:  # noqa: BLE001 (a broken plug-in is named, not a traceback)
                dist = getattr(item, "dist", None)
                package = f" of the package {dist.name!r}" if dist is not None else ""
                raise InputError(f"the {self.kind} plug-in {item.name!r}{package} "
                                 f"({item.value}) failed to load: {type(e).__name__}: {e}",
                                 key=self.kind, value=item.name) from None
            with self._lock:
                if self._items.get(name) is item:
                    self._items[name] = loaded
            item = loaded
        return item

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __contains__(self, name: object) -> bool:
        return name in self.names()

    def __getitem__(self, name: str) -> Any:
        return self.get(name)

    def __len__(self) -> int:
        return len(self.names())

    def forget_entry_points(self) -> None:
        """Drop what the entry points added; the next unknown name reads them again."""
        for name in self._plugged:
            self._items.pop(name, None)
        self._plugged.clear()
        self._entry_points_loaded = False


def import_path(path: str, key: str) -> Any:
    """The attribute ``Attribute`` of module ``package.module`` for ``"package.module:Attribute"``
    (dots in the attribute walk into it); an :class:`InputError` naming ``key`` and what was
    missing otherwise."""
    module_name, _, attribute = path.partition(":")
    if not module_name or not attribute:
        raise InputError(f"expected 'package.module:Attribute', got {path!r}", key=key,
                         value=path)
    try:
        obj: Any = importlib.import_module(module_name)
    except ImportError as e:
        raise InputError(f"cannot import module {module_name!r} of {path!r}: {e}", key=key,
                         value=path) from None
    for part in attribute.split("."):
        if not hasattr(obj, part):
            raise InputError(f"module {module_name!r} has no attribute {attribute!r}", key=key,
                             value=path)
        obj = getattr(obj, part)
    return obj


def check_settings(cls: type, settings: dict[str, Any], what: str, key: str) -> None:
    """Refuse a setting that is not a keyword argument of ``cls`` (unless it takes
    ``**kwargs``), naming ``key.<setting>``, the closest valid one and all of them."""
    params = inspect.signature(cls).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return
    valid = tuple(name for name, p in params.items() if p.kind in (
        inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD))
    for setting in settings:
        if setting not in valid:
            hint = closest(setting, valid) if valid else None
            raise InputError(
                f"{what} has no setting {setting!r}"
                + (f" (did you mean {hint!r}?)" if hint else "")
                + (f"; its settings: {', '.join(valid)}" if valid else "; it takes none"),
                key=f"{key}.{setting}", value=setting, choices=valid)


_REGISTRIES: dict[str, Registry] = {}


def registry(kind: str) -> Registry:
    """The registry of ``kind`` (one of :data:`KINDS`)."""
    if kind not in _REGISTRIES:
        if kind not in KINDS:
            raise unknown_name("plug-in kind", kind, KINDS, key="kind")
        _REGISTRIES[kind] = Registry(kind, _BUILTIN_LOADERS.get(kind))
    return _REGISTRIES[kind]


def reload_entry_points() -> None:
    """Forget the plug-ins every registry has loaded from entry points, so that the next
    lookup reads the ``inkarm.plugins`` entry points again: after installing or removing a
    package in a running process (a test that puts one on ``sys.path``, a notebook after
    ``pip install``). Built-ins and things registered in code stay."""
    importlib.invalidate_caches()  # importlib.metadata's view of sys.path included
    for reg in _REGISTRIES.values():
        reg.forget_entry_points()


def _import(*modules: str) -> Callable[[], None]:
    def load() -> None:
        for module in modules:
            importlib.import_module(module)
    return load


# The modules whose import registers each kind's built-ins (imported at the first lookup only:
# looking up a law never imports a backend, and a plotter never imports MuJoCo).
_BUILTIN_LOADERS: dict[str, Callable[[], None]] = {
    "law": _import("inkarm.control.laws.builtin"),
    "watchdog": _import("inkarm.control.watchdogs.builtin"),
    "backend": _import("inkarm.jobs.backends.builtin"),
    "ink": _import("inkarm.ink.inks"),
    "robot": _import("inkarm.robots.registry"),
    "stroke_kind": _import("inkarm.plans.kinds"),
}


__all__ = ["GROUP", "KINDS", "Lazy", "Registry", "check_settings", "import_path", "registry",
           "reload_entry_points"]
