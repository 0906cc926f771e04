"""Particle-filter belief over the target state (section III.A of Hoffmann et al. 2006).

The posterior ``p_t(theta)`` is approximated by ``N`` weighted particles (eq. 11),

    p_t(theta) ~= sum_k w_k delta(theta - theta_k).

Weights are stored as normalised log-weights (``logsumexp(log_w) = 0``) so that products of
many sharp likelihoods never underflow.

One filter cycle (:meth:`ParticleBelief.predict`, :meth:`~ParticleBelief.update`,
:meth:`~ParticleBelief.resample_if_needed`):

1. *Predict*: each particle is propagated by the target motion model.
2. *Update* (Bayes' rule, eq. 4): with the ``M`` conditionally independent observations
   ``z^{(j)}`` received this step (own and shared, eq. 14),
   ``log w_k <- log w_k + sum_j log p(z^{(j)} | theta_k) - log E``, where the log evidence
   ``log E = logsumexp_k(log w_k + sum_j log p(z^{(j)} | theta_k))`` estimates
   ``log p(z_{1..M} | past)``.
3. *Resample* when ``ESS = 1 / sum w_k^2 < resample_threshold * N`` with the systematic
   low-variance sampler (O(N), as in the paper; threshold 1.0 = after every informative update).
   A stationary target has no process noise, so resampling alone would collapse the particle
   set onto ever fewer distinct points. After resampling we therefore apply Gordon *roughening*
   (Gordon, Salmond & Smith 1993): every coordinate ``j`` gets Gaussian jitter of standard
   deviation ``roughening * E_j * N^(-1/d)``, ``E_j`` the spread (max - min) of the resampled
   particles in coordinate ``j`` (for periodic angles, measured around the circular/axial mean),
   floored at ``SPREAD_FLOOR = 1e-3`` of the domain width so that a set collapsed onto one point
   is separated again.
   Positions are reflected back into the box, angles wrapped.

Progressive correction (tempering; Oudjane & Musso 2000). Near an avalanche beacon the
likelihood is extremely sharp (angular std ``~ r^3 noise_std / moment``), far narrower than the
particle spacing: a one-shot update then leaves one or two particles with all the weight, or
none within thousands of standard deviations of the likelihood peak. Write
``L_k = sum_j log p(z^{(j)} | theta_k)`` for the batch log-likelihood and ``1 = lambda_1 + ... +
lambda_S`` for a split of the exponent. Since
``prod_s p(z | theta)^{lambda_s} = p(z | theta)^{sum_s lambda_s} = p(z | theta)``,
the posterior can be reached through the intermediate targets
``pi_s(theta) ~ p(theta | past) p(z | theta)^{lambda_1 + ... + lambda_s}``. Stage ``s``
reweights by ``exp(lambda_s L_k)`` only, resamples (systematic) and moves the particles with
``TEMPERING_MOVE_SWEEPS`` Metropolis sweeps: Gaussian proposals of ``TEMPERING_MOVE_SCALE`` times
the *current* per-coordinate std of the particles (so the steps shrink as they concentrate),
each sweep ``TEMPERING_MOVE_SHRINK`` times smaller, accepted with probability
``min(1, exp(Lambda_s (L(proposal) - L(particle)) + H(proposal) - H(particle)))``,
``Lambda_s = lambda_1 + ... + lambda_s``, with ``H(theta)`` the log-likelihood of every earlier
observation the belief has kept (:mod:`infoseek.envs.history`). For a stationary target and the
uniform prior ``p_0``, ``p(theta | past) ~ p_0(theta) exp(H(theta))`` exactly, so this is an
exact Metropolis kernel for ``pi_s`` (the reflecting random-walk proposal is symmetric and
stays in the domain): resample-move for a static parameter (Gilks & Berzuini 2001; Chopin
2002). A belief built from given
particles (not the prior) is treated as drawn from ``p_0`` with no observations yet. A moving
target has no such closed form: tempering then needs ``tempering_ess = 0`` (the environments
default to it). An earlier kernel treated the prior as locally flat (``H = 0``); for a
concentrated prior it drifts the particles toward the current readings, ignoring the
history, which built false fixes from noise-dominated beacon readings (``beacon_v0`` keeps
``tempering_ess = 0``). A plain Gordon
jitter (scale
``~ range * N^(-1/d)``) was tried first: it is far too small to carry the particles to a peak
thousands of its own widths away, and too large (range of a multi-modal set) to keep them on
a thin likelihood ridge. ``L_k`` of accepted proposals is reused in the next stage.
``lambda_s in (0, remaining]`` is chosen by bisection (on ``log lambda``,
:mod:`infoseek.envs.tempering`) so that the ESS after the partial reweighting equals
``tempering_ess`` times the ESS before it (``tempering_ess * N`` for the uniform weights that
resampling leaves); when applying all the remaining exponent keeps the ESS above that floor, or
at stage ``max_tempering_stages``, the remainder is applied and the weights are kept (the normal
resampling step follows). A mild update therefore takes one stage and is exactly the plain
Bayes update. The log evidence is accumulated over stages,
``log E = sum_s log sum_k w^{(s)}_k exp(lambda_s L^{(s)}_k)``, the usual sequential Monte Carlo
estimate of ``log p(z_{1..M} | past)``. Tempering is disabled by ``tempering_ess = 0`` and, as
it resamples, also by ``resample_threshold = 0`` (never resample: pure importance weighting).

Degeneracy recovery: if the (tempered) ``log E`` is not finite or below ``-700`` (every weight
would underflow in float64 in a one-shot update; the observations are impossible under every
particle even after the particles were moved towards them by tempering), a fraction
``recovery_fraction`` of the particles is replaced by fresh samples of the uniform prior ``p_0``,
the remaining particles are drawn (systematically) from the pre-update weights, all weights are
set uniform and this step's likelihood is reapplied (tempered again). If the update is still
degenerate the observations are dropped and the pre-update particles and weights are kept.
Either way the returned :class:`BeliefUpdate` has ``recovered=True``; no NaN is ever produced.
The threshold is applied to the tempered evidence of the whole observation batch, so a sharp
but consistent observation (which tempering follows to its peak) does not trigger recovery.

Estimates:

* MMSE estimate (eq. 12) ``theta_hat = sum_k w_k theta_k`` for linear coordinates; for periodic
  angles the circular mean ``arg(sum_k w_k e^{i phi_k})`` (``phi`` the angle scaled to
  ``[0, 2 pi)``); for axial angles the axial mean ``arg(sum_k w_k e^{2 i phi_k}) / 2``.
* Posterior mass within a radius (the metric of Fig. 1): ``sum_k w_k [||p_k - c|| <= r]`` over
  the position coordinates ``p_k``, ``c`` the MMSE position by default.
* Entropy (eq. 6): the differential entropy of a histogram density of the particles
  (:mod:`infoseek.envs.entropy`): by default on a grid adapted to the particles (a fixed number of
  effective particles per cell, Miller-Madow corrected), which reads ``log(vol(Theta))`` at the
  uniform prior whatever the particle count and follows the belief as it collapses; with
  ``entropy_bins`` on a fixed grid over the whole domain.
"""

