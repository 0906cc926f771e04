r"""Utility functions of the information-seeking planners (section III.C).

For vehicle ``i`` with next poses ``x^{(1)}, ..., x^{(n_v)}`` of all vehicles:

* single-node approximation (Proposition 1, eq. 20): :math:`V_s^{(i)} = I(z^{(i)}; \theta)`;
* pairwise-node approximation (Proposition 2, eq. 22, ``n_v >= 2``):
  :math:`V_p^{(i)} = (2 - n_v) I(z^{(i)}; \theta) + \sum_{j \ne i} I(z^{(i)}, z^{(j)}; \theta)`;
* the exact joint utility (eq. 10): :math:`I(z^{(1)}, \dots, z^{(n_v)}; \theta)`, feasible for
  small ``n_v`` (on a grid for ``n_v <= 3``, by Monte Carlo beyond).

Every function takes the belief as any object with ``.particles`` ``(N, d)`` and ``.weights``
``(N,)`` (e.g. :class:`infoseek.envs.belief.BeliefView`), or an already bound
:class:`~infoseek.planners.information.BeliefMI`, and forwards keyword options (``method``,
``n_points``, ``edges``, ``n_samples``, ``rng``) to
:func:`~infoseek.planners.information.make_estimator`. Each call binds the belief to one
estimator once, so all terms of a utility come from one estimator at one resolution and share
its per-pose work. The batched forms score ``C`` candidate next poses of one vehicle at once,
with the other vehicles' next poses held fixed.

:func:`subsample_particles` reduces a belief to a smaller, equally weighted planning set by
systematic (low-variance) resampling.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information import BeliefMI, make_estimator

FloatArray = NDArray[np.float64]

__all__ = [
    "BeliefLike",
    "bind_belief",
    "single_node_utility",
    "pairwise_node_utility",
    "joint_utility",
    "single_node_utilities",
    "pairwise_node_utilities",
    "joint_utilities",
    "subsample_particles",
    "PlanningBelief",
]


class BeliefLike(Protocol):
    """Anything carrying a weighted particle set."""

    @property
    def particles(self) -> FloatArray: ...

    @property
    def weights(self) -> FloatArray: ...


class PlanningBelief:
    """A plain weighted particle set (what :func:`subsample_particles` returns).

    Attributes:
        particles: ``(n, d)`` particles.
        weights: ``(n,)`` normalised weights.
    """

    def __init__(self, particles: FloatArray, weights: FloatArray) -> None:
        self.particles = particles
        self.weights = weights

    def __repr__(self) -> str:
        return f"PlanningBelief(n_particles={self.particles.shape[0]})"


def _belief_arrays(belief: BeliefLike) -> tuple[FloatArray, FloatArray]:
    try:
        particles = np.asarray(belief.particles, dtype=np.float64)
        weights = np.asarray(belief.weights, dtype=np.float64)
    except AttributeError as error:
        raise TypeError(
            f"belief must have .particles (N, d) and .weights (N,), got {type(belief).__name__}"
        ) from error
    return particles, weights


def bind_belief(
    belief: BeliefLike | BeliefMI, sensor: Sensor, n_observations: int, **options: Any
) -> BeliefMI:
    """``belief`` bound to the estimator that ``options`` name (``method``, default ``"auto"``).

    A :class:`~infoseek.planners.information.BeliefMI` is returned as it is (then ``options``
    must be empty).
    """
    if isinstance(belief, BeliefMI):
        if options:
            raise TypeError(f"options {sorted(options)} cannot be applied to a bound BeliefMI")
        return belief
    particles, weights = _belief_arrays(belief)
    method = options.pop("method", "auto")
    estimator = make_estimator(method, sensor, n_observations=n_observations, **options)
    estimator.check_observations(n_observations)
    return estimator.bind(particles, weights)


def _next_poses(sensor: Sensor, next_poses: Any, agent_index: int) -> FloatArray:
    poses = np.asarray(next_poses, dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] != sensor.pose_dim or poses.shape[0] == 0:
        raise ValueError(
            f"next_poses must have shape (n_v, {sensor.pose_dim}) with n_v >= 1, got {poses.shape}"
        )
    if isinstance(agent_index, bool) or not isinstance(agent_index, int | np.integer):
        raise TypeError(f"agent_index must be an int, got {type(agent_index).__name__}")
    if not 0 <= agent_index < poses.shape[0]:
        raise ValueError(f"agent_index must be in [0, {poses.shape[0]}), got {agent_index}")
    return poses


def _candidates(sensor: Sensor, poses: Any, name: str) -> FloatArray:
    poses = np.asarray(poses, dtype=np.float64)
    if poses.ndim != 2 or poses.shape[1] != sensor.pose_dim or poses.shape[0] == 0:
        raise ValueError(
            f"{name} must have shape (C, {sensor.pose_dim}) with C >= 1, got {poses.shape}"
        )
    return poses


def _others(sensor: Sensor, poses: Any) -> FloatArray:
    poses = np.asarray(poses, dtype=np.float64)
    if poses.ndim == 1 and poses.size == 0:
        poses = poses.reshape(0, sensor.pose_dim)
    if poses.ndim != 2 or poses.shape[1] != sensor.pose_dim:
        raise ValueError(
            f"other_poses must have shape (n_v - 1, {sensor.pose_dim}), got {poses.shape}"
        )
    return poses


def single_node_utility(
    belief: BeliefLike, sensor: Sensor, next_poses: Any, agent_index: int, **options: Any
) -> float:
    """Single-node utility ``V_s = I(z_i; theta)`` (eq. 20).

    Args:
        belief: Object with ``.particles`` ``(N, d)`` and ``.weights`` ``(N,)``.
        sensor: The shared sensor model.
        next_poses: ``(n_v, pose_dim)`` next poses of all vehicles.
        agent_index: ``i``, the vehicle whose utility is evaluated.
        **options: Estimator options (:func:`bind_belief`).

    Returns:
        The utility in nats.
    """
    poses = _next_poses(sensor, next_poses, agent_index)
    bound = bind_belief(belief, sensor, 1, **options)
    return float(bound.single(poses[agent_index : agent_index + 1])[0])


def pairwise_node_utility(
    belief: BeliefLike, sensor: Sensor, next_poses: Any, agent_index: int, **options: Any
) -> float:
    """Pairwise-node utility ``V_p = (2 - n_v) I(z_i) + sum_{j != i} I(z_i, z_j)`` (eq. 22).

    Args:
        belief: Object with ``.particles`` and ``.weights``.
        sensor: The shared sensor model.
        next_poses: ``(n_v, pose_dim)`` next poses of all vehicles, ``n_v >= 2``.
        agent_index: ``i``.
        **options: Estimator options (:func:`bind_belief`).

    Returns:
        The utility in nats (equals the exact joint MI when ``n_v == 2``).

    Raises:
        ValueError: If ``n_v < 2`` (the approximation is defined for ``n_v >= 2``).
    """
    poses = _next_poses(sensor, next_poses, agent_index)
    if poses.shape[0] < 2:
        raise ValueError(
            f"pairwise_node_utility needs n_v >= 2 vehicles, got n_v={poses.shape[0]}; "
            "use single_node_utility for a single vehicle"
        )
    others = np.delete(poses, agent_index, axis=0)
    values = pairwise_node_utilities(
        belief, sensor, poses[agent_index : agent_index + 1], others, **options
    )
    return float(values[0])


def joint_utility(
    belief: BeliefLike,
    sensor: Sensor,
    next_poses: Any,
    agent_index: int | None = None,
    **options: Any,
) -> float:
    """Exact joint utility ``I(z_1, ..., z_{n_v}; theta)`` (eq. 10).

    Computed on a grid for ``n_v <= 3`` and by Monte Carlo beyond (then ``rng`` is required;
    see :func:`~infoseek.planners.information.mutual_information`).

    Args:
        belief: Object with ``.particles`` and ``.weights``.
        sensor: The shared sensor model.
        next_poses: ``(n_v, pose_dim)`` next poses of all vehicles.
        agent_index: Accepted for a uniform signature; the joint utility is the same for every
            vehicle (checked for range if given).
        **options: Estimator options (:func:`bind_belief`).

    Returns:
        The utility in nats.
    """
    poses = _next_poses(sensor, next_poses, 0 if agent_index is None else agent_index)
    bound = bind_belief(belief, sensor, poses.shape[0], **options)
    return float(bound.joint(poses[None])[0])


def single_node_utilities(
    belief: BeliefLike, sensor: Sensor, candidate_poses: Any, **options: Any
) -> FloatArray:
    """Single-node utilities for ``C`` candidate next poses of one vehicle.

    Args:
        belief: Object with ``.particles`` and ``.weights``.
        sensor: The shared sensor model.
        candidate_poses: ``(C, pose_dim)`` candidate next poses.
        **options: Estimator options (:func:`bind_belief`).

    Returns:
        ``(C,)`` utilities ``I(z_c; theta)`` in nats.
    """
    candidates = _candidates(sensor, candidate_poses, "candidate_poses")
    return bind_belief(belief, sensor, 1, **options).single(candidates)


def pairwise_node_utilities(
    belief: BeliefLike,
    sensor: Sensor,
    candidate_poses: Any,
    other_poses: Any,
    **options: Any,
) -> FloatArray:
    """Pairwise-node utilities (eq. 22) for ``C`` candidate next poses of one vehicle.

    ``V_p(c) = (2 - n_v) I(z_c) + sum_j I(z_c, z_j)`` with ``n_v = M + 1``; all ``C`` single
    MIs and ``C * M`` pair MIs are evaluated in two batched calls, the partners' per-pose work
    computed once.

    Args:
        belief: Object with ``.particles`` and ``.weights``.
        sensor: The shared sensor model.
        candidate_poses: ``(C, pose_dim)`` candidate next poses of vehicle ``i``.
        other_poses: ``(M, pose_dim)`` next poses of the other ``M = n_v - 1 >= 1`` vehicles.
        **options: Estimator options (:func:`bind_belief`).

    Returns:
        ``(C,)`` utilities in nats.

    Raises:
        ValueError: If ``M == 0`` (``n_v < 2``).
    """
    candidates = _candidates(sensor, candidate_poses, "candidate_poses")
    others = _others(sensor, other_poses)
    n_vehicles = others.shape[0] + 1
    if n_vehicles < 2:
        raise ValueError(
            "pairwise_node_utilities needs n_v >= 2 (other_poses with at least one row); "
            "use single_node_utilities for a single vehicle"
        )
    bound = bind_belief(belief, sensor, 2, **options)
    pairs = bound.pairs(candidates, others)
    if n_vehicles == 2:
        return pairs[:, 0].copy()
    return (2 - n_vehicles) * bound.single(candidates) + pairs.sum(axis=1)


def joint_utilities(
    belief: BeliefLike,
    sensor: Sensor,
    candidate_poses: Any,
    other_poses: Any,
    **options: Any,
) -> FloatArray:
    """Exact joint utilities for ``C`` candidate next poses of one vehicle.

    Args:
        belief: Object with ``.particles`` and ``.weights``.
        sensor: The shared sensor model.
        candidate_poses: ``(C, pose_dim)`` candidate next poses.
        other_poses: ``(M, pose_dim)`` next poses of the other vehicles (``M`` may be 0).
        **options: Estimator options (:func:`bind_belief`).

    Returns:
        ``(C,)`` values of ``I(z_c, z_1, ..., z_M; theta)`` in nats.
    """
    candidates = _candidates(sensor, candidate_poses, "candidate_poses")
    others = _others(sensor, other_poses)
    bound = bind_belief(belief, sensor, others.shape[0] + 1, **options)
    sets = np.concatenate(
        [candidates[:, None, :], np.broadcast_to(others, (candidates.shape[0],) + others.shape)],
        axis=1,
    )
    return bound.joint(sets)


def subsample_particles(
    belief: BeliefLike, n_planning: int, rng: np.random.Generator
) -> PlanningBelief:
    """Systematic resampling down to ``n_planning`` equally weighted planning particles.

    The low-variance sampler: one uniform offset ``u ~ U[0, 1/n)``, pointers ``u + m / n``
    into the cumulative weights. If the belief has at most ``n_planning`` particles it is
    returned unchanged (as a :class:`PlanningBelief` with normalised weights).

    Args:
        belief: Object with ``.particles`` ``(N, d)`` and ``.weights`` ``(N,)``.
        n_planning: Number of planning particles, ``>= 1``.
        rng: Source of the offset.

    Returns:
        A :class:`PlanningBelief` with ``min(N, n_planning)`` particles.
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if isinstance(n_planning, bool) or int(n_planning) != n_planning or n_planning < 1:
        raise ValueError(f"n_planning must be an integer >= 1, got {n_planning}")
    particles, weights = _belief_arrays(belief)
    if weights.shape != (particles.shape[0],) or not np.isfinite(weights).all():
        raise ValueError("belief.weights must be a finite (N,) array matching belief.particles")
    if (weights < 0).any() or not weights.sum() > 0:
        raise ValueError("belief.weights must be non-negative with a positive sum")
    weights = weights / weights.sum()
    n_planning = int(n_planning)
    if particles.shape[0] <= n_planning:
        return PlanningBelief(particles.copy(), weights.copy())
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0
    pointers = (rng.random() + np.arange(n_planning)) / n_planning
    index = np.minimum(np.searchsorted(cumulative, pointers, side="right"), particles.shape[0] - 1)
    return PlanningBelief(particles[index].copy(), np.full(n_planning, 1.0 / n_planning))
