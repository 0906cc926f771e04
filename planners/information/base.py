r"""The mutual-information estimator interface.

An estimator computes :math:`I(z^{(1)}, \dots, z^{(k)}; \theta) = H(z) - H(z \mid \theta)`
(eq. 9) for sensors at ``k`` poses observing a target whose belief is a weighted particle set
(eq. 11, 15, 16, 19). Every estimator is one subclass of :class:`MIEstimator`:

* class attributes say what it needs: :attr:`MIEstimator.name` (its registry name),
  :attr:`~MIEstimator.required_methods` (sensor methods besides the :class:`Sensor` protocol),
  :attr:`~MIEstimator.max_observations`, :attr:`~MIEstimator.periodic_only`,
  :attr:`~MIEstimator.options` (the keyword options :func:`make_estimator` forwards);
* it implements :meth:`~MIEstimator.joint` for ``(C, k, pose_dim)`` pose sets and may override
  :meth:`~MIEstimator.singles` and :meth:`~MIEstimator.pairs` with faster batched forms.

Estimators are used through :meth:`MIEstimator.bind`, which validates a belief once and returns
a :class:`BeliefMI`: the estimator applied to that belief, holding a cache of per-pose work
(noise-free predictions, stencils, likelihood channels) that repeated calls on the same belief
share. A planner owns one :class:`BeliefMI` per vehicle and step, so the cache lives exactly as
long as the belief it describes.

Every term of a utility is computed at one resolution: an estimator's grid does not depend on
``k`` for ``k <= 2`` (single and pair terms of eq. 22 live on the same grid), so
``I(z_a, z_a) >= I(z_a)`` and the chain rule hold for the discretised channels exactly.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor

FloatArray = NDArray[np.float64]

__all__ = [
    "BeliefMI",
    "FloatArray",
    "JointEntropies",
    "MIEstimate",
    "MIEstimator",
    "MILowerBoundWarning",
    "check_belief",
    "check_poses",
    "single_many",
]

#: Bytes of per-pose work one :class:`BeliefMI` keeps before it forgets the oldest half.
CACHE_BYTES = 256 << 20


class MILowerBoundWarning(UserWarning):
    """A mutual-information value is only a lower bound of the exact MI (the estimator did not
    resolve every particle's likelihood); the message says how much weight and what to do."""


class MIEstimate(float):
    """A mutual-information value in nats, usable as a ``float``.

    Attributes:
        stderr: Standard error of the estimate (``0.0`` for deterministic estimators).
        method: Registry name of the estimator that produced the value.
        entropy: ``H(z)`` (eq. 16): differential entropy for the grid densities, the discrete
            entropy of the bin index for ``"quantised"``, NaN for ``"monte_carlo"``.
        conditional_entropy: ``H(z | theta)`` (eq. 19) in the same sense; the value is
            ``entropy - conditional_entropy``.
        unresolved_mass: Posterior weight of the particles whose likelihood the estimator did
            not resolve at these poses (:meth:`MIEstimator.unresolved_mass`); ``0.0`` unless
            the value is only a lower bound of the MI.
        lower_bound: Whether the value is only a lower bound of the exact MI: the estimator
            bounds by construction (``"quantised"``) or ``unresolved_mass > 0``.
    """

    stderr: float
    method: str
    entropy: float
    conditional_entropy: float
    unresolved_mass: float
    lower_bound: bool

    def __new__(
        cls,
        value: float,
        stderr: float = 0.0,
        method: str = "quadrature",
        entropy: float = math.nan,
        conditional_entropy: float = math.nan,
        unresolved_mass: float = 0.0,
        lower_bound: bool = False,
    ) -> MIEstimate:
        obj = super().__new__(cls, float(value))
        obj.stderr = float(stderr)
        obj.method = str(method)
        obj.entropy = float(entropy)
        obj.conditional_entropy = float(conditional_entropy)
        obj.unresolved_mass = float(unresolved_mass)
        obj.lower_bound = bool(lower_bound) or obj.unresolved_mass > 0.0
        return obj

    @property
    def value(self) -> float:
        """The estimate as a plain ``float``."""
        return float(self)

    def as_tuple(self) -> tuple[float, float]:
        """``(value, stderr)``."""
        return float(self), self.stderr

    def __repr__(self) -> str:
        return f"MIEstimate({float(self)!r}, stderr={self.stderr!r}, method={self.method!r})"


@dataclass(frozen=True)
class JointEntropies:
    """MI of ``C`` pose sets with the two entropies it is the difference of.

    Attributes:
        values: ``(C,)`` MI in nats.
        stderrs: ``(C,)`` standard errors (zeros for deterministic estimators).
        entropy: ``(C,)`` ``H(z)`` (NaN where the estimator does not form it).
        conditional: ``(C,)`` ``H(z | theta)`` (NaN where not formed).
    """

    values: FloatArray
    stderrs: FloatArray
    entropy: FloatArray
    conditional: FloatArray

    @classmethod
    def from_entropies(cls, entropy: FloatArray, conditional: FloatArray) -> JointEntropies:
        """Deterministic result ``H(z) - H(z | theta)``."""
        entropy = np.asarray(entropy, dtype=np.float64)
        conditional = np.broadcast_to(np.asarray(conditional, dtype=np.float64), entropy.shape)
        return cls(entropy - conditional, np.zeros(entropy.shape), entropy, conditional.copy())


# ------------------------------------------------------------------------------------ validation
def check_belief(particles: Any, weights: Any) -> tuple[FloatArray, FloatArray]:
    """``(particles (N, d), weights (N,))`` as float64, the weights normalised.

    Raises:
        ValueError: Wrong shapes, non-finite values, negative weights or a zero total.
    """
    particles = np.asarray(particles, dtype=np.float64)
    if particles.ndim != 2 or particles.shape[0] == 0:
        raise ValueError(
            f"particles must have shape (N, target_dim), N >= 1; got {particles.shape}"
        )
    if not np.isfinite(particles).all():
        raise ValueError("particles must be finite")
    weights = np.asarray(weights, dtype=np.float64)
    if weights.shape != (particles.shape[0],):
        raise ValueError(
            f"weights must have shape ({particles.shape[0]},) like particles; got {weights.shape}"
        )
    if not np.isfinite(weights).all() or (weights < 0).any():
        raise ValueError("weights must be finite and non-negative")
    total = weights.sum()
    if not total > 0:
        raise ValueError("weights must have a positive sum")
    return particles, weights / total


def check_poses(sensor: Sensor, poses: Any, name: str, shape: str) -> FloatArray:
    """``poses`` as a finite float64 array of the documented ``shape`` (``"(k, pose_dim)"``,
    ``"(C, pose_dim)"`` or ``"(C, k, pose_dim)"``).

    Raises:
        ValueError: Wrong number of axes, wrong last axis, an empty axis or non-finite values.
    """
    poses = np.asarray(poses, dtype=np.float64)
    pose_dim = int(sensor.pose_dim)
    ndim = shape.count(",") + 1
    if poses.ndim != ndim or poses.shape[-1] != pose_dim or 0 in poses.shape:
        raise ValueError(
            f"{name} must have shape {shape} with pose_dim={pose_dim} and no empty axis; "
            f"got {poses.shape}"
        )
    if not np.isfinite(poses).all():
        raise ValueError(f"{name} must be finite")
    return poses


# ------------------------------------------------------------------------------------- estimator
class MIEstimator(ABC):
    """Base class of the mutual-information estimators (module docstring).

    Args:
        sensor: The sensor model the estimator serves.

    Raises:
        TypeError: The sensor lacks a method the estimator needs (the message names it).
        ValueError: The sensor's observation domain does not suit the estimator.
    """

    #: Registry name.
    name: ClassVar[str]
    #: Sensor methods the estimator calls besides ``sample`` and ``log_likelihood``.
    required_methods: ClassVar[tuple[str, ...]] = ()
    #: Largest number of joint observations ``k`` (``None``: any).
    max_observations: ClassVar[int | None] = 3
    #: Whether the observation must be one periodic coordinate.
    periodic_only: ClassVar[bool] = False
    #: Keyword options :func:`~infoseek.planners.information.make_estimator` forwards.
    options: ClassVar[tuple[str, ...]] = ()
    #: Whether values carry a sampling error.
    stochastic: ClassVar[bool] = False
    #: Whether every value is only a lower bound of the MI (a coarsened observation).
    lower_bound: ClassVar[bool] = False

    def __init__(self, sensor: Sensor) -> None:
        self.check_sensor(sensor)
        self.sensor = sensor

    # -- what the estimator serves
    @classmethod
    def missing_methods(cls, sensor: Sensor) -> list[str]:
        """Names in :attr:`required_methods` that ``sensor`` does not provide."""
        return [name for name in cls.required_methods if not callable(getattr(sensor, name, None))]

    @classmethod
    def domain_problem(cls, sensor: Sensor) -> str | None:
        """Why ``sensor``'s observation domain does not suit the estimator (``None``: it does)."""
        if cls.max_observations is not None and int(sensor.obs_dim) != 1:
            return f"needs obs_dim == 1, got {sensor.obs_dim}"
        if cls.periodic_only and not bool(sensor.domain.periodic[0]):
            return "needs a periodic observation (an angle)"
        return None

    @classmethod
    def serves(cls, sensor: Sensor, n_observations: int = 1) -> bool:
        """Whether the estimator can evaluate ``n_observations`` joint observations of
        ``sensor``."""
        within = cls.max_observations is None or n_observations <= cls.max_observations
        return within and not cls.missing_methods(sensor) and cls.domain_problem(sensor) is None

    @classmethod
    def check_sensor(cls, sensor: Sensor) -> None:
        """Raise unless the estimator can serve ``sensor`` (see the class docstring)."""
        missing = cls.missing_methods(sensor)
        if missing:
            raise TypeError(
                f"MI estimator {cls.name!r} needs sensor method(s) {missing}, which "
                f"{type(sensor).__name__} does not provide"
            )
        problem = cls.domain_problem(sensor)
        if problem is not None:
            raise ValueError(f"MI estimator {cls.name!r} {problem} ({type(sensor).__name__})")

    def check_observations(self, k: int) -> None:
        """Raise ``ValueError`` if ``k`` joint observations exceed :attr:`max_observations`."""
        if self.max_observations is not None and k > self.max_observations:
            raise ValueError(
                f"MI estimator {self.name!r} handles at most {self.max_observations} joint "
                f"observations, got k={k}; use 'monte_carlo'"
            )

    def bind(self, particles: Any, weights: Any) -> BeliefMI:
        """This estimator applied to one belief (validated here, once)."""
        return BeliefMI(self, particles, weights)

    def unresolved(self, belief: BeliefMI, poses: FloatArray) -> NDArray[np.bool_]:
        """``(P, N)``: whether this estimator leaves particle ``n``'s likelihood at pose ``p``
        unresolved (the MI of any set holding ``p`` is then only a lower bound). Nothing,
        unless an estimator caps what it resolves."""
        return np.zeros((poses.shape[0], belief.n_particles), dtype=bool)

    def unresolved_mass(self, belief: BeliefMI, pose_sets: FloatArray) -> FloatArray:
        """``(C,)`` posterior weight of the particles left unresolved (:meth:`unresolved`) at
        some pose of each ``(C, k, pose_dim)`` set: where it is positive the value is only a
        lower bound of the MI."""
        n_sets, k, pose_dim = pose_sets.shape
        flags = self.unresolved(belief, pose_sets.reshape(n_sets * k, pose_dim))
        return np.asarray(flags.reshape(n_sets, k, -1).any(axis=1) @ belief.weights)

    # -- the computations (arrays already validated)
    @abstractmethod
    def joint(self, belief: BeliefMI, pose_sets: FloatArray) -> JointEntropies:
        """MI of ``(C, k, pose_dim)`` pose sets (``k`` sensors observing jointly)."""

    def singles(self, belief: BeliefMI, poses: FloatArray) -> FloatArray:
        """``(C,)`` single-observation MIs of ``(C, pose_dim)`` poses."""
        return self.joint(belief, poses[:, None, :]).values

    def singles_of(
        self, beliefs: Sequence[BeliefMI], pose_sets: Sequence[FloatArray]
    ) -> list[FloatArray]:
        """:meth:`singles` of several beliefs (one pose set each), e.g. every vehicle's
        candidates on its own belief; estimators may share work across them."""
        return [self.singles(b, poses) for b, poses in zip(beliefs, pose_sets, strict=True)]

    def pairs(self, belief: BeliefMI, poses_a: FloatArray, poses_b: FloatArray) -> FloatArray:
        """``(C, M)`` pair MIs of every pose in ``poses_a`` with every pose in ``poses_b``."""
        n_a, n_b = poses_a.shape[0], poses_b.shape[0]
        sets = np.stack(
            [
                np.repeat(poses_a, n_b, axis=0),
                np.tile(poses_b, (n_a, 1)),
            ],
            axis=1,
        )
        return self.joint(belief, sets).values.reshape(n_a, n_b)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.sensor!r})"