from __future__ import annotations

import copy as _copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.belief_batch import (
    DEFAULT_TEMPERING_ESS,
    DEGENERATE_LOG_EVIDENCE,
    SPREAD_FLOOR,
    TEMPERING_BISECTION_STEPS,
    TEMPERING_MOVE_SCALE,
    TEMPERING_MOVE_SHRINK,
    TEMPERING_MOVE_SWEEPS,
    BeliefBatch,
    logsumexp_rows,
)
from infoseek.envs.targets import StationaryTarget, TargetMotion, TargetSpace

FloatArray = NDArray[np.float64]

__all__ = [
    "DEFAULT_TEMPERING_ESS",
    "DEGENERATE_LOG_EVIDENCE",
    "TEMPERING_BISECTION_STEPS",
    "TEMPERING_MOVE_SCALE",
    "TEMPERING_MOVE_SHRINK",
    "TEMPERING_MOVE_SWEEPS",
    "SPREAD_FLOOR",
    "BeliefUpdate",
    "BeliefView",
    "ParticleBelief",
    "belief_view",
    "default_tempering_ess",
    "check_belief_settings",
]


def _readonly(arr: np.ndarray) -> np.ndarray:
    view = arr.view()
    view.flags.writeable = False
    return view


@dataclass(frozen=True)
class BeliefUpdate:
    """Outcome of :meth:`ParticleBelief.update`.

    Attributes:
        recovered: Whether the degeneracy recovery ran (observations impossible under every
            particle).
        log_evidence: Estimate of ``log p(z_1..M | past)`` under the pre-update belief: the
            one-shot ``logsumexp_k(log w_k + sum_j log p(z_j | theta_k))``, or its sum over the
            tempering stages (module docstring). May be ``-inf`` when ``recovered``; 0.0 for no
            observations.
        n_observations: Number ``M`` of observations incorporated (0 when they were dropped
            because even the recovered particle set could not explain them).
        n_stages: Number of progressive-correction (tempering) stages of the update that was
            kept: 1 for a plain one-shot update, up to ``max_tempering_stages``; 0 when there
            were no observations or they were dropped.
    """

    recovered: bool
    log_evidence: float
    n_observations: int
    n_stages: int = 1


