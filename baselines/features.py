"""Fixed affine observation scaling inside the policy network.

The observation of the information-seeking environments mixes positions in distance units
(``0 .. 40`` and beyond: airplanes may leave the domain), angles in ``[-pi, pi]``, belief masses
in ``[0, 1]`` and the MMSE estimate in domain units. Raw positions of order 40 saturate the
``tanh`` units of an MLP, so every observation entry ``o_j`` is mapped to

    x_j = (o_j - offset_j) / scale_j,

with constants fixed by the environment's a-priori geometry (:func:`observation_scaling`):

* finite bounds ``[lo_j, hi_j]``: ``offset_j = (lo_j + hi_j) / 2``, ``scale_j = (hi_j - lo_j) / 2``
  (so the box maps to ``[-1, 1]``);
* own planar position (unbounded): centre and half-size of the domain, per axis;
* relative positions of the other agents (unbounded): offset 0, half-size of the domain;
* any other unbounded entry: offset 0, scale 1.

Unlike a running normaliser (SB3's ``VecNormalize``) the constants do not change during training
and are stored with the model (they are the ``features_extractor_kwargs`` in ``model.zip``), so
a loaded policy needs nothing else to act.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium
import numpy as np
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

__all__ = ["ScaledObservationExtractor", "observation_scaling"]


def observation_scaling(env: Any) -> tuple[list[float], list[float]]:
    """``(offset, scale)`` lists (length ``obs_dim``) for an information-seeking env.

    Args:
        env: A parallel environment whose ``unwrapped`` has ``observation_layout``, ``space``,
            ``vehicle`` and the (shared) observation space (see the module docstring).

    Returns:
        Two lists of floats, ``scale`` strictly positive.
    """
    base = env.unwrapped
    space = env.observation_space(env.possible_agents[0])
    low = np.asarray(space.low, dtype=np.float64)
    high = np.asarray(space.high, dtype=np.float64)
    finite = np.isfinite(low) & np.isfinite(high) & (high > low)
    offset = np.zeros_like(low)
    scale = np.ones_like(low)
    offset[finite] = 0.5 * (low[finite] + high[finite])
    scale[finite] = 0.5 * (high[finite] - low[finite])

    domain_low = np.asarray(base.space.low, dtype=np.float64)[:2]
    domain_high = np.asarray(base.space.high, dtype=np.float64)[:2]
    centre = 0.5 * (domain_low + domain_high)
    half = 0.5 * (domain_high - domain_low)
    layout = base.observation_layout
    own = layout["own_state"]
    state_names = list(base.vehicle.state_names)
    for axis, name in enumerate(("x", "y")):
        if name in state_names:
            j = own.start + state_names.index(name)
            if not finite[j]:
                offset[j], scale[j] = centre[axis], half[axis]
    others = layout.get("others_relative_positions")
    if others is not None:
        for j in range(others.start, others.stop):
            if not finite[j]:
                offset[j], scale[j] = 0.0, half[(j - others.start) % 2]
    return offset.tolist(), scale.tolist()


class ScaledObservationExtractor(BaseFeaturesExtractor):
    """Features ``(obs - offset) / scale`` of a flat Box observation (no learned parameters).

    Args:
        observation_space: The flat ``Box`` observation space, shape ``(obs_dim,)``.
        offset: ``obs_dim`` offsets.
        scale: ``obs_dim`` strictly positive scales.

    Raises:
        ValueError: wrong lengths or non-positive/non-finite scales.
    """

    def __init__(
        self,
        observation_space: gymnasium.spaces.Box,
        offset: Sequence[float],
        scale: Sequence[float],
    ) -> None:
        n = int(np.prod(observation_space.shape))
        offset_array = np.asarray(offset, dtype=np.float32).reshape(-1)
        scale_array = np.asarray(scale, dtype=np.float32).reshape(-1)
        if offset_array.shape != (n,) or scale_array.shape != (n,):
            raise ValueError(
                f"offset and scale must have {n} entries (the observation size), got "
                f"{offset_array.size} and {scale_array.size}"
            )
        if not np.all(np.isfinite(scale_array) & (scale_array > 0)):
            raise ValueError("scale must be finite and > 0 in every entry")
        super().__init__(observation_space, features_dim=n)
        self.register_buffer("offset", torch.as_tensor(offset_array))
        self.register_buffer("scale", torch.as_tensor(scale_array))

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        """``(batch, obs_dim)`` -> ``(batch, obs_dim)`` scaled features."""
        flat = observations.reshape(observations.shape[0], -1).float()
        return (flat - self.offset) / self.scale
