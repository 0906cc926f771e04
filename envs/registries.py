"""One registry type for every pluggable component (sensors, vehicles, target motions, MI
estimators).

A :class:`Registry` maps a short name to a factory (usually the component's class). It is a
read-only :class:`~collections.abc.Mapping` (``name in registry``, ``sorted(registry)``,
``registry.items()``), grows through :meth:`Registry.register`, and builds components with
:meth:`Registry.make`, which also passes ready-made instances through. An unknown name raises
:class:`UnknownNameError`, which is both a ``ValueError`` (what callers validating user input
catch) and a ``KeyError`` (what mapping look-ups raise), and whose message lists the valid names.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import Any, Generic, TypeVar

__all__ = ["Registry", "UnknownNameError"]

F = TypeVar("F", bound=Callable[..., Any])


class UnknownNameError(KeyError, ValueError):
    """A name that is not in a :class:`Registry` (the message lists the valid names)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class Registry(Mapping[str, F], Generic[F]):
    """Name -> factory (a class, usually) of one kind of component.

    Args:
        kind: What the entries are, for error messages (``"sensor"``, ``"MI estimator"``).
        base: The component type (a class or runtime-checkable ``Protocol``) that
            :meth:`make` accepts as a ready-made instance; ``None`` accepts none.
    """

    def __init__(self, kind: str, base: type | None = None) -> None:
        self.kind = kind
        self.base = base
        self._entries: dict[str, F] = {}

    def register(self, name: str, factory: F) -> F:
        """Add ``factory`` under ``name`` and return it (usable as a class decorator helper).

        Raises:
            TypeError: ``name`` is not a non-empty string or ``factory`` is not callable.
            ValueError: ``name`` is already registered.
        """
        if not isinstance(name, str) or not name:
            raise TypeError(f"{self.kind} registry: name must be a non-empty str, got {name!r}")
        if not callable(factory):
            raise TypeError(f"{self.kind} registry: factory for {name!r} must be callable")
        if name in self._entries:
            raise ValueError(f"{self.kind} registry: {name!r} is already registered")
        self._entries[name] = factory
        return factory

    def __getitem__(self, name: str) -> F:
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise UnknownNameError(
                f"unknown {self.kind} {name!r}; valid names: {sorted(self._entries)}"
            ) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {sorted(self._entries)})"

    def make(self, spec: Any, **kwargs: Any) -> Any:
        """Build a component from a registry name, or pass an instance through.

        Args:
            spec: A registered name, or an instance of :attr:`base`.
            **kwargs: Constructor arguments for a named component; must be empty with an
                instance.

        Returns:
            The component.

        Raises:
            UnknownNameError: (a ``ValueError``) ``spec`` is an unknown name.
            TypeError: ``kwargs`` with an instance, or ``spec`` is neither a name nor a
                :attr:`base` instance.
        """
        if isinstance(spec, str):
            return self[spec](**kwargs)
        if self.base is not None and isinstance(spec, self.base):
            if kwargs:
                raise TypeError(
                    f"spec: keyword arguments {sorted(kwargs)} are only allowed with a {self.kind} "
                    f"name, not with an instance of {type(spec).__name__}"
                )
            return spec
        raise TypeError(
            f"spec: expected a {self.kind} name {sorted(self._entries)} or a "
            f"{getattr(self.base, '__name__', 'component')} instance, got {type(spec).__name__}"
        )