@dataclass(frozen=True)
class BeliefView:
    """Read-only snapshot of a belief (the arrays are never modified in place later).

    Attributes:
        particles: ``(N, d)`` read-only particle states.
        weights: ``(N,)`` read-only normalised weights.
        log_weights: ``(N,)`` read-only normalised log-weights.
        space: The target space.
    """

    particles: FloatArray
    weights: FloatArray
    log_weights: FloatArray
    space: TargetSpace

    def __eq__(self, other: object) -> bool:
        """Value equality: same space and bit-identical particles and log-weights.

        (The dataclass-generated ``==`` would compare arrays inside a tuple, which raises for
        ``N > 1``; PettingZoo's determinism checks compare infos with ``==``.)
        """
        if not isinstance(other, BeliefView):
            return NotImplemented
        return bool(
            self.space == other.space
            and np.array_equal(self.particles, other.particles)
            and np.array_equal(self.log_weights, other.log_weights)
        )

    __hash__ = None  # type: ignore[assignment]


class ParticleBelief:
    """Weighted particle approximation of the target posterior (eq. 11).

    Args:
        particles: ``(N, d)`` initial particle states inside ``space``.
        space: The target state space.
        rng: Random generator for prediction noise, resampling, roughening and recovery.
        log_weights: ``(N,)`` initial log-weights (normalised internally; ``-inf`` allowed,
            not all). Default uniform.
        motion: Target motion model (default :class:`StationaryTarget`).
        resample_threshold: Resample when ``ESS < resample_threshold * N``; 1.0 resamples after
            every update that makes the weights non-uniform (the paper), 0 never.
        roughening: Roughening constant ``K``; jitter std ``K * E_j * N^(-1/d)``. 0 disables.
        entropy_bins: Cells per coordinate of a fixed entropy grid over the whole domain
            (``None``, the default: the adaptive grid of
            :func:`~infoseek.envs.entropy.adaptive_histogram_entropy`).
        recovery_fraction: Fraction of particles replaced by prior samples on degeneracy, in
            ``(0, 1]``.
        tempering_ess: Progressive-correction floor in ``[0, 1)``: an update that would make the
            ESS fall below ``tempering_ess`` times its pre-update value is applied in stages
            (module docstring). 0 disables tempering (as does ``resample_threshold = 0``);
            ``None`` (default): :func:`default_tempering_ess` (0.1 for a stationary target, 0
            for a moving one; > 0 with a moving target is a ``ValueError``).
        max_tempering_stages: Maximum number of tempering stages (>= 1; the last one applies
            whatever exponent remains).
    """

    def __init__(
        self,
        particles: FloatArray,
        space: TargetSpace,
        rng: np.random.Generator,
        *,
        log_weights: FloatArray | None = None,
        motion: TargetMotion | None = None,
        resample_threshold: float = 1.0,
        roughening: float = 0.2,
        entropy_bins: tuple[int, ...] | None = None,
        recovery_fraction: float = 0.5,
        tempering_ess: float | None = None,
        max_tempering_stages: int = 20,
    ) -> None:
        if not isinstance(space, TargetSpace):
            raise TypeError(f"space must be a TargetSpace, got {type(space).__name__}")
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        p = np.array(particles, dtype=np.float64, copy=True)
        if p.ndim != 2 or p.shape[0] < 1 or p.shape[1] != space.dim:
            raise ValueError(
                f"particles must have shape (N, {space.dim}) with N >= 1, got {p.shape}"
            )
        if not np.all(np.isfinite(p)):
            raise ValueError("particles must be finite (got NaN or inf)")
        n = p.shape[0]
        if log_weights is None:
            lw = np.full(n, -math.log(n))
        else:
            lw = np.array(log_weights, dtype=np.float64, copy=True)
            if lw.shape != (n,):
                raise ValueError(f"log_weights must have shape ({n},), got {lw.shape}")
            if np.any(np.isnan(lw)) or np.any(lw == np.inf):
                raise ValueError("log_weights must not contain NaN or +inf")
            total = float(logsumexp_rows(lw[None])[0])
            if not np.isfinite(total):
                raise ValueError("log_weights must not all be -inf")
            lw = lw - total
        settings = check_belief_settings(
            motion=motion,
            resample_threshold=resample_threshold,
            roughening=roughening,
            entropy_bins=entropy_bins,
            recovery_fraction=recovery_fraction,
            tempering_ess=tempering_ess,
            max_tempering_stages=max_tempering_stages,
            space=space,
        )
        self._batch = BeliefBatch(space.wrap(p)[None], lw[None], space, [rng], **settings)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_prior(
        cls, space: TargetSpace, n_particles: int, rng: np.random.Generator, **kwargs: Any
    ) -> ParticleBelief:
        """Belief with ``n_particles`` samples of the uniform prior ``p_0`` and equal weights.

        Args:
            space: The target space.
            n_particles: Number of particles (>= 1).
            rng: Random generator (used for the samples and kept by the belief).
            **kwargs: Keyword arguments of the constructor.
        """
        if (
            isinstance(n_particles, bool)
            or not isinstance(n_particles, int | np.integer)
            or n_particles < 1
        ):
            raise ValueError(f"n_particles must be a positive integer, got {n_particles!r}")
        if not isinstance(space, TargetSpace):
            raise TypeError(f"space must be a TargetSpace, got {type(space).__name__}")
        return cls(space.sample_uniform(int(n_particles), rng), space, rng, **kwargs)

    @classmethod
    def row_of(cls, batch: BeliefBatch, row: int) -> ParticleBelief:
        """A new belief holding a copy of row ``row`` of ``batch`` (its generator state copied)."""
        new = object.__new__(cls)
        new._batch = BeliefBatch(
            batch.particles[row : row + 1],
            batch.log_weights[row : row + 1],
            batch.space,
            [_copy.deepcopy(batch.rngs[row])],
            **_settings_of(batch),
            history=batch.history.of_row(row),
        )
        return new

    def copy(self, rng: np.random.Generator | None = None) -> ParticleBelief:
        """Independent copy of this belief.

        Args:
            rng: Generator for the copy; by default a copy of this belief's generator state
                (the copy then draws the same random stream, and this belief's stream is not
                advanced).
        """
        if rng is not None and not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        new = ParticleBelief.row_of(self._batch, 0)
        if rng is not None:
            new._batch.rngs[0] = rng
        return new  # arrays are never mutated in place, so sharing them is safe

    # ------------------------------------------------------------------ accessors
    @property
    def particles(self) -> FloatArray:
        """``(N, d)`` read-only particle states."""
        return _readonly(self._batch.particles[0])

    @property
    def log_weights(self) -> FloatArray:
        """``(N,)`` read-only normalised log-weights (``logsumexp = 0``)."""
        return _readonly(self._batch.log_weights[0])

    @property
    def weights(self) -> FloatArray:
        """``(N,)`` read-only normalised weights."""
        return _readonly(self._batch.weights[0])

    @property
    def n_particles(self) -> int:
        """Number of particles ``N``."""
        return self._batch.n_particles

    @property
    def dim(self) -> int:
        """Target dimension ``d``."""
        return self._batch.space.dim

    @property
    def space(self) -> TargetSpace:
        """The target space."""
        return self._batch.space

    @property
    def motion(self) -> TargetMotion:
        """The target motion model."""
        return self._batch.motion

    @property
    def entropy_bins(self) -> tuple[int, ...] | None:
        """Cells per coordinate of the fixed entropy grid (``None``: adaptive grid)."""
        return self._batch.entropy_bins

    @property
    def ess(self) -> float:
        """Effective sample size ``1 / sum w_k^2`` in ``[1, N]``."""
        return float(self._batch.ess()[0])

    def view(self) -> BeliefView:
        """Read-only snapshot (arrays are shared, never mutated in place afterwards)."""
        return belief_view(self._batch, 0)

    # ------------------------------------------------------------------ filter cycle
    def predict(self, dt: float = 1.0) -> None:
        """Propagate every particle with the target motion model over ``dt`` (> 0)."""
        if isinstance(dt, bool) or not (
            isinstance(dt, int | float | np.floating | np.integer) and np.isfinite(dt) and dt > 0
        ):
            raise ValueError(f"dt must be a positive finite float, got {dt!r}")
        self._batch.predict(float(dt))

    def update(self, sensor: Any, z: FloatArray, poses: FloatArray) -> BeliefUpdate:
        """Condition on ``M`` conditionally independent observations (eq. 4, eq. 14).

        Args:
            sensor: A :class:`~infoseek.envs.sensors.base.Sensor`.
            z: ``(M, obs_dim)`` observations (``M`` may be 0: nothing happens).
            poses: ``(M, pose_dim)`` poses of the sensors that made them.

        Returns:
            The :class:`BeliefUpdate` (recovery flag, log evidence, ``M``).

        Raises:
            TypeError: ``sensor`` has no ``log_likelihood``.
            ValueError: Shapes inconsistent, non-finite ``z``/``poses``, or the sensor returned
                NaN.
        """
        if not callable(getattr(sensor, "log_likelihood", None)):
            raise TypeError(
                f"sensor must implement log_likelihood(z, poses, particles), got "
                f"{type(sensor).__name__}"
            )
        z_arr = np.asarray(z, dtype=np.float64)
        poses_arr = np.asarray(poses, dtype=np.float64)
        obs_dim = getattr(sensor, "obs_dim", None)
        pose_dim = getattr(sensor, "pose_dim", None)
        if z_arr.ndim != 2 or (obs_dim is not None and z_arr.shape[1] != obs_dim):
            raise ValueError(f"z must have shape (M, {obs_dim}), got {z_arr.shape}")
        if poses_arr.ndim != 2 or (pose_dim is not None and poses_arr.shape[1] != pose_dim):
            raise ValueError(f"poses must have shape (M, {pose_dim}), got {poses_arr.shape}")
        if poses_arr.shape[0] != z_arr.shape[0]:
            raise ValueError(
                f"z and poses must have the same number of rows M, got {z_arr.shape[0]} and "
                f"{poses_arr.shape[0]}"
            )
        if not (np.all(np.isfinite(z_arr)) and np.all(np.isfinite(poses_arr))):
            raise ValueError("z and poses must be finite (got NaN or inf)")
        m = int(z_arr.shape[0])
        if m == 0:
            return BeliefUpdate(recovered=False, log_evidence=0.0, n_observations=0)
        outcome = self._batch.update(
            sensor, z_arr[None], poses_arr[None], np.ones((1, m), dtype=bool)
        )
        return BeliefUpdate(
            recovered=bool(outcome.recovered[0]),
            log_evidence=float(outcome.log_evidence[0]),
            n_observations=int(outcome.n_observations[0]),
            n_stages=int(outcome.n_stages[0]),
        )

    def resample_if_needed(self) -> bool:
        """Systematic resampling plus roughening when ``ESS < resample_threshold * N``.

        Uniform weights (``ESS = N`` up to round-off) are never resampled.

        Returns:
            Whether resampling happened (weights are then uniform).
        """
        return bool(self._batch.resample_if_needed()[0])

    # ------------------------------------------------------------------ estimates
    def mmse(self) -> FloatArray:
        """MMSE estimate (eq. 12), circular mean for periodic and axial mean for axial angles.

        Returns:
            ``(d,)`` estimate. Axial coordinates are reported in ``[low, low + period / 2)``; a
            periodic coordinate whose resultant vanishes (uniform) is reported as ``low``.
        """
        return self._batch.mmse()[0]

    def mass_within(self, radius: float, center: FloatArray | None = None) -> float:
        """Posterior mass whose position lies within ``radius`` of ``center`` (Fig. 1 metric).

        Args:
            radius: Radius (>= 0).
            center: ``(2,)`` position or ``(d,)`` state (its position part is used); default
                the MMSE position.

        Returns:
            Mass in ``[0, 1]``.
        """
        if isinstance(radius, bool) or not (
            isinstance(radius, int | float | np.integer | np.floating)
            and np.isfinite(radius)
            and radius >= 0
        ):
            raise ValueError(f"radius must be a finite float >= 0, got {radius!r}")
        if center is None:
            c = self.mmse()[:2]
        else:
            c = np.asarray(center, dtype=np.float64)
            if c.shape not in ((2,), (self.dim,)) or not np.all(np.isfinite(c)):
                raise ValueError(f"center must be finite with shape (2,) or ({self.dim},)")
            c = c[:2]
        return float(self._batch.mass_within(float(radius), c[None])[0])

    def entropy(self) -> float:
        """Histogram estimate of the differential entropy (eq. 6), in nats.

        On the adaptive grid (default) or on the fixed ``entropy_bins`` grid; see
        :mod:`infoseek.envs.entropy`.
        """
        return float(self._batch.entropy()[0])

    def mass_grid(self, shape: tuple[int, int] = (8, 8)) -> FloatArray:
        """Posterior position mass on a coarse ``gx x gy`` grid over the position box.

        Args:
            shape: ``(gx, gy)`` cells along x and y.

        Returns:
            ``(gx, gy)`` masses summing to one; ``[i, j]`` is the cell ``i``-th along x and
            ``j``-th along y.
        """
        try:
            gx, gy = shape
        except (TypeError, ValueError) as err:
            raise ValueError(f"shape must be a pair of positive integers, got {shape!r}") from err
        for g in (gx, gy):
            if isinstance(g, bool) or not isinstance(g, int | np.integer) or g < 1:
                raise ValueError(f"shape must be a pair of positive integers, got {shape!r}")
        return self._batch.mass_grid((int(gx), int(gy)))[0]

    def __repr__(self) -> str:
        return (
            f"ParticleBelief(n_particles={self.n_particles}, dim={self.dim}, "
            f"ess={self.ess:.1f}, motion={self.motion!r})"
        )


