r"""The batched simulation: ``B`` independent search episodes stepped at once as arrays.

:class:`SearchCore` is the one implementation of the environment's dynamics, measurement,
communication, filtering, reward and termination (the model and the binding step order are
documented in :mod:`infoseek.envs.search_env`). The PettingZoo environment is a view of a core
with ``B = 1``; :func:`infoseek.baselines.make_vec` trains on a core with ``B`` copies.

Arrays are batch-first: vehicle states ``(B, A, state_dim)``, targets ``(B, d)``,
measurements ``(B, A, obs_dim)``, receptions ``(B, A, A)``, rewards ``(B, A)``, and the
``K = B * A`` beliefs (environment ``b``'s agent ``i`` is belief ``b * A + i``) live in one
:class:`~infoseek.envs.belief_batch.BeliefBatch`.

Randomness: every environment ``b`` owns a ``numpy.random.SeedSequence``; its reset spawns, in
this order, the target, observation-noise, message-loss and vehicle streams and one stream
per agent's belief, exactly as a lone environment does. Environment ``b`` of a core therefore
follows the same trajectory as a PettingZoo environment reset with the same seed and given the
same actions, bit for bit (the belief batch is row-independent, and every random draw is made
from its own environment's or belief's stream).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.belief import check_belief_settings
from infoseek.envs.belief_batch import BatchUpdate, BeliefBatch
from infoseek.envs.config import SearchConfig
from infoseek.envs.targets import StationaryTarget

FloatArray = NDArray[np.float64]
ObsArray = NDArray[np.float32]
BoolArray = NDArray[np.bool_]

__all__ = ["SearchCore", "StepResult", "check_seed", "separation_violations"]


def check_seed(seed: object, name: str = "seed") -> None:
    """Raise unless ``seed`` is ``None`` or a non-negative integer (a NumPy root seed).

    Raises:
        TypeError: ``seed`` is not an integer (a bool counts as not one).
        ValueError: ``seed`` is negative.
    """
    if seed is None:
        return
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise TypeError(f"{name} must be None or a non-negative integer, got {seed!r}")
    if seed < 0:
        raise ValueError(f"{name} must be None or a non-negative integer, got {seed!r}")


def separation_violations(positions: FloatArray, min_separation: float) -> NDArray[np.int64]:
    """Per-agent count of violated pairs of eq. 2 (distance strictly below ``min_separation``).

    Args:
        positions: ``(..., A, 2)`` vehicle positions (any leading batch shape, e.g. ``(B,)``).
        min_separation: The minimum separation :math:`\\bar d`.

    Returns:
        ``(..., A)`` number of other vehicles closer than ``min_separation`` to each vehicle.
    """
    diff = positions[..., :, None, :] - positions[..., None, :, :]
    close = np.sqrt(np.einsum("...ijk,...ijk->...ij", diff, diff)) < min_separation
    diagonal = np.arange(positions.shape[-2])
    close[..., diagonal, diagonal] = False
    return close.sum(axis=-1).astype(np.int64)


@dataclass(frozen=True)
class StepResult:
    """What one batched step (or reset) produced; ``B`` environments, ``A`` agents.

    Attributes:
        observations: ``(B, A, obs_dim)`` float32 agent observations.
        rewards: ``(B, A)`` rewards (zeros at reset).
        terminated: ``(B,)`` every agent localised (with ``terminate_on_localization``).
        truncated: ``(B,)`` ``max_cycles`` reached (and not terminated).
    """

    observations: ObsArray
    rewards: FloatArray
    terminated: BoolArray
    truncated: BoolArray


class SearchCore:
    """``B`` search episodes of one :class:`~infoseek.envs.config.SearchConfig`.

    Args:
        config: The validated settings.
        n_envs: Number of environments ``B >= 1``.
    """

    def __init__(self, config: SearchConfig, n_envs: int = 1) -> None:
        if isinstance(n_envs, bool) or not isinstance(n_envs, int | np.integer) or n_envs < 1:
            raise ValueError(f"n_envs must be an integer >= 1, got {n_envs!r}")
        self.config = config
        self.n_envs = int(n_envs)
        self._filter_settings = check_belief_settings(
            motion=config.target_motion,
            resample_threshold=config.resample_threshold,
            roughening=config.roughening,
            entropy_bins=config.entropy_bins,
            recovery_fraction=0.5,
            tempering_ess=config.tempering_ess,
            max_tempering_stages=20,
            space=config.space,
        )
        b, a, n, d = self.n_envs, config.n_agents, config.n_particles, config.space.dim
        self.seed_sequences: list[np.random.SeedSequence | None] = [None] * b
        self.target_rngs: list[np.random.Generator] = [np.random.default_rng(0)] * b
        self.obs_rngs: list[np.random.Generator] = [np.random.default_rng(0)] * b
        self.message_rngs: list[np.random.Generator] = [np.random.default_rng(0)] * b
        self.targets = np.zeros((b, d))
        self.states = np.zeros((b, a, len(config.vehicle.state_names)))
        self.cycles = np.zeros(b, dtype=np.int64)
        self.entropies = np.zeros((b, a))
        self.recovered = np.zeros((b, a), dtype=bool)
        self.violations = np.zeros((b, a), dtype=np.int64)
        self.ess = np.full((b, a), float(n))
        self.masses = np.zeros((b, a))
        self.estimates = np.zeros((b, a, d))
        self.grids = np.zeros((b, a, config.belief_grid[0] * config.belief_grid[1]))
        self.moments = np.zeros((b, a, 4 if config.belief_moments else 0))
        self.last_measurements: FloatArray | None = None
        self.last_reception: BoolArray | None = None
        self.beliefs = BeliefBatch(
            np.zeros((b * a, n, d)),
            np.full((b * a, n), -math.log(n)),
            config.space,
            [np.random.default_rng(0)] * (b * a),
            **self._filter_settings,
        )
        self.started = np.zeros(b, dtype=bool)

    # ----------------------------------------------------------------------------- reset
    def reset(
        self,
        envs: NDArray[np.intp] | list[int],
        seeds: list[int | None],
        targets: list[FloatArray | None] | None = None,
    ) -> None:
        """Start new episodes in environments ``envs``.

        Args:
            envs: Indices of the environments to reset.
            seeds: One root seed (or ``None``: continue that environment's seed sequence, or OS
                entropy on its first reset) per environment.
            targets: Optional true target per environment (already validated), used instead of
                the prior draw; the random streams are the same either way.
        """
        for seed in seeds:  # before any state changes
            check_seed(seed)
        config = self.config
        a, n = config.n_agents, config.n_particles
        envs = [int(e) for e in envs]
        rows: list[int] = []
        particles, rngs = [], []
        for position, b in enumerate(envs):
            seed = seeds[position]
            if seed is not None or self.seed_sequences[b] is None:
                self.seed_sequences[b] = np.random.SeedSequence(seed)
            sequence = self.seed_sequences[b]
            assert sequence is not None
            streams = [np.random.default_rng(s) for s in sequence.spawn(4 + a)]
            self.target_rngs[b], self.obs_rngs[b], self.message_rngs[b] = streams[:3]
            self.targets[b] = config.space.sample_uniform(1, self.target_rngs[b])[0]
            if targets is not None and targets[position] is not None:
                self.targets[b] = targets[position]
            self.states[b] = np.asarray(
                config.vehicle.initial_states(config.start_positions.copy(), streams[3]),
                dtype=np.float64,
            )
            for i, rng in enumerate(streams[4:]):
                particles.append(config.space.wrap(config.space.sample_uniform(n, rng)))
                rngs.append(rng)
                rows.append(b * a + i)
        index = np.array(rows, dtype=np.intp)
        self.beliefs.restart_rows(
            index, np.stack(particles), np.full((index.size, n), -math.log(n))
        )
        for row, rng in zip(rows, rngs, strict=True):
            self.beliefs.rngs[row] = rng
        self.cycles[envs] = 0
        self.recovered[envs] = False
        self.entropies.reshape(-1)[index] = self.beliefs.entropy(index)
        positions = config.vehicle.position(self.states[envs])
        self.violations[envs] = separation_violations(positions, config.min_separation)
        self._summarise(index)
        self.started[envs] = True

    # ----------------------------------------------------------------------------- step
    def step(self, controls: FloatArray) -> StepResult:
        """Advance every environment one step (order of :mod:`infoseek.envs.search_env`).

        Args:
            controls: ``(B, A, control_dim)`` controls inside the vehicle's bounds
                (:meth:`~infoseek.envs.config.SearchConfig.decode_actions`).
        """
        if not np.all(self.started):
            raise RuntimeError("step() before every environment was reset: call reset() first")
        config = self.config
        b, a = self.n_envs, config.n_agents
        shape = self.states.shape
        self.states = np.asarray(
            config.vehicle.step(
                self.states.reshape(b * a, -1), controls.reshape(b * a, -1), config.dt
            ),
            dtype=np.float64,
        ).reshape(shape)
        if not isinstance(config.target_motion, StationaryTarget):  # the identity: no draw
            for e in range(b):
                self.targets[e] = config.target_motion.propagate(
                    self.targets[e][None, :], config.space, config.dt, self.target_rngs[e]
                )[0]
        positions = config.vehicle.position(self.states)
        measurements = self._measure(positions)
        reception = self._reception(positions)
        self.last_measurements = measurements
        self.last_reception = reception

        previous = self.entropies.copy()
        self.beliefs.predict(config.dt)
        update: BatchUpdate = self.beliefs.update(
            config.filter_sensor, measurements, positions, reception.reshape(b * a, a)
        )
        self.recovered = update.recovered.reshape(b, a)
        self.beliefs.resample_if_needed()
        self.entropies = self.beliefs.entropy().reshape(b, a)
        self.cycles += 1
        self.violations = separation_violations(positions, config.min_separation)
        self._summarise(None)

        rewards = (previous - self.entropies) - config.separation_penalty * self.violations
        localised = np.zeros(b, dtype=bool)
        if config.terminate_on_localization:
            localised = np.all(self.masses >= config.localization_mass, axis=1)
        truncated = (self.cycles >= config.max_cycles) & ~localised
        return StepResult(self.observations(), rewards, localised, truncated)

    def _measure(self, positions: FloatArray) -> FloatArray:
        """``(B, A, obs_dim)`` noisy measurements, each environment from its own stream."""
        config = self.config
        a, obs_dim, d = config.n_agents, config.sensor.obs_dim, config.space.dim
        out = np.empty((self.n_envs, a, obs_dim))
        for e in range(self.n_envs):
            out[e] = np.asarray(
                config.sensor.sample(
                    positions[e], np.broadcast_to(self.targets[e], (a, d)), self.obs_rngs[e]
                ),
                dtype=np.float64,
            ).reshape(a, obs_dim)
        return out

    def _reception(self, positions: FloatArray) -> BoolArray:
        """``(B, A, A)``: ``[b, i, j]`` is True when agent i of env b receives j's observation."""
        config = self.config
        a = config.n_agents
        # drawn every step, whatever the settings, so the streams stay aligned
        uniforms = np.stack([rng.random((a, a)) for rng in self.message_rngs])
        reception = uniforms >= config.message_loss
        if config.message_loss >= 1.0:
            reception[:] = False
        if math.isfinite(config.comm_range):
            diff = positions[:, :, None, :] - positions[:, None, :, :]
            reception &= np.sqrt(np.einsum("bijk,bijk->bij", diff, diff)) <= config.comm_range
        reception[:, np.arange(a), np.arange(a)] = True
        return reception

    # ----------------------------------------------------------------------------- outputs
    def _summarise(self, rows: NDArray[np.intp] | None) -> None:
        """Refresh the belief summaries (grids, MMSE estimates, masses, ESS) of ``rows``."""
        config = self.config
        k = slice(None) if rows is None else rows
        estimates = self.beliefs.mmse(rows)
        self.estimates.reshape(-1, config.space.dim)[k] = estimates
        self.masses.reshape(-1)[k] = self.beliefs.mass_within(
            config.localization_radius, estimates, rows
        )
        grids = self.beliefs.mass_grid(config.belief_grid, rows)
        self.grids.reshape(-1, self.grids.shape[-1])[k] = grids.reshape(grids.shape[0], -1)
        self.ess.reshape(-1)[k] = self.beliefs.ess(rows)
        if config.belief_moments:
            moments = self.moments.reshape(-1, 4)
            moments[k, :3] = self.beliefs.position_spread(estimates, rows)
            moments[k, 3] = self.masses.reshape(-1)[k]

    def observations(self) -> ObsArray:
        """``(B, A, obs_dim)`` float32 observations (layout ``config.observation_layout``)."""
        config = self.config
        b, a = self.n_envs, config.n_agents
        positions = config.vehicle.position(self.states)
        relative = positions[:, None, :, :] - positions[:, :, None, :]  # [b, i, j] = x_j - x_i
        others = relative[:, ~np.eye(a, dtype=bool)].reshape(b, a, 2 * (a - 1))
        blocks = [self.states, others, self.grids, self.estimates, self.moments]
        flat = np.concatenate(blocks, axis=2)
        out = flat.astype(np.float32)  # float32 rounding can step past a bound: clip
        np.maximum(out, config.obs_low, out=out)
        return np.minimum(out, config.obs_high, out=out)

    def state(self, env: int) -> ObsArray:
        """Environment ``env``'s centralised state (layout ``config.state_layout``)."""
        config = self.config
        state = np.concatenate(
            [
                self.states[env].ravel(),
                self.grids[env].ravel(),
                self.estimates[env].ravel(),
                self.masses[env],
            ]
        )
        return np.clip(state.astype(np.float32), config.state_low, config.state_high)
