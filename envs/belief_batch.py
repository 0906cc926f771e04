"""``K`` particle-filter beliefs stepped at once: the implementation of the filter.

The filter itself (predict, Bayes update with progressive correction and degeneracy recovery,
systematic resampling with Gordon roughening, the estimates) is documented in
:mod:`infoseek.envs.belief`; :class:`~infoseek.envs.belief.ParticleBelief` is one row of a
:class:`BeliefBatch`. Here the ``K`` beliefs (every agent of every environment of a batch) are
arrays: particles ``(K, N, d)``, normalised log-weights and weights ``(K, N)``, and each belief
keeps its own ``numpy.random.Generator``.

Row independence. Row ``k`` of every result is bit-for-bit what a single belief with row
``k``'s particles, weights and generator computes: elementwise arithmetic and reductions
along the particle axis are done on the whole ``(K, N)`` array (numpy reduces each row the
same way as a 1-D array), while the few operations whose rounding depends on how they are
batched (BLAS dot products and matrix-vector products, compacted sums, ``searchsorted``) and
every random draw run row by row. The rare stages that depend on one belief's data
(progressive correction, degeneracy recovery, the weighted-quantile sort of unequal weights)
run on that row alone. A batch of ``K`` beliefs therefore gives the same numbers as ``K``
separate beliefs (test ``tests/test_belief_batch.py``), whatever ``K``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.circular import circular_means, circular_ranges
from infoseek.envs.entropy import (
    adaptive_histogram_entropy_rows,
    fixed_grid_entropy,
)
from infoseek.envs.history import ObservationHistory
from infoseek.envs.log_weights import (
    DEGENERATE_LOG_EVIDENCE,
    bayes_step,
    ess_rows,
    logsumexp_rows,
    normalised,
)
from infoseek.envs.pcg64 import uniforms as draw_uniforms
from infoseek.envs.resampling import gather_rows, systematic_resample, systematic_resample_rows
from infoseek.envs.roughening import coordinate_ranges, jitter
from infoseek.envs.sensors.arrays import has_nan_or_plus_inf
from infoseek.envs.summaries import mass_grids, masses_within, weighted_means
from infoseek.envs.targets import StationaryTarget, TargetMotion, TargetSpace
from infoseek.envs.tempering import metropolis_accept, tempering_exponent

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

__all__ = [
    "DEFAULT_TEMPERING_ESS",
    "DEGENERATE_LOG_EVIDENCE",
    "SPREAD_FLOOR",
    "TEMPERING_BISECTION_STEPS",
    "TEMPERING_MOVE_SCALE",
    "TEMPERING_MOVE_SHRINK",
    "TEMPERING_MOVE_SWEEPS",
    "BatchUpdate",
    "BeliefBatch",
    "logsumexp_rows",
]

#: Progressive-correction floor of a belief of a stationary target (``tempering_ess=None``).
DEFAULT_TEMPERING_ESS = 0.1
#: Roughening spread floor, as a fraction of each coordinate's domain width.
SPREAD_FLOOR = 1e-3
#: Bisection steps for a tempering exponent (on ``log lambda`` over 60 nats below the remainder).
TEMPERING_BISECTION_STEPS = 40
#: Metropolis sweeps of the tempering move: the first proposes Gaussian steps of
#: ``TEMPERING_MOVE_SCALE`` times the particles' per-coordinate std, each next one
#: ``TEMPERING_MOVE_SHRINK`` times smaller.
TEMPERING_MOVE_SWEEPS = 5
TEMPERING_MOVE_SCALE = 1.0
TEMPERING_MOVE_SHRINK = 0.3


def _logsumexp(values: FloatArray) -> float:
    """``log sum exp(values)`` of one ``(N,)`` row: :func:`~infoseek.envs.log_weights.
    logsumexp_rows` of that row (the same operations, without the batch bookkeeping, for the
    scalar loops of progressive correction)."""
    peak = float(values.max())
    if not math.isfinite(peak):
        return peak
    return peak + math.log(float(np.exp(values - peak).sum()))


def _log_ess(log_weights: FloatArray) -> float:
    """``log ESS`` of unnormalised ``(N,)`` log-weights."""
    return 2.0 * _logsumexp(log_weights) - _logsumexp(2.0 * log_weights)


@dataclass(frozen=True)
class BatchUpdate:
    """Outcome of :meth:`BeliefBatch.update`, one entry per belief (fields as
    :class:`~infoseek.envs.belief.BeliefUpdate`).

    Attributes:
        recovered: ``(K,)`` whether the degeneracy recovery ran.
        log_evidence: ``(K,)`` log evidence of the observations (0 for none).
        n_observations: ``(K,)`` observations incorporated.
        n_stages: ``(K,)`` progressive-correction stages of the update kept.
    """

    recovered: BoolArray
    log_evidence: FloatArray
    n_observations: NDArray[np.int64]
    n_stages: NDArray[np.int64]


def _angle_scale(space: TargetSpace) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Indices of periodic dims, their lows, periods and the harmonic (2 axial, 1 circular)."""
    idx = np.flatnonzero(space.periodic_mask)
    low = space.low_array[idx]
    period = space.high_array[idx] - low
    harmonic = np.where(space.axial_mask[idx], 2.0, 1.0)
    return idx, low, period, harmonic