def belief_view(batch: BeliefBatch, row: int) -> BeliefView:
    """Read-only snapshot of belief ``row`` of ``batch`` (its arrays are shared: a batch
    replaces its arrays rather than writing into them)."""
    return BeliefView(
        particles=_readonly(batch.particles[row]),
        weights=_readonly(batch.weights[row]),
        log_weights=_readonly(batch.log_weights[row]),
        space=batch.space,
    )


def _settings_of(batch: BeliefBatch) -> dict[str, Any]:
    return {
        "motion": batch.motion,
        "resample_threshold": batch.resample_threshold,
        "roughening": batch.roughening,
        "entropy_bins": batch.entropy_bins,
        "recovery_fraction": batch.recovery_fraction,
        "tempering_ess": batch.tempering_ess,
        "max_tempering_stages": batch.max_tempering_stages,
    }


def default_tempering_ess(motion: TargetMotion) -> float:
    """The ``tempering_ess=None`` default: :data:`DEFAULT_TEMPERING_ESS` for a stationary target,
    0 (off) for a moving one, whose exact posterior the tempering moves cannot target."""
    return DEFAULT_TEMPERING_ESS if isinstance(motion, StationaryTarget) else 0.0


def check_belief_settings(
    *,
    motion: TargetMotion | None,
    resample_threshold: float,
    roughening: float,
    entropy_bins: tuple[int, ...] | None,
    recovery_fraction: float,
    tempering_ess: float | None,
    max_tempering_stages: int,
    space: TargetSpace,
) -> dict[str, Any]:
    """Validate the filter settings (meanings: :class:`ParticleBelief`) and return them as the
    keyword arguments of :class:`~infoseek.envs.belief_batch.BeliefBatch`.

    Raises:
        TypeError: ``motion`` is not a :class:`~infoseek.envs.targets.TargetMotion`.
        ValueError: A setting outside its range, naming it.
    """
    motion = _check_motion(motion)
    _check_resampling(resample_threshold, roughening, recovery_fraction)
    tempering_ess = _check_tempering(tempering_ess, max_tempering_stages, motion)
    bins = _check_entropy_bins(entropy_bins, space)
    return {
        "motion": motion,
        "resample_threshold": float(resample_threshold),
        "roughening": float(roughening),
        "entropy_bins": bins,
        "recovery_fraction": float(recovery_fraction),
        "tempering_ess": float(tempering_ess),
        "max_tempering_stages": int(max_tempering_stages),
    }


