"""Checks of RL hyperparameters before anything is built or written (``--hyper KEY=VALUE``).

A value's type is checked against the annotation of the algorithm's constructor argument
(Stable-Baselines3 annotates every one: ``n_steps: int``, ``gamma: float``,
``learning_rate: float | Callable``, ``train_freq: int | tuple[int, str]``, ...), then its range
against :data:`RANGES` where one is known, so ``--hyper n_steps=abc`` or ``--hyper gamma=2``
fail at once with a message naming the hyperparameter, not deep inside the algorithm after a
run directory was written. From the command line a value is JSON (``net_arch=[64,64]``), so a
callable schedule or a class cannot be given there; such annotations accept only what JSON can
express (``None``, numbers, strings, lists, objects).
"""

from __future__ import annotations

import collections.abc
import inspect
import math
import types
import typing
from collections.abc import Mapping
from typing import Any

__all__ = ["RANGES", "check_hyperparameters"]

#: Hyperparameter -> (lowest, highest, lowest excluded) for numbers; None: unbounded there.
RANGES: dict[str, tuple[float | None, float | None, bool]] = {
    "learning_rate": (0.0, None, True),
    "n_steps": (1, None, False),
    "batch_size": (2, None, False),  # PPO asserts batch_size > 1
    "n_epochs": (1, None, False),
    "gamma": (0.0, 1.0, False),
    "gae_lambda": (0.0, 1.0, False),
    "clip_range": (0.0, None, True),
    "clip_range_vf": (0.0, None, True),
    "ent_coef": (0.0, None, False),
    "vf_coef": (0.0, None, False),
    "max_grad_norm": (0.0, None, True),
    "target_kl": (0.0, None, True),
    "buffer_size": (1, None, False),
    "learning_starts": (0, None, False),
    "tau": (0.0, 1.0, True),
    "policy_delay": (1, None, False),
    "target_policy_noise": (0.0, None, False),
    "target_noise_clip": (0.0, None, False),
    "stats_window_size": (1, None, False),
}


def _describe(annotation: Any) -> str:
    if annotation is type(None):
        return "None"
    if isinstance(annotation, type):
        return {"int": "an integer", "float": "a number", "bool": "true/false"}.get(
            annotation.__name__, annotation.__name__
        )
    return str(annotation).replace("typing.", "").replace("collections.abc.", "")


def _options(annotation: Any) -> tuple[Any, ...]:
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        return typing.get_args(annotation)
    return (annotation,)


def _conform(value: Any, annotation: Any) -> tuple[bool, Any]:
    """``(fits, value converted)`` of ``value`` against one annotation (not a union)."""
    origin = typing.get_origin(annotation)
    if annotation is Any:
        return True, value
    if annotation is type(None):
        return value is None, value
    if annotation is bool:
        return isinstance(value, bool), value
    if annotation is int:
        return isinstance(value, int) and not isinstance(value, bool), value
    if annotation is float:
        fits = isinstance(value, int | float) and not isinstance(value, bool)
        return fits and math.isfinite(value), float(value) if fits else value
    if annotation is str:
        return isinstance(value, str), value
    if origin is tuple:
        kinds = typing.get_args(annotation)
        if not isinstance(value, list | tuple) or len(value) != len(kinds):
            return False, value
        parts = [_conform(item, kind) for item, kind in zip(value, kinds, strict=True)]
        return all(fits for fits, _ in parts), tuple(item for _, item in parts)
    if origin is dict:
        return isinstance(value, dict), value
    if origin is collections.abc.Callable or origin is type:
        return False, value  # a schedule or a class: not expressible on the command line
    if isinstance(annotation, type):
        return isinstance(value, annotation), value
    return True, value  # an annotation this check does not know: left to the algorithm


def _check_range(name: str, value: Any) -> None:
    if name not in RANGES or isinstance(value, bool) or not isinstance(value, int | float):
        return
    low, high, open_low = RANGES[name]
    if (low is not None and (value < low or (open_low and value == low))) or (
        high is not None and value > high
    ):
        bounds = f"{'(' if open_low else '['}{low}, {'inf' if high is None else high}]"
        raise ValueError(f"hyperparameter {name} must lie in {bounds}, got {value!r}")


def _check_net_arch(value: Any) -> list[int]:
    if not isinstance(value, list | tuple) or not value:
        raise TypeError(f"hyperparameter net_arch must be a list of layer sizes, got {value!r}")
    for size in value:
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(
                f"hyperparameter net_arch must be a list of integers >= 1, got {value!r}"
            )
    return list(value)


def check_hyperparameters(algorithm: type, values: Mapping[str, Any]) -> dict[str, Any]:
    """``values`` checked against ``algorithm``'s constructor (module docstring).

    Args:
        algorithm: The Stable-Baselines3 class (``PPO``, ``SAC``, ``TD3``).
        values: Hyperparameter -> value; ``net_arch`` (hidden layer sizes) is infoseek's own.

    Returns:
        The values, lists converted to tuples where the annotation is a tuple.

    Raises:
        TypeError: A value of the wrong type (the message names it and the expected type).
        ValueError: A value out of range.
    """
    parameters = inspect.signature(algorithm).parameters  # the constructor's, without self
    checked: dict[str, Any] = {}
    for name, value in values.items():
        if name == "net_arch":
            checked[name] = _check_net_arch(value)
            continue
        annotation = parameters[name].annotation if name in parameters else Any
        if annotation is inspect.Parameter.empty:
            annotation = Any
        for option in _options(annotation):
            fits, converted = _conform(value, option)
            if fits:
                break
        else:
            expected = " or ".join(_describe(option) for option in _options(annotation))
            raise TypeError(f"hyperparameter {name} must be {expected}, got {value!r}")
        _check_range(name, converted)
        checked[name] = converted
    return checked