class BeliefBatch:
    """``K`` weighted particle beliefs over one target space, stepped at once.

    Arguments are validated by the caller (:class:`~infoseek.envs.belief.ParticleBelief` or the
    environment core); the meaning of every setting is documented there.

    Args:
        particles: ``(K, N, d)`` particle states inside ``space``.
        log_weights: ``(K, N)`` normalised log-weights.
        space: The target space.
        rngs: ``K`` generators, one per belief.
        motion: Target motion model of every belief's ``predict``.
        resample_threshold: Resample when ``ESS < resample_threshold * N``.
        roughening: Roughening constant (0 disables).
        entropy_bins: Fixed entropy grid, or ``None`` for the adaptive one.
        recovery_fraction: Fraction of particles replaced by prior samples on degeneracy.
        tempering_ess: Progressive-correction floor (0 disables).
        max_tempering_stages: Most tempering stages per update.
        history: The observations each belief has kept so far (default: none, every belief
            fresh from the prior); the target of the tempering moves.
    """

    def __init__(
        self,
        particles: FloatArray,
        log_weights: FloatArray,
        space: TargetSpace,
        rngs: Sequence[np.random.Generator],
        *,
        motion: TargetMotion,
        resample_threshold: float,
        roughening: float,
        entropy_bins: tuple[int, ...] | None,
        recovery_fraction: float,
        tempering_ess: float,
        max_tempering_stages: int,
        history: ObservationHistory | None = None,
    ) -> None:
        if particles.ndim != 3 or log_weights.shape != particles.shape[:2]:
            raise ValueError(
                f"particles must be (K, N, d) and log_weights (K, N), got {particles.shape} "
                f"and {log_weights.shape}"
            )
        if len(rngs) != particles.shape[0]:
            raise ValueError(
                f"need one generator per belief ({particles.shape[0]}), got {len(rngs)}"
            )
        self.space = space
        # the space's arrays, built once (TargetSpace is frozen): bounds, periodic angles
        self._bounds = (space.low_array, space.high_array, space.periodic_mask)
        self._angles = _angle_scale(space)
        self.rngs = list(rngs)
        self.motion = motion
        self.resample_threshold = float(resample_threshold)
        self.roughening = float(roughening)
        self.entropy_bins = entropy_bins
        self.recovery_fraction = float(recovery_fraction)
        self.tempering_ess = float(tempering_ess)
        self.max_tempering_stages = int(max_tempering_stages)
        self.particles = particles
        self.set_log_weights(log_weights)
        if history is None:
            history = ObservationHistory(particles.shape[0])
        elif history.n_beliefs != particles.shape[0]:
            raise ValueError(f"history has {history.n_beliefs} beliefs, need {particles.shape[0]}")
        self.history = history

    # ------------------------------------------------------------------ state
    @property
    def n_beliefs(self) -> int:
        """Number of beliefs ``K``."""
        return int(self.particles.shape[0])

    @property
    def n_particles(self) -> int:
        """Particles per belief ``N``."""
        return int(self.particles.shape[1])

    def set_log_weights(
        self, log_weights: FloatArray, rows: NDArray[np.intp] | None = None
    ) -> None:
        """Store normalised ``(K, N)`` log-weights (or those of ``rows``) and their weights."""
        weights = normalised(log_weights)
        if rows is None or self._all_rows(rows):
            self.log_weights, self.weights = log_weights, weights
            return
        self.log_weights = self.log_weights.copy()
        self.weights = self.weights.copy()
        self.log_weights[rows] = log_weights
        self.weights[rows] = weights

    def set_rows(
        self, rows: NDArray[np.intp], particles: FloatArray, log_weights: FloatArray
    ) -> None:
        """Replace the particles and log-weights of ``rows`` (new arrays; views stay valid)."""
        if self._all_rows(rows):
            self.particles = particles
        else:
            self.particles = self.particles.copy()
            self.particles[rows] = particles
        self.set_log_weights(log_weights, rows)

    def restart_rows(
        self, rows: NDArray[np.intp], particles: FloatArray, log_weights: FloatArray
    ) -> None:
        """Start ``rows`` afresh: new particles drawn from the prior, no observations yet."""
        self.set_rows(rows, particles, log_weights)
        self.history.restart(rows)

    def _all_rows(self, rows: NDArray[np.intp]) -> bool:
        return rows.size == self.n_beliefs and bool(np.all(rows == np.arange(rows.size)))

    def ess(self, rows: NDArray[np.intp] | None = None) -> FloatArray:
        """``(K,)`` effective sample sizes ``1 / sum w^2`` (of ``rows`` only, if given)."""
        return ess_rows(self.weights if rows is None else self.weights[rows])

    # ------------------------------------------------------------------ filter cycle
    def predict(self, dt: float) -> None:
        """Propagate every belief's particles with the motion model (each its own stream)."""
        if isinstance(self.motion, StationaryTarget):
            return  # the identity: no draw, the arrays are never mutated in place
        moved = np.empty_like(self.particles)
        for k, rng in enumerate(self.rngs):
            out = np.asarray(
                self.motion.propagate(self.particles[k], self.space, float(dt), rng),
                dtype=np.float64,
            )
            if out.shape != moved.shape[1:] or not np.all(np.isfinite(out)):
                raise ValueError(
                    f"motion {self.motion!r} returned shape {out.shape} or non-finite states; "
                    f"expected finite {moved.shape[1:]}"
                )
            moved[k] = out
        self.particles = moved

    def log_likelihoods(
        self, sensor: Any, z: FloatArray, poses: FloatArray, received: BoolArray
    ) -> FloatArray:
        """``(K, N)`` summed log-likelihood of the observations each belief received.

        Args:
            sensor: The likelihood model (``log_likelihood(z, poses, particles)``; its
                compiled ``summed_log_likelihood`` with these arguments where it has one).
            z: ``(G, M, obs_dim)`` observations of ``G`` groups; belief ``k`` belongs to group
                ``k // (K / G)`` (every agent of one environment is one group).
            poses: ``(G, M, pose_dim)`` sensor poses.
            received: ``(K, M)`` which of its group's observations each belief received.
        """
        compiled = getattr(sensor, "summed_log_likelihood", None)
        if compiled is not None:
            total = compiled(z, poses, self.particles, received)
            if total is not None:
                return _checked_total(sensor, total)
        k_rows, n, d = self.particles.shape
        groups, m = z.shape[0], z.shape[1]
        per = k_rows // groups
        each = np.empty((m, k_rows, n))
        for g in range(groups):  # one likelihood call per group, over all its beliefs
            rows = self.particles[g * per : (g + 1) * per].reshape(per * n, d)
            loglik = _sensor_log_likelihood(sensor, z[g], poses[g], rows)
            each[:, g * per : (g + 1) * per] = loglik.reshape(m, per, n)
        # a non-received observation adds exactly 0.0: the sum is that of the received ones
        if not np.all(received):
            each = np.where(received.T[:, :, None], each, 0.0)
        return _checked_total(sensor, each.sum(axis=0))

    def update(
        self, sensor: Any, z: FloatArray, poses: FloatArray, received: BoolArray
    ) -> BatchUpdate:
        """Bayes update of every belief with the observations it received (eq. 4, eq. 14).

        Args are those of :meth:`log_likelihoods`. A belief that received nothing is unchanged.
        """
        k_rows = self.n_beliefs
        counts = received.sum(axis=1).astype(np.int64)
        result = BatchUpdate(
            recovered=np.zeros(k_rows, dtype=bool),
            log_evidence=np.zeros(k_rows),
            n_observations=counts.copy(),
            n_stages=np.where(counts > 0, 1, 0).astype(np.int64),
        )
        live = np.flatnonzero(counts > 0)
        if live.size == 0:
            return result
        loglik = self.log_likelihoods(sensor, z, poses, received)
        tempering = self._tempering_on() and self.max_tempering_stages > 1
        log_weights, weights, log_z, accept = bayes_step(
            self.log_weights, loglik, counts > 0, self.tempering_ess if tempering else None
        )
        plain = np.flatnonzero(accept)
        result.log_evidence[plain] = log_z[plain]
        rows, row_particles, row_log_weights = [], [], []
        special = [int(k) for k in live if not accept[k]]
        for k in special:  # progressive correction or recovery: that belief alone
            g = k // (k_rows // z.shape[0])
            mask = received[k]
            changed = self._update_row(k, sensor, z[g][mask], poses[g][mask], loglik[k], result)
            if changed is not None:
                rows.append(k)
                row_particles.append(changed[0])
                row_log_weights.append(changed[1])
        if plain.size == k_rows:
            self.log_weights, self.weights = log_weights, weights
        elif plain.size or rows:
            self._write_rows(plain, log_weights, weights, rows, row_particles, row_log_weights)
        if self._moves_on():  # only the tempering moves read the history
            self.history.append(sensor, z, poses, received)
            dropped = np.flatnonzero((counts > 0) & (result.n_observations == 0))
            if dropped.size:
                self.history.drop_latest(dropped)
        return result

    def _tempering_on(self) -> bool:
        return self.tempering_ess > 0.0 and self.resample_threshold > 0.0 and self.n_particles > 1

    def _moves_on(self) -> bool:
        """Whether an update can run tempering moves (which target the kept observations)."""
        return self._tempering_on() and self.max_tempering_stages > 1 and self.roughening > 0.0

    def _write_rows(
        self,
        plain: NDArray[np.intp],
        plain_log_weights: FloatArray,
        plain_weights: FloatArray,
        rows: list[int],
        particles: list[FloatArray],
        log_weights: list[FloatArray],
    ) -> None:
        """Write an update's rows into new arrays, each array copied once (views handed out
        earlier stay valid): the ``plain`` rows' log-weights and weights, and the ``(N, d)``
        particles and ``(N,)`` log-weights of the tempered ``rows``."""
        self.log_weights = self.log_weights.copy()
        self.weights = self.weights.copy()
        self.log_weights[plain] = plain_log_weights
        self.weights[plain] = plain_weights
        if rows:
            self.particles = self.particles.copy()
            self.particles[rows] = np.stack(particles)
            self.log_weights[rows] = np.stack(log_weights)
            self.weights[rows] = normalised(self.log_weights[rows])

    def _update_row(
        self,
        k: int,
        sensor: Any,
        z: FloatArray,
        poses: FloatArray,
        loglik: FloatArray,
        result: BatchUpdate,
    ) -> tuple[FloatArray, FloatArray] | None:
        """The tempered update of belief ``k`` with degeneracy recovery (module docstring of
        :mod:`infoseek.envs.belief`); writes the outcome into ``result`` and returns belief
        ``k``'s new ``(particles, log_weights)`` (``None``: unchanged, its readings dropped).
        It reads row ``k`` only, so the caller may write every row's outcome at once."""
        particles, log_weights, log_evidence, stages = self._tempered_update(
            k, sensor, z, poses, self.particles[k], self.log_weights[k], loglik
        )
        result.log_evidence[k] = log_evidence
        if np.isfinite(log_evidence) and log_evidence >= DEGENERATE_LOG_EVIDENCE:
            result.n_stages[k] = stages
            return particles, log_weights
        result.recovered[k] = True
        n = self.n_particles
        n_fresh = min(n, max(1, math.ceil(self.recovery_fraction * n)))
        survivors = systematic_resample(self.weights[k], self.rngs[k], n - n_fresh)
        candidate = np.concatenate(
            [self.particles[k][survivors], self.space.sample_uniform(n_fresh, self.rngs[k])]
        )
        loglik = self._row_log_likelihood(sensor, z, poses, candidate)
        particles, log_weights, retry, stages = self._tempered_update(
            k, sensor, z, poses, candidate, np.full(n, -math.log(n)), loglik
        )
        if np.isfinite(retry) and retry >= DEGENERATE_LOG_EVIDENCE:
            result.n_stages[k] = stages
            return particles, log_weights
        result.n_observations[k] = 0  # still impossible: drop them, keep the prior belief
        result.n_stages[k] = 0
        return None

    def _past_log_likelihood(
        self, past: list[tuple[Any, FloatArray, FloatArray]], particles: FloatArray
    ) -> FloatArray:
        """``H``: ``(N,)`` log-likelihood of a belief's kept observations at ``particles``."""
        total = np.zeros(particles.shape[0])
        for sensor, z, poses in past:
            total += self._row_log_likelihood(sensor, z, poses, particles)
        return total

    @staticmethod
    def _row_log_likelihood(
        sensor: Any, z: FloatArray, poses: FloatArray, particles: FloatArray
    ) -> FloatArray:
        """``(N,)`` log-likelihood of the ``(M, obs_dim)`` readings ``z`` at ``(N, d)``
        ``particles``, summed over the readings (the sensor's compiled
        ``summed_log_likelihood`` where it has one, as one group of one belief)."""
        compiled = getattr(sensor, "summed_log_likelihood", None)
        if compiled is not None:
            every = np.ones((1, z.shape[0]), dtype=bool)
            total = compiled(z[None], poses[None], particles[None], every)
            if total is not None:
                return _checked_total(sensor, total[0])
        loglik = _sensor_log_likelihood(sensor, z, poses, particles)
        return _checked_total(sensor, loglik.sum(axis=0))

    def _tempered_update(
        self,
        k: int,
        sensor: Any,
        z: FloatArray,
        poses: FloatArray,
        particles: FloatArray,
        log_weights: FloatArray,
        loglik: FloatArray,
    ) -> tuple[FloatArray, FloatArray, float, int]:
        """Progressive-correction Bayes update of belief ``k``'s ``(N, d)`` particles; returns
        ``(particles, normalised log-weights, log evidence, stages)`` (log evidence ``-inf``
        when some stage had no particle of non-zero likelihood)."""
        n = particles.shape[0]
        tempering = self._tempering_on()
        remaining, log_evidence, stage = 1.0, 0.0, 0
        past_loglik: FloatArray | None = None  # of the kept observations, once moves ran
        while True:
            stage += 1
            full = log_weights + remaining * loglik
            log_z = _logsumexp(full)
            if not np.isfinite(log_z):
                return particles, log_weights, -math.inf, stage
            log_floor = math.log(self.tempering_ess) + _log_ess(log_weights) if tempering else 0.0
            if not tempering or stage >= self.max_tempering_stages or _log_ess(full) >= log_floor:
                return particles, full - log_z, log_evidence + log_z, stage
            lam = tempering_exponent(
                log_weights, loglik, remaining, log_floor, TEMPERING_BISECTION_STEPS
            )
            partial = log_weights + lam * loglik
            log_z = _logsumexp(partial)
            log_evidence += log_z
            idx = systematic_resample(np.exp(partial - log_z), self.rngs[k])
            particles, loglik = particles[idx], loglik[idx]
            if past_loglik is not None:
                past_loglik = past_loglik[idx]
            remaining -= lam
            if self.roughening > 0.0:
                particles, loglik, past_loglik = self._tempered_move(
                    k, sensor, z, poses, particles, loglik, 1.0 - remaining, past_loglik
                )
            log_weights = np.full(n, -math.log(n))

    def _tempered_move(
        self,
        k: int,
        sensor: Any,
        z: FloatArray,
        poses: FloatArray,
        particles: FloatArray,
        loglik: FloatArray,
        exponent: float,
        past_loglik: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``TEMPERING_MOVE_SWEEPS`` Metropolis sweeps of belief ``k``'s resampled particles
        (proposal: the roughening jitter at a shrinking scale) with target the stage's exact
        posterior ``p_0 * (likelihood of the kept past observations) * L^exponent``; returns
        the particles, their ``L`` and their past log-likelihood (``past_loglik``, when given,
        is that of ``particles``: an earlier stage's, carried through its resampling, the
        same numbers as evaluating the history again)."""
        particles, loglik = particles.copy(), loglik.copy()
        past = self.history.observations(k)
        if past_loglik is None:
            past_loglik = self._past_log_likelihood(past, particles)
        else:
            past_loglik = past_loglik.copy()
        scale = TEMPERING_MOVE_SCALE
        for _ in range(TEMPERING_MOVE_SWEEPS):
            proposal = self.roughen(particles[None], [self.rngs[k]], move_scale=scale)[0]
            proposal_loglik = self._row_log_likelihood(sensor, z, poses, proposal)
            proposal_past = self._past_log_likelihood(past, proposal)
            log_u = np.log(self.rngs[k].random(particles.shape[0]))
            metropolis_accept(
                particles,
                loglik,
                past_loglik,
                proposal,
                proposal_loglik,
                proposal_past,
                log_u,
                exponent,
            )
            scale *= TEMPERING_MOVE_SHRINK
        return particles, loglik, past_loglik

    def resample_if_needed(self) -> BoolArray:
        """Systematic resampling plus roughening of every belief whose
        ``ESS < resample_threshold * N`` (uniform weights never); returns ``(K,)`` which did."""
        k_rows, n = self.n_beliefs, self.n_particles
        if self.resample_threshold <= 0.0 or n == 1:
            return np.zeros(k_rows, dtype=bool)
        need = self.ess() < self.resample_threshold * n * (1.0 - 1e-9)
        rows = np.flatnonzero(need)
        if rows.size == 0:
            return need
        uniforms = draw_uniforms([self.rngs[k] for k in rows])
        idx = systematic_resample_rows(self.weights[rows], uniforms)
        particles = gather_rows(self.particles, rows, idx)
        if self.roughening > 0.0:
            particles = self.roughen(particles, [self.rngs[k] for k in rows])
        self.set_rows(rows, particles, np.full((rows.size, n), -math.log(n)))
        return need

    def roughen(
        self,
        particles: FloatArray,
        rngs: Sequence[np.random.Generator],
        move_scale: float | None = None,
    ) -> FloatArray:
        """Gordon roughening of ``(R, N, d)`` equally weighted particle sets, row ``r`` drawing
        from ``rngs[r]`` (see :mod:`infoseek.envs.belief`). With ``move_scale`` the jitter is a
        tempering-move proposal: ``move_scale`` times each coordinate's standard deviation."""
        r_rows, n, d = particles.shape
        if move_scale is None:
            spread = coordinate_ranges(particles)
            idx, low, period, harmonic = self._angles
            if idx.size:
                angles = particles[:, :, idx]
                spread[:, idx] = circular_ranges(angles, low, period, harmonic)
        else:
            spread = self._spread(np.ascontiguousarray(particles.transpose(0, 2, 1)))
        box_low, box_high, periodic = self._bounds
        width = box_high - box_low
        if move_scale is None:
            # floor: a fully collapsed set (spread 0) would otherwise never be separated again
            spread = np.maximum(spread, SPREAD_FLOOR * width)
            std = self.roughening * spread * n ** (-1.0 / d)
        else:
            std = move_scale * np.maximum(spread, 1e-12 * width)
        return jitter(particles, std, rngs, box_low, box_high, periodic)

    def _spread(self, columns: FloatArray) -> FloatArray:
        """``(R, d)`` standard deviation of each coordinate of particles given as ``(R, d, N)``
        columns (periodic ones: of the residuals about the circular mean)."""
        idx, low, period, harmonic = self._angles
        r_rows, _, n = columns.shape
        spread = columns.std(axis=2)
        if idx.size:
            uniform = np.full((r_rows, n), 1.0 / n)
            angles = columns[:, idx].transpose(0, 2, 1)
            center = circular_means(angles, uniform, low, period, harmonic)
            half = period / (2.0 * harmonic)  # residuals live in [-half, half)
            resid = np.mod(
                columns[:, idx] - center[:, :, None] + half[:, None], 2.0 * half[:, None]
            )
            spread[:, idx] = resid.std(axis=2)
        return spread

    # ------------------------------------------------------------------ estimates
    # Each takes ``rows`` (default all beliefs) and returns one entry per row.
    def _rows(self, rows: NDArray[np.intp] | None) -> tuple[FloatArray, FloatArray]:
        if rows is None:
            return self.particles, self.weights
        return self.particles[rows], self.weights[rows]

    def mmse(self, rows: NDArray[np.intp] | None = None) -> FloatArray:
        """``(K, d)`` MMSE estimates (eq. 12; circular/axial means of periodic angles)."""
        particles, weights = self._rows(rows)
        est = weighted_means(particles, weights)
        idx, low, period, harmonic = self._angles
        if idx.size:
            est[:, idx] = circular_means(particles[:, :, idx], weights, low, period, harmonic)
        return est

    def mass_within(
        self, radius: float, centers: FloatArray, rows: NDArray[np.intp] | None = None
    ) -> FloatArray:
        """``(K,)`` posterior mass whose position lies within ``radius`` of ``(K, >= 2)``
        ``centers`` (their position part)."""
        particles, weights = self._rows(rows)
        return masses_within(particles, weights, centers, radius)

    def entropy(self, rows: NDArray[np.intp] | None = None) -> FloatArray:
        """``(K,)`` histogram entropy estimates (eq. 6; :mod:`infoseek.envs.entropy`)."""
        particles, weights = self._rows(rows)
        if self.entropy_bins is None:
            return adaptive_histogram_entropy_rows(particles, weights, self.space)
        bins = self.entropy_bins
        pairs = zip(particles, weights, strict=True)
        return np.array([fixed_grid_entropy(p, w, self.space, bins) for p, w in pairs])

    def position_spread(
        self, centers: FloatArray, rows: NDArray[np.intp] | None = None
    ) -> FloatArray:
        """``(K, 3)`` weighted ``(s_x, s_y, rho)`` of the planar positions about ``(K, >= 2)``
        ``centers`` (the MMSE estimates): standard deviations and correlation, ``rho = 0``
        where a deviation is 0."""
        particles, weights = self._rows(rows)
        offsets = particles[:, :, :2] - centers[:, None, :2]
        second = np.einsum("kn,kni,knj->kij", weights, offsets, offsets)
        deviations = np.sqrt(np.maximum(np.diagonal(second, axis1=1, axis2=2), 0.0))
        scale = deviations[:, 0] * deviations[:, 1]
        rho = np.divide(second[:, 0, 1], scale, out=np.zeros_like(scale), where=scale > 0.0)
        return np.column_stack([deviations, np.clip(rho, -1.0, 1.0)])

    def mass_grid(self, shape: tuple[int, int], rows: NDArray[np.intp] | None = None) -> FloatArray:
        """``(K, gx, gy)`` posterior position mass on a coarse grid over the position box."""
        particles, weights = self._rows(rows)
        low = self.space.low_array[[0, 1]]
        return mass_grids(particles, weights, low, self.space.high_array[[0, 1]] - low, shape)


def _sensor_log_likelihood(
    sensor: Any, z: FloatArray, poses: FloatArray, particles: FloatArray
) -> FloatArray:
    """``(M, N)`` ``sensor.log_likelihood`` of ``(N, d)`` particles, its shape checked."""
    loglik = np.asarray(sensor.log_likelihood(z, poses, particles), dtype=np.float64)
    if loglik.shape != (z.shape[0], particles.shape[0]):
        raise ValueError(
            f"sensor {getattr(sensor, 'name', sensor)!r}: log_likelihood returned shape "
            f"{loglik.shape}, expected {(z.shape[0], particles.shape[0])}"
        )
    return loglik


def _checked_total(sensor: Any, total: FloatArray) -> FloatArray:
    """``total`` (summed log-likelihoods), unless it holds NaN or +inf (then ``ValueError``)."""
    if has_nan_or_plus_inf(total):
        raise ValueError(
            f"sensor {getattr(sensor, 'name', sensor)!r}: log_likelihood returned NaN or +inf"
        )
    return total
