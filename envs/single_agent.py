"""Single-vehicle search as a Gymnasium environment (``gymnasium.Env``).

With one vehicle the team game is an ordinary MDP over the vehicle state and its belief. This
module wraps the one-agent parallel environment so that single-agent tooling
(``gymnasium.utils.env_checker.check_env``, stable-baselines3's ``check_env`` and algorithms,
any ``gymnasium.Env`` consumer) works unmodified::

    import gymnasium
    import infoseek.envs  # registers the ids below with Gymnasium

    env = gymnasium.make("infoseek/Bearings-v0", n_particles=1000)

Registered ids: ``infoseek/Bearings-v0`` (``bearings_v0``) and ``infoseek/Beacon-v0``
(``beacon_v0``); ``gymnasium.make("infoseek.envs:infoseek/Bearings-v0")`` also works without
importing ``infoseek.envs`` first. Observations, actions, reward, termination, truncation and
infos are those of the agent ``vehicle_0`` of the parallel environment, whose manual
(``infoseek.envs.bearings_v0`` / ``beacon_v0``) documents them; the parallel environment is
``env.unwrapped.parallel`` (its ``belief("vehicle_0")``, ``true_target()``, ...).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np

from infoseek.envs.registration import make

__all__ = ["GYMNASIUM_IDS", "SingleAgentSearchEnv", "register_with_gymnasium"]

#: Gymnasium id -> infoseek environment id.
GYMNASIUM_IDS = {"infoseek/Bearings-v0": "bearings_v0", "infoseek/Beacon-v0": "beacon_v0"}


class SingleAgentSearchEnv(gymnasium.Env):  # type: ignore[type-arg]
    """One vehicle searching alone, as a ``gymnasium.Env``.

    Args:
        env_id: The infoseek environment (``"bearings_v0"``, ``"beacon_v0"``).
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
        **kwargs: Configuration of the parallel environment (its manual); ``n_agents`` may only
            be 1.

    Raises:
        ValueError: ``n_agents`` other than 1, or an invalid configuration.
    """

    metadata: dict[str, Any] = {"render_modes": ["human", "rgb_array"], "render_fps": 4}

    def __init__(self, env_id: str = "bearings_v0", render_mode: str | None = None, **kwargs: Any):
        if kwargs.get("n_agents", 1) != 1:
            raise ValueError(
                f"SingleAgentSearchEnv has one vehicle: n_agents must be 1, got "
                f"{kwargs['n_agents']!r} (use infoseek.envs.make for a team)"
            )
        kwargs.pop("n_agents", None)
        self.parallel = make(env_id, n_agents=1, render_mode=render_mode, **kwargs)
        self.agent = self.parallel.possible_agents[0]
        self.observation_space = self.parallel.observation_space(self.agent)
        self.action_space = self.parallel.action_space(self.agent)
        self.render_mode = render_mode

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode (``options``: as the parallel environment's ``reset``)."""
        super().reset(seed=seed)
        observations, infos = self.parallel.reset(seed=seed, options=options)
        return observations[self.agent], infos[self.agent]

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply the vehicle's action for one step."""
        if not self.parallel.agents:
            raise RuntimeError("step() called after the episode ended: call reset() first")
        observations, rewards, terminations, truncations, infos = self.parallel.step(
            {self.agent: action}
        )
        return (
            observations[self.agent],
            rewards[self.agent],
            terminations[self.agent],
            truncations[self.agent],
            infos[self.agent],
        )

    def render(self) -> Any:
        """The parallel environment's frame (``rgb_array``) or window (``human``)."""
        return self.parallel.render()

    def close(self) -> None:
        """Release the rendering figure."""
        self.parallel.close()


def register_with_gymnasium() -> None:
    """Register :data:`GYMNASIUM_IDS` with Gymnasium's registry (once; idempotent)."""
    registry = gymnasium.envs.registration.registry
    for gym_id, env_id in GYMNASIUM_IDS.items():
        if gym_id not in registry:
            gymnasium.register(
                id=gym_id,
                entry_point=f"{__name__}:SingleAgentSearchEnv",
                kwargs={"env_id": env_id},
            )
