"""Uniform random baseline policy.

Each agent's action is drawn uniformly from its action space with the policy's own
``numpy.random.Generator`` (seeded by the ``seed`` option), never from the spaces' internal
generators, so a seeded policy is reproducible: continuous actions uniformly in the Box
``[control_low, control_high]`` (as ``float32``), discrete actions uniformly over
``range(K)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from infoseek.planners.base import Planner
from infoseek.planners.model import EnvModel, FloatArray

__all__ = ["RandomPolicy", "RandomPolicyConfig"]


@dataclass(frozen=True)
class RandomPolicyConfig:
    """Options of :class:`RandomPolicy`.

    Attributes:
        seed: Seed of the policy's own generator (``None``: OS entropy).
    """

    seed: int | None = None


@dataclass(frozen=True)
class RandomPlan:
    """Diagnostics of one :meth:`RandomPolicy.act` call.

    Attributes:
        controls: Agent -> the control applied (``(control_dim,)``).
    """

    controls: Mapping[str, FloatArray]


class RandomPolicy(Planner):
    """Uniform random actions (a baseline)."""

    config_class = RandomPolicyConfig

    def __init__(self, model: EnvModel, config: RandomPolicyConfig) -> None:
        super().__init__(model, config)
        self.rng = np.random.default_rng(config.seed)

    def reset(self, seed: int | None = None) -> None:
        """Forget diagnostics; with ``seed``, also reseed the generator."""
        super().reset()
        if seed is not None:
            self.rng = np.random.default_rng(seed)

    def _plan(
        self, agents: list[str], states: FloatArray, infos: Mapping[str, Any]
    ) -> dict[str, Any]:
        actions: dict[str, Any] = {}
        controls: dict[str, FloatArray] = {}
        if self.model.action_type == "discrete":
            assert self.model.discrete_controls is not None
            k = self.model.discrete_controls.shape[0]
            for agent in agents:
                index = int(self.rng.integers(k))
                actions[agent] = index
                controls[agent] = self.model.discrete_controls[index].copy()
        else:
            for agent in agents:
                space = self.model.action_spaces[agent]
                u = self.rng.uniform(self.model.control_low, self.model.control_high)
                action = np.clip(u.astype(np.float32), space.low, space.high).astype(np.float32)
                actions[agent] = action
                controls[agent] = action.astype(np.float64)
        self.last_plan = RandomPlan(controls=controls)
        return actions