def single_many(beliefs: Sequence[BeliefMI], pose_sets: Sequence[Any]) -> list[FloatArray]:
    """``[beliefs[i].single(pose_sets[i]) ...]``, evaluated together by their (common)
    estimator (:meth:`MIEstimator.singles_of`).

    Raises:
        ValueError: The beliefs are bound to different estimators, the lists differ in length,
            or a pose set is malformed.
    """
    if len(beliefs) != len(pose_sets):
        raise ValueError(f"need one pose set per belief, got {len(pose_sets)} for {len(beliefs)}")
    if not beliefs:
        return []
    estimator = beliefs[0].estimator
    if any(belief.estimator is not estimator for belief in beliefs):
        raise ValueError("single_many needs beliefs bound to one estimator")
    checked = [
        check_poses(belief.sensor, poses, "poses", "(C, pose_dim)")
        for belief, poses in zip(beliefs, pose_sets, strict=True)
    ]
    values = estimator.singles_of(beliefs, checked)
    return [np.asarray(value, dtype=np.float64) for value in values]


class BeliefMI:
    """One estimator applied to one particle belief.

    Created by :meth:`MIEstimator.bind`. Validates the belief once and remembers per-pose work
    (keyed by the exact pose) so that repeated calls on the same belief - a planner's candidate
    scoring, coordination sweeps and refinement - compute each pose's predictions or channels
    once.

    Attributes:
        estimator: The estimator.
        sensor: Its sensor.
        particles: ``(N, d)`` particles (float64).
        weights: ``(N,)`` normalised weights.
        uniform: Whether every weight is equal (cheaper unweighted histograms).
    """

    def __init__(self, estimator: MIEstimator, particles: Any, weights: Any) -> None:
        self.estimator = estimator
        self.sensor = estimator.sensor
        self.particles, self.weights = check_belief(particles, weights)
        if self.particles.shape[1] < int(self.sensor.target_dim):
            raise ValueError(
                f"particles must have at least target_dim={self.sensor.target_dim} columns, "
                f"got shape {self.particles.shape}"
            )
        self.uniform = bool(self.weights.min() == self.weights.max())
        self._cache: dict[tuple[str, bytes], Any] = {}
        self._cache_bytes = 0

    @property
    def n_particles(self) -> int:
        """``N``."""
        return int(self.particles.shape[0])

    # -- public evaluations
    def joint(self, pose_sets: Any) -> FloatArray:
        """``(C,)`` MIs (nats) of ``(C, k, pose_dim)`` pose sets."""
        return self.joint_entropies(pose_sets).values

    def joint_entropies(self, pose_sets: Any) -> JointEntropies:
        """:meth:`joint` with standard errors and the two entropies."""
        pose_sets = check_poses(self.sensor, pose_sets, "poses", "(C, k, pose_dim)")
        self.estimator.check_observations(pose_sets.shape[1])
        return self.estimator.joint(self, pose_sets)

    def single(self, poses: Any) -> FloatArray:
        """``(C,)`` single-observation MIs ``I(z_c; theta)`` of ``(C, pose_dim)`` poses."""
        poses = check_poses(self.sensor, poses, "poses", "(C, pose_dim)")
        return np.asarray(self.estimator.singles(self, poses), dtype=np.float64)

    def pairs(self, poses_a: Any, poses_b: Any) -> FloatArray:
        """``(C, M)`` pair MIs ``I(z_a, z_b; theta)`` of ``(C, pose_dim)`` and ``(M, pose_dim)``."""
        poses_a = check_poses(self.sensor, poses_a, "poses_a", "(C, pose_dim)")
        poses_b = check_poses(self.sensor, poses_b, "poses_b", "(M, pose_dim)")
        self.estimator.check_observations(2)
        return np.asarray(self.estimator.pairs(self, poses_a, poses_b), dtype=np.float64)

    # -- the caches
    def derived(self, kind: str, compute: Callable[[], Any]) -> Any:
        """A quantity derived from the belief alone (e.g. the particles in float32), computed
        once."""
        key = (kind, b"")
        if key not in self._cache:
            self._remember(key, compute())
        return self._cache[key]

    def for_pose_set(
        self, kind: str, poses: FloatArray, compute: Callable[[FloatArray], Any]
    ) -> Any:
        """``compute(poses)`` for a whole ``(P, pose_dim)`` pose set, computed once per set."""
        key = (kind, poses.tobytes())
        if key not in self._cache:
            self._remember(key, compute(poses))
        return self._cache[key]

    def per_pose(
        self,
        kind: str,
        poses: FloatArray,
        compute: Callable[[FloatArray], Iterable[Any]],
    ) -> list[Any]:
        """Per-pose results of ``compute`` for ``(P, pose_dim)`` poses, computed once per pose.

        Args:
            kind: What is cached (one name per kind of work, e.g. ``"channels"``).
            poses: The poses.
            compute: ``compute(missing_poses) -> one item per pose`` (an array with a leading
                pose axis, or a list), called once with the poses not seen before.

        Returns:
            One item per row of ``poses``.
        """
        keys = [(kind, pose.tobytes()) for pose in poses]
        missing = [p for p, key in enumerate(keys) if key not in self._cache]
        fresh: dict[tuple[str, bytes], Any] = {}
        if missing:
            for p, item in zip(missing, compute(poses[missing]), strict=True):
                fresh[keys[p]] = item
        items = [fresh[key] if key in fresh else self._cache[key] for key in keys]
        for key, item in fresh.items():
            self._remember(key, item)
        return items

    def _remember(self, key: tuple[str, bytes], item: Any) -> None:
        size = _nbytes(item)
        if self._cache_bytes + size > CACHE_BYTES:
            # forget the oldest half (dicts keep insertion order)
            for old in list(self._cache)[: max(1, len(self._cache) // 2)]:
                self._cache_bytes -= _nbytes(self._cache.pop(old))
        self._cache[key] = item
        self._cache_bytes += size

    def __repr__(self) -> str:
        return f"BeliefMI({self.estimator.name!r}, n_particles={self.n_particles})"


def _nbytes(item: Any) -> int:
    if isinstance(item, np.ndarray) or hasattr(item, "nbytes"):
        return int(item.nbytes)
    if isinstance(item, tuple | list):
        return sum(_nbytes(part) for part in item)
    return 64
