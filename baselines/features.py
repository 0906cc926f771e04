"""Observation features inside the policy network: fixed scaling and an egocentric view.

The observation of the information-seeking environments mixes positions in distance units
(``0 .. 40`` and beyond: airplanes may leave the domain), angles in ``[-pi, pi]``, belief masses
in ``[0, 1]`` and the MMSE estimate in domain units. Raw positions of order 40 saturate the
``tanh`` units of an MLP, so every observation entry ``o_j`` is mapped to

    x_j = (o_j - offset_j) / scale_j,

with constants fixed by the environment's a-priori geometry (:func:`observation_scaling`):

* own planar position: centre and half-size of the domain, per axis (the observation bound is
  the far larger reachable box, which would squash the domain to a small range);
* relative positions of the other agents: offset 0, half-size of the domain;
* other finite bounds ``[lo_j, hi_j]``: ``offset_j = (lo_j + hi_j) / 2``,
  ``scale_j = (hi_j - lo_j) / 2`` (so the box maps to ``[-1, 1]``);
* any other unbounded entry: offset 0, scale 1.

Unlike a running normaliser (SB3's ``VecNormalize``) the constants do not change during training
and are stored with the model (they are the ``features_extractor_kwargs`` in ``model.zip``), so
a loaded policy needs nothing else to act.

**Egocentric features** (:class:`EgocentricObservationExtractor`, the training default). The
flat observation states positions in the world frame, but what a vehicle should do next depends
on where things are *relative to its own position and heading*: "the estimate is ahead and to
the left", "a team-mate is close on the right". An MLP can learn the rotation
``R(-theta) (p - x)`` from ``(x, y, theta, p)`` only slowly, so the extractor computes it
(no learned parameters) and appends it to the scaled observation. With own position
``x_i``, heading ``theta_i`` (0 for vehicles without a heading), ``R = R(-theta_i)`` and the
domain half-size ``h`` (per axis), the appended entries are

* ``cos theta_i, sin theta_i``;
* the own MMSE estimate ``m_i``: ``R (m_i - x_i) / h`` and ``|m_i - x_i| / |h|``;
* each other vehicle ``j`` (by index): ``R (x_j - x_i) / h`` and ``1 / (1 + |x_j - x_i|)``
  (large when close, the repulsion a team needs to spread its viewpoints);
* the domain centre ``c``: ``R (c - x_i) / h``;
* the spread of the belief-grid masses ``w_k`` at cell centres ``g_k``:
  ``sqrt(sum_k w_k (g_k - gbar)^2) / h`` per axis (``gbar = sum_k w_k g_k``);
* with the environment's ``belief_moments`` block (the belief's covariance ``S`` from
  ``(s_x, s_y, rho)``): the body-frame covariance ``R S R^T`` as ``log(s_f + e)``,
  ``log(s_l + e)`` and its correlation, and, along the line of sight ``u`` to the estimate at
  distance ``r``, ``log(sqrt(u^T S u) + e)``, ``log(sqrt(v^T S v) + e)`` (``v`` perpendicular
  to ``u``) and the angular spread ``log(sqrt(v^T S v) / r + e)`` (``e = 0.01``). Logarithms,
  because what matters after the first readings is whether the belief is 0.1 or 0.5 units
  wide, which a scale of the domain's size cannot show; the angular spread is what decides how
  much a bearing reading can tell (it is small against the noise when the belief is far).

Everything is computed from the observation alone, so the policy sees nothing the environment
does not hand every agent.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium
import numpy as np
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

__all__ = [
    "EgocentricObservationExtractor",
    "ScaledObservationExtractor",
    "egocentric_layout",
    "observation_scaling",
]


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

    domain_low = np.asarray(base.config.space.low, dtype=np.float64)[:2]
    domain_high = np.asarray(base.config.space.high, dtype=np.float64)[:2]
    centre = 0.5 * (domain_low + domain_high)
    half = 0.5 * (domain_high - domain_low)
    layout = base.config.observation_layout
    own = layout["own_state"]
    state_names = list(base.config.vehicle.state_names)
    for axis, name in enumerate(("x", "y")):
        if name in state_names:
            j = own.start + state_names.index(name)
            offset[j], scale[j] = centre[axis], half[axis]
    others = layout.get("others_relative_positions")
    if others is not None:
        for j in range(others.start, others.stop):
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

    offset: torch.Tensor
    scale: torch.Tensor

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


def egocentric_layout(env: Any) -> dict[str, Any]:
    """The observation indices and geometry :class:`EgocentricObservationExtractor` needs.

    Args:
        env: A parallel information-seeking environment (``unwrapped`` has
            ``observation_layout``, ``space``, ``vehicle`` and ``belief_grid``).

    Returns:
        JSON-friendly keywords: ``x_index``, ``y_index``, ``heading_index`` (-1: no heading),
        ``others_start``, ``n_others``, ``grid_start``, ``grid_shape``, ``estimate_start``,
        ``domain_low``, ``domain_high`` (planar ``(2,)`` lists), ``moments_start`` (-1: the
        observation has no ``belief_moments`` block).

    Raises:
        ValueError: The vehicle state has no ``x``/``y`` entries.
    """
    base = env.unwrapped
    layout = base.config.observation_layout
    names = list(base.config.vehicle.state_names)
    if "x" not in names or "y" not in names:
        raise ValueError(f"egocentric features need x and y in the vehicle state, got {names}")
    own = layout["own_state"].start
    heading = names.index("heading") if "heading" in names else -1
    others = layout.get("others_relative_positions", slice(0, 0))
    return {
        "x_index": own + names.index("x"),
        "y_index": own + names.index("y"),
        "heading_index": own + heading if heading >= 0 else -1,
        "others_start": others.start,
        "n_others": (others.stop - others.start) // 2,
        "grid_start": layout["belief_grid"].start,
        "grid_shape": [int(g) for g in base.config.belief_grid],
        "estimate_start": layout["mmse_estimate"].start,
        "domain_low": [float(v) for v in np.asarray(base.config.space.low)[:2]],
        "domain_high": [float(v) for v in np.asarray(base.config.space.high)[:2]],
        "moments_start": layout["belief_moments"].start if "belief_moments" in layout else -1,
    }


class EgocentricObservationExtractor(ScaledObservationExtractor):
    """Scaled observation plus body-frame geometry (module docstring; no learned parameters).

    Args:
        observation_space: The flat ``Box`` observation space, shape ``(obs_dim,)``.
        offset: ``obs_dim`` offsets (:func:`observation_scaling`).
        scale: ``obs_dim`` strictly positive scales.
        layout: :func:`egocentric_layout` of the environment.

    Raises:
        ValueError: wrong lengths, non-positive scales, or layout indices outside the
            observation.
    """

    cell_centres: torch.Tensor
    half_size: torch.Tensor
    half_size_norm: torch.Tensor
    domain_centre: torch.Tensor

    def __init__(
        self,
        observation_space: gymnasium.spaces.Box,
        offset: Sequence[float],
        scale: Sequence[float],
        layout: dict[str, Any],
    ) -> None:
        super().__init__(observation_space, offset, scale)
        n = self._features_dim
        gx, gy = (int(g) for g in layout["grid_shape"])
        n_others = int(layout["n_others"])
        checks = {
            "x_index": int(layout["x_index"]) + 1,
            "y_index": int(layout["y_index"]) + 1,
            "heading_index": int(layout["heading_index"]) + 1,
            "others": int(layout["others_start"]) + 2 * n_others,
            "grid": int(layout["grid_start"]) + gx * gy,
            "estimate": int(layout["estimate_start"]) + 2,
            "moments": int(layout.get("moments_start", -1)) + 4,
        }
        outside = {name: stop for name, stop in checks.items() if stop > n}
        if outside:
            raise ValueError(f"layout entries {sorted(outside)} lie beyond the {n} observations")
        low = np.asarray(layout["domain_low"], dtype=np.float32)
        high = np.asarray(layout["domain_high"], dtype=np.float32)
        if low.shape != (2,) or high.shape != (2,) or not np.all(high > low):
            raise ValueError(f"domain_low/high must be (2,) with high > low, got {low}, {high}")
        self.x_index = int(layout["x_index"])
        self.y_index = int(layout["y_index"])
        self.heading_index = int(layout["heading_index"])
        self.others_start = int(layout["others_start"])
        self.n_others = n_others
        self.grid_start = int(layout["grid_start"])
        self.grid_size = gx * gy
        self.estimate_start = int(layout["estimate_start"])
        self.moments_start = int(layout.get("moments_start", -1))
        # cell centres of the x-slowest flat grid, (gx * gy, 2)
        cx = low[0] + (np.arange(gx, dtype=np.float32) + 0.5) * (high[0] - low[0]) / gx
        cy = low[1] + (np.arange(gy, dtype=np.float32) + 0.5) * (high[1] - low[1]) / gy
        centres = np.stack(np.meshgrid(cx, cy, indexing="ij"), axis=-1).reshape(-1, 2)
        self.register_buffer("cell_centres", torch.as_tensor(centres))
        self.register_buffer("half_size", torch.as_tensor(0.5 * (high - low)))
        self.register_buffer("domain_centre", torch.as_tensor(0.5 * (high + low)))
        # not stored in model.zip: derived from half_size as the forward pass once did
        self.register_buffer(
            "half_size_norm", torch.linalg.vector_norm(self.half_size), persistent=False
        )
        self._features_dim = n + 2 + 3 + 3 * n_others + 2 + 2
        if self.moments_start >= 0:
            self._features_dim += len(MOMENT_FEATURES)

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        """``(batch, obs_dim)`` -> ``(batch, features_dim)``.

        Every vector is rotated in one pass and every square root taken in one: elementwise
        arithmetic gives each entry the same bits whichever tensor it sits in, and the fewer
        torch calls are what a policy's decision time is made of (a few microseconds each).
        """
        flat = observations.reshape(observations.shape[0], -1).float()
        scaled = (flat - self.offset) / self.scale
        if self.y_index == self.x_index + 1:
            position = flat[:, self.x_index : self.x_index + 2]  # (B, 2)
        else:
            position = flat[:, [self.x_index, self.y_index]]
        if self.heading_index >= 0:
            heading = flat[:, self.heading_index]
        else:
            heading = torch.zeros_like(flat[:, 0])
        cos, sin = torch.cos(heading), torch.sin(heading)
        to_estimate = flat[:, self.estimate_start : self.estimate_start + 2] - position
        others = flat[:, self.others_start : self.others_start + 2 * self.n_others]
        others = others.reshape(-1, self.n_others, 2)
        distance = torch.linalg.vector_norm(to_estimate, dim=1)
        proximity = 1.0 / (1.0 + torch.linalg.vector_norm(others, dim=-1))
        masses = flat[:, self.grid_start : self.grid_start + self.grid_size]
        masses = masses / masses.sum(dim=1, keepdim=True).clamp_min(1e-12)
        mean = masses @ self.cell_centres  # (B, 2)
        deviations = self.cell_centres[None, :, :] - mean[:, None, :]  # (B, cells, 2)
        variance = (masses[:, :, None] * deviations**2).sum(dim=1)
        # world-frame (B, n_others + 2, 2) -> body frame, divided by the half-size
        vectors = torch.cat(
            [to_estimate[:, None], others, (self.domain_centre - position)[:, None]], dim=1
        )
        c, s = cos[:, None], sin[:, None]
        along_x, along_y = vectors.unbind(-1)
        forward = c * along_x + s * along_y
        left = -s * along_x + c * along_y
        body = torch.stack([forward, left], dim=-1) / self.half_size
        parts = [
            scaled,
            torch.stack([cos, sin], dim=1),
            body[:, 0],
            (distance / self.half_size_norm)[:, None],
            body[:, 1:-1].reshape(-1, 2 * self.n_others),
            proximity,
            body[:, -1],
        ]
        if self.moments_start < 0:
            parts.append(_sqrt(variance) / self.half_size)
            return torch.cat(parts, dim=1)
        moments = flat[:, self.moments_start : self.moments_start + 3]
        spread, covariance = _covariance_features(moments, c, s, to_estimate, distance, variance)
        parts.append(spread / self.half_size)
        parts.append(covariance)
        return torch.cat(parts, dim=1)


def _sqrt(values: torch.Tensor) -> torch.Tensor:
    """The square root of float32 ``values``, taken in float64 and rounded to float32: the
    correctly rounded value wherever the float64 root is (float64 has more than twice
    float32's digits, so the second rounding is exact). torch's float32 ``sqrt`` on the CPU
    goes through MKL's vector library, whose last bits depend on the CPU
    (``docs/development.md``), so a policy would act differently on different machines."""
    return torch.sqrt(values.double()).to(values.dtype)


#: Names of the features :func:`_covariance_features` appends (module docstring).
MOMENT_FEATURES = (
    "log_spread_forward",
    "log_spread_left",
    "body_correlation",
    "log_spread_line_of_sight",
    "log_spread_across",
    "log_angular_spread",
)
_EPSILON = 0.01


def _covariance_features(
    moments: torch.Tensor,
    cos: torch.Tensor,
    sin: torch.Tensor,
    to_estimate: torch.Tensor,
    distance: torch.Tensor,
    variance: torch.Tensor,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The grid's ``(B, 2)`` standard deviations ``sqrt(variance)`` and the ``(B, 6)``
    :data:`MOMENT_FEATURES` from ``(B, 3)`` ``(s_x, s_y, rho)``, the heading's ``(B, 1)``
    ``cos``/``sin``, the ``(B, 2)`` world-frame offset to the estimate and its length
    ``distance``.

    The four quadratic forms share one pass over stacked directions, all seven square roots
    one :func:`_sqrt` and the five logarithms one ``torch.log``; each entry gets the bits it
    would get alone (``tests/test_baselines.py`` checks that torch's float32 logarithm of an
    element does not depend on its neighbours)."""
    sx, sy, rho = moments[:, 0:1], moments[:, 1:2], moments[:, 2:3]
    cxx, cyy, cxy = sx * sx, sy * sy, rho * sx * sy
    distance = distance.clamp_min(1e-6)[:, None]
    unit = to_estimate / distance  # along the line of sight
    ux, uy = unit[:, 0:1], unit[:, 1:2]
    # directions (B, 4): forward, left, line of sight, across it
    dx = torch.cat([cos, -sin, ux, -uy], dim=1)
    dy = torch.cat([sin, cos, uy, ux], dim=1)
    quadratic = (dx * dx * cxx + 2.0 * dx * dy * cxy + dy * dy * cyy).clamp_min(0.0)
    mixed = -cos * sin * cxx + (cos * cos - sin * sin) * cxy + sin * cos * cyy
    product = quadratic[:, 0:1] * quadratic[:, 1:2]  # forward x left
    roots = _sqrt(torch.cat([variance, quadratic, product], dim=1))
    correlation = (mixed / roots[:, 6:7].clamp_min(1e-12)).clamp(-1.0, 1.0)
    # spreads forward, left, along and across the line of sight, angular spread
    spreads = torch.cat([roots[:, 2:6], roots[:, 5:6] / distance], dim=1)
    logs = torch.log(spreads + _EPSILON)
    return roots[:, :2], torch.cat([logs[:, :2], correlation, logs[:, 2:]], dim=1)