def _check_motion(motion: TargetMotion | None) -> TargetMotion:
    """``motion``, a stationary target when ``None``."""
    if motion is None:
        motion = StationaryTarget()
    if not isinstance(motion, TargetMotion):
        raise TypeError(f"motion must be a TargetMotion, got {type(motion).__name__}")
    return motion


def _check_resampling(
    resample_threshold: float, roughening: float, recovery_fraction: float
) -> None:
    """The resampling threshold in ``[0, 1]``, roughening ``>= 0`` and recovery fraction in
    ``(0, 1]``, each finite."""
    if not (np.isfinite(resample_threshold) and 0.0 <= resample_threshold <= 1.0):
        raise ValueError(f"resample_threshold must be in [0, 1], got {resample_threshold!r}")
    if not (np.isfinite(roughening) and roughening >= 0.0):
        raise ValueError(f"roughening must be a finite float >= 0, got {roughening!r}")
    if not (np.isfinite(recovery_fraction) and 0.0 < recovery_fraction <= 1.0):
        raise ValueError(f"recovery_fraction must be in (0, 1], got {recovery_fraction!r}")


def _check_tempering(
    tempering_ess: float | None, max_tempering_stages: int, motion: TargetMotion
) -> float:
    """The progressive-correction floor (``None``: the default for ``motion``), in ``[0, 1)``
    and 0 unless the target is stationary, and a stage cap ``>= 1``; returns the floor."""
    if tempering_ess is None:
        tempering_ess = default_tempering_ess(motion)
    if isinstance(tempering_ess, bool) or not (
        isinstance(tempering_ess, int | float | np.integer | np.floating)
        and 0.0 <= tempering_ess < 1.0
    ):
        raise ValueError(f"tempering_ess must be a float in [0, 1), got {tempering_ess!r}")
    if tempering_ess > 0.0 and not isinstance(motion, StationaryTarget):
        raise ValueError(
            f"tempering_ess > 0 needs a stationary target (its moves target the exact "
            f"static-target posterior), got motion {motion!r}: set tempering_ess=0"
        )
    if (
        isinstance(max_tempering_stages, bool)
        or not isinstance(max_tempering_stages, int | np.integer)
        or max_tempering_stages < 1
    ):
        raise ValueError(
            f"max_tempering_stages must be an integer >= 1, got {max_tempering_stages!r}"
        )
    return tempering_ess


def _check_entropy_bins(
    entropy_bins: tuple[int, ...] | None, space: TargetSpace
) -> tuple[int, ...] | None:
    """``None``, or one positive integer per dimension of ``space`` (as Python ints)."""
    if entropy_bins is None:
        return None
    bins = tuple(entropy_bins)
    if len(bins) != space.dim or not all(
        isinstance(b, int | np.integer) and not isinstance(b, bool) and b >= 1 for b in bins
    ):
        raise ValueError(
            f"entropy_bins must be {space.dim} positive integers, got {entropy_bins!r}"
        )
    return tuple(int(b) for b in bins)
