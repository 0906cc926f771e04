r"""Mutual information between a particle belief and future observations (section III.B).

The planners score candidate sensor poses by the mutual information (eq. 9)

.. math::  I(z; \theta) = H(z) - H(z \mid \theta)

between the target state :math:`\theta` and the observations :math:`z = (z^{(1)}, \dots,
z^{(k)})` that sensors at the ``k`` given poses would make next. With the particle belief
:math:`\sum_n w_n \delta(\theta - \theta_n)` (eq. 11) and conditionally independent
observations, the observation density is the particle mixture (eq. 15)

.. math::  p(z) = \sum_n w_n \prod_j p(z^{(j)} \mid \theta_n),

:math:`H(z) = -\int p \log p` (eq. 16) and :math:`H(z \mid \theta) = \sum_n w_n \sum_j
H(z^{(j)} \mid \theta_n)` (eq. 19; the double sum follows from conditional independence).

Estimators (one class per module, all behind :class:`~infoseek.planners.information.base.
MIEstimator`, registered in :data:`ESTIMATORS`):

=================  ===============================================  ============================
name               serves                                           method
=================  ===============================================  ============================
``"fft"``          additive-noise sensors (bearing, range)          histograms + FFT, windows
``"fourier"``      shift-kernel sensors (beacon, bearing)           Fourier-synthesised channels
``"quadrature"``   every sensor with a 1-D observation              likelihoods on nodes
``"quantised"``    sensors with ``bin_probabilities``               exact binned MI (lower bound)
``"monte_carlo"``  every sensor, any ``k``                          sampling, with stderr
=================  ===============================================  ============================

``method="auto"`` takes the first of ``fft``, ``fourier``, ``quadrature`` that serves the
sensor and ``k``, and ``monte_carlo`` beyond ``k = 3`` (which then needs ``rng``). For a sensor
whose kernels can be sharper than any practical grid (the exact ``BeaconSensor``, SNR
unbounded) ``fourier`` resolves them when given ``rng``: the grid over the particles it
resolves plus a Monte Carlo remainder over the sharp ones, unbiased, with its standard error
(:mod:`~infoseek.planners.information.sharp_remainder`). Without ``rng`` it returns the MI of
the receiver with its SNR capped at ``max_shape`` (64), a lower bound, marked
(``MIEstimate.lower_bound``, ``unresolved_mass``) and warned about (``MILowerBoundWarning``),
never silently. Sensors bounded by the grid (the filters' floored beacon, bearings) give the
same values with or without ``rng`` and never draw from it. Every grid
estimator uses one grid for ``k = 1`` and ``k = 2``, so the terms of a utility (eq. 20, 22)
share one resolution.

Use an estimator directly for repeated evaluations on one belief (a planner does)::

    estimator = make_estimator("auto", sensor)
    mi = estimator.bind(particles, weights)        # a BeliefMI: validated once, caches per pose
    singles = mi.single(candidate_poses)            # (C,)
    pairs = mi.pairs(candidate_poses, other_poses)  # (C, M)

or the functions :func:`mutual_information`, :func:`mutual_information_batch` and
:func:`pairwise_mutual_information` for one-off calls. A new estimator is one module with one
:class:`MIEstimator` subclass plus ``ESTIMATORS.register(name, cls)``; the shared test suite
(``tests/test_estimators.py``) runs every registered estimator against references.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from infoseek.envs.registries import Registry
from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information.base import (
    BeliefMI,
    FloatArray,
    JointEntropies,
    MIEstimate,
    MIEstimator,
    MILowerBoundWarning,
    check_poses,
)
from infoseek.planners.information.fft import AdditiveFFTEstimator
from infoseek.planners.information.fourier import ShiftKernelEstimator
from infoseek.planners.information.monte_carlo import MonteCarloEstimator
from infoseek.planners.information.noise_kernel import noise_std
from infoseek.planners.information.quadrature import QuadratureEstimator, observation_nodes
from infoseek.planners.information.quantised import QuantisedEstimator, uniform_bin_edges

__all__ = [
    "ESTIMATORS",
    "MAX_GRID_OBSERVATIONS",
    "METHODS",
    "BeliefMI",
    "JointEntropies",
    "MIEstimate",
    "MIEstimator",
    "MILowerBoundWarning",
    "make_estimator",
    "mutual_information",
    "mutual_information_batch",
    "noise_std",
    "observation_nodes",
    "pairwise_mutual_information",
    "select_method",
    "uniform_bin_edges",
]

#: Registry name -> estimator class.
ESTIMATORS: Registry[type[MIEstimator]] = Registry("MI estimator", MIEstimator)
for _cls in (
    AdditiveFFTEstimator,
    ShiftKernelEstimator,
    QuadratureEstimator,
    QuantisedEstimator,
    MonteCarloEstimator,
):
    ESTIMATORS.register(_cls.name, _cls)

#: Estimators ``method="auto"`` tries, in order.
AUTO_ORDER: tuple[str, ...] = ("fft", "fourier", "quadrature", "monte_carlo")

#: Largest ``k`` handled on a grid; larger ``k`` needs Monte Carlo.
MAX_GRID_OBSERVATIONS = 3


def methods() -> tuple[str, ...]:
    """Names accepted by ``method=``: ``"auto"`` and every registered estimator."""
    return ("auto", *ESTIMATORS)


#: Names accepted by ``method=`` when this module was imported (see :func:`methods`).
METHODS: tuple[str, ...] = methods()


def select_method(sensor: Sensor, n_observations: int) -> str:
    """The estimator ``method="auto"`` uses for ``n_observations`` joint observations.

    Returns:
        The first of :data:`AUTO_ORDER` that serves ``sensor`` and ``n_observations``.
    """
    if isinstance(n_observations, bool) or int(n_observations) != n_observations:
        raise ValueError(f"n_observations must be an integer >= 1, got {n_observations!r}")
    if n_observations < 1:
        raise ValueError(f"n_observations must be >= 1, got {n_observations}")
    for name in AUTO_ORDER:
        if ESTIMATORS[name].serves(sensor, n_observations):
            return name
    raise TypeError(f"no MI estimator serves {type(sensor).__name__} (k={n_observations})")


def make_estimator(
    method: str,
    sensor: Sensor,
    *,
    n_observations: int = 1,
    **options: Any,
) -> MIEstimator:
    """Build an estimator by name for ``sensor``.

    Args:
        method: ``"auto"`` or a name in :data:`ESTIMATORS`.
        sensor: The sensor model.
        n_observations: Largest ``k`` the caller will ask for (used by ``"auto"``).
        **options: Estimator options (``n_points``, ``edges``, ``max_shape``, ``n_samples``,
            ``rng``); each estimator takes those in its ``options`` and ignores the rest.

    Raises:
        ValueError: Unknown ``method`` (the message lists the valid names) or a bad option.
        TypeError: The estimator needs a sensor method the sensor lacks (the message names it).
    """
    if not isinstance(method, str) or (method != "auto" and method not in ESTIMATORS):
        raise ValueError(f"method must be one of {list(methods())}, got {method!r}")
    name = select_method(sensor, n_observations) if method == "auto" else method
    cls = ESTIMATORS[name]
    accepted = {key: value for key, value in options.items() if key in cls.options}
    return cls(sensor, **accepted)


def _options(
    n_points: int | None,
    edges: Any,
    n_samples: int,
    max_shape: float | None,
    rng: np.random.Generator | None,
) -> dict[str, Any]:
    """The estimator options of the public functions (``None``: the estimator's default)."""
    options = {"n_points": n_points, "edges": edges, "n_samples": n_samples, "rng": rng}
    return options if max_shape is None else {**options, "max_shape": max_shape}


def _estimate(
    sensor: Sensor,
    pose_sets: FloatArray,
    particles: Any,
    weights: Any,
    method: str,
    options: dict[str, Any],
) -> tuple[JointEntropies, MIEstimator, FloatArray]:
    """The joint entropies of ``pose_sets``, the estimator, and the ``(C,)`` unresolved mass
    (warned about when positive)."""
    k = pose_sets.shape[1]
    estimator = make_estimator(method, sensor, n_observations=k, **options)
    estimator.check_observations(k)
    belief = estimator.bind(particles, weights)
    result = belief.joint_entropies(pose_sets)
    unresolved = estimator.unresolved_mass(belief, pose_sets)
    _warn_if_bounded(estimator, unresolved, stacklevel=3)  # the public function's caller
    return result, estimator, unresolved


def _warn_if_bounded(estimator: MIEstimator, unresolved: FloatArray, stacklevel: int) -> None:
    """An :class:`MILowerBoundWarning` when some particle's likelihood was not resolved,
    attributed ``stacklevel`` frames up (the public function's caller)."""
    worst = float(np.max(unresolved, initial=0.0))
    if worst > 0.0:
        warnings.warn(
            f"MI estimator {estimator.name!r} did not resolve the likelihood of particles "
            f"holding up to {worst:.3g} of the belief's weight (kernels sharper than its "
            "max_shape option): the value is a lower bound of the exact MI. Pass "
            "rng=numpy.random.Generator to resolve them (a Monte Carlo remainder with its "
            "standard error), or raise max_shape.",
            MILowerBoundWarning,
            stacklevel=stacklevel + 1,
        )


def mutual_information(
    sensor: Sensor,
    poses: Any,
    particles: Any,
    weights: Any,
    *,
    method: str = "auto",
    n_points: int | None = None,
    edges: Any | None = None,
    n_samples: int = 4096,
    max_shape: float | None = None,
    rng: np.random.Generator | None = None,
) -> MIEstimate:
    """Joint MI (nats) between the target and the observations of sensors at ``poses``.

    Implements eq. 9 with the particle mixture of eq. 15 and the entropies of eq. 16 and 19.

    Args:
        sensor: The sensor model shared by all vehicles.
        poses: ``(k, pose_dim)`` poses of the ``k`` sensors observing jointly.
        particles: ``(N, target_dim)`` belief particles.
        weights: ``(N,)`` non-negative particle weights (normalised here).
        method: ``"auto"`` (default) or an estimator name (module docstring).
        n_points: Grid size per observation of the grid estimators (default: each
            estimator's own).
        edges: ``(Q + 1,)`` increasing bin edges for ``"quantised"`` (overrides ``n_points``).
        n_samples: Monte Carlo sample size (default 4096).
        max_shape: Largest kernel shape ``"fourier"``'s grid resolves (default: the sensor's
            bound, or 64 for an unbounded one such as the exact beacon receiver); particles
            beyond it go to the Monte Carlo remainder when ``rng`` is given, else make the
            value a lower bound, which is then marked and warned about.
        rng: Generator for ``"monte_carlo"`` (required there) and for ``"fourier"``'s
            remainder beyond ``max_shape`` (without it: the marked lower bound); never drawn
            from where the grid resolves every particle.

    Returns:
        An :class:`MIEstimate` (a ``float``) with ``stderr``, ``method`` and ``lower_bound``.

    Warns:
        MILowerBoundWarning: The value is only a lower bound because the estimator did not
            resolve every particle's likelihood (``unresolved_mass`` says how much weight;
            for the exact beacon: pass ``rng``).

    Raises:
        ValueError: On malformed inputs, an unknown method, or Monte Carlo without ``rng``.
        TypeError: If a forced method needs an interface the sensor lacks.
    """
    poses = check_poses(sensor, poses, "poses", "(k, pose_dim)")
    options = _options(n_points, edges, n_samples, max_shape, rng)
    result, estimator, unresolved = _estimate(
        sensor, poses[None], particles, weights, method, options
    )
    return _set_estimate(result, estimator, unresolved, 0)


def _set_estimate(
    result: JointEntropies, estimator: MIEstimator, unresolved: FloatArray, index: int
) -> MIEstimate:
    """The :class:`MIEstimate` of pose set ``index`` of ``result`` (by ``estimator``, with the
    ``unresolved`` mass of each set)."""
    return MIEstimate(
        result.values[index],
        result.stderrs[index],
        estimator.name,
        result.entropy[index],
        result.conditional[index],
        unresolved_mass=unresolved[index],
        lower_bound=estimator.lower_bound,
    )


def mutual_information_batch(
    sensor: Sensor,
    poses: Any,
    particles: Any,
    weights: Any,
    *,
    method: str = "auto",
    n_points: int | None = None,
    edges: Any | None = None,
    n_samples: int = 4096,
    max_shape: float | None = None,
    rng: np.random.Generator | None = None,
    return_stderr: bool = False,
) -> FloatArray | tuple[FloatArray, FloatArray]:
    """:func:`mutual_information` for ``C`` candidate pose sets at once.

    Args:
        sensor: The sensor model.
        poses: ``(C, k, pose_dim)`` candidate pose sets.
        particles: ``(N, target_dim)`` belief particles.
        weights: ``(N,)`` particle weights.
        method, n_points, edges, n_samples, max_shape, rng: As in :func:`mutual_information`.
        return_stderr: Also return the ``(C,)`` standard errors.

    Returns:
        ``(C,)`` MI values in nats, or ``(values, stderrs)`` if ``return_stderr``.

    Warns:
        MILowerBoundWarning: As in :func:`mutual_information`, for any of the ``C`` sets.
    """
    poses = check_poses(sensor, poses, "poses", "(C, k, pose_dim)")
    options = _options(n_points, edges, n_samples, max_shape, rng)
    result, _, _ = _estimate(sensor, poses, particles, weights, method, options)
    return (result.values, result.stderrs) if return_stderr else result.values


def pairwise_mutual_information(
    sensor: Sensor,
    poses_a: Any,
    poses_b: Any,
    particles: Any,
    weights: Any,
    *,
    method: str = "auto",
    n_points: int | None = None,
    edges: Any | None = None,
    n_samples: int = 4096,
    max_shape: float | None = None,
    rng: np.random.Generator | None = None,
) -> FloatArray:
    """Pair MIs ``I(z_a, z_b; theta)`` for every pose in ``poses_a`` with every one in ``poses_b``.

    The per-pose work is done once for each of the ``C + M`` poses and reused across all
    ``C * M`` pairs.

    Args:
        sensor: The sensor model.
        poses_a: ``(C, pose_dim)`` poses (e.g. one agent's candidate next poses).
        poses_b: ``(M, pose_dim)`` poses (e.g. the other agents' planned next poses).
        particles: ``(N, target_dim)`` belief particles.
        weights: ``(N,)`` particle weights.
        method, n_points, edges, n_samples, max_shape, rng: As in :func:`mutual_information`
            (``k = 2``).

    Returns:
        ``(C, M)`` MI values in nats.

    Warns:
        MILowerBoundWarning: As in :func:`mutual_information`, for any of the ``C * M`` pairs.
    """
    options = _options(n_points, edges, n_samples, max_shape, rng)
    estimator = make_estimator(method, sensor, n_observations=2, **options)
    belief = estimator.bind(particles, weights)
    values = belief.pairs(poses_a, poses_b)
    # weight unresolved at a or at b: w(a) + w(b) - w(a and b), from the C + M poses alone
    a = estimator.unresolved(belief, check_poses(sensor, poses_a, "poses_a", "(C, pose_dim)"))
    b = estimator.unresolved(belief, check_poses(sensor, poses_b, "poses_b", "(M, pose_dim)"))
    w = belief.weights
    unresolved = (a @ w)[:, None] + (b @ w)[None, :] - (a * w) @ b.T.astype(np.float64)
    _warn_if_bounded(estimator, unresolved, 2)
    return values
