"""The belief entropy estimate (eq. 6) against closed forms: the uniform prior's log-volume for
any particle count on both environments, Gaussian beliefs, importance-weighted particles, a
belief across the wrap of a periodic angle."""

from __future__ import annotations

import math

import numpy as np
import pytest

import infoseek.envs
from infoseek.envs.belief import ParticleBelief
from infoseek.envs.entropy import adaptive_histogram_entropy, fixed_grid_entropy
from infoseek.envs.targets import TargetSpace

PLANAR = TargetSpace.planar()
ORIENTED = TargetSpace.planar_with_orientation()


@pytest.mark.parametrize("env_id", ["bearings_v0", "beacon_v0"])
@pytest.mark.parametrize("n_particles", [500, 1000, 2000, 5000, 10_000])
def test_entropy_at_the_uniform_prior_is_the_log_volume(env_id: str, n_particles: int) -> None:
    env = infoseek.envs.make(env_id, n_agents=2, n_particles=n_particles)
    true = math.log(env.unwrapped.config.space.volume)  # 7.38 (bearings), 9.22 (beacon)
    values = []
    for seed in range(5):
        _, infos = env.reset(seed=seed)
        values += [infos[a]["entropy"] for a in env.agents]
    assert np.all(np.abs(np.asarray(values) - true) < 0.02 * true)  # the bound
    assert abs(np.mean(values) - true) < 0.005 * true  # and in fact far tighter
    env.close()


def test_the_old_fixed_grid_depends_on_the_particle_count() -> None:
    """The failure the adaptive grid removes: plug-in on 40 x 40 x 16 cells reads ~6.6 nats."""
    rng = np.random.default_rng(0)
    particles = ORIENTED.sample_uniform(2000, rng)
    weights = np.full(2000, 1 / 2000)
    fixed = fixed_grid_entropy(particles, weights, ORIENTED, (40, 40, 16))
    assert fixed < math.log(ORIENTED.volume) - 2.0
    adaptive = adaptive_histogram_entropy(particles, weights, ORIENTED)
    assert adaptive == pytest.approx(math.log(ORIENTED.volume), rel=0.01)


@pytest.mark.parametrize("sigma", [0.05, 0.3, 2.0])
def test_gaussian_belief_reads_its_closed_form_entropy(sigma: float) -> None:
    rng = np.random.default_rng(1)
    particles = np.clip(rng.normal(20.0, sigma, size=(5000, 2)), 0.0, 40.0)
    belief = ParticleBelief(particles, PLANAR, rng)
    assert belief.entropy() == pytest.approx(math.log(2 * math.pi * math.e * sigma**2), abs=0.05)


def test_importance_weighted_particles_read_the_weighted_density() -> None:
    rng = np.random.default_rng(2)
    particles = PLANAR.sample_uniform(10_000, rng)
    sigma = 5.0
    log_w = -np.sum((particles - 20.0) ** 2, axis=1) / (2 * sigma**2)
    belief = ParticleBelief(particles, PLANAR, rng, log_weights=log_w)
    assert belief.ess < 2500
    assert belief.entropy() == pytest.approx(math.log(2 * math.pi * math.e * sigma**2), abs=0.15)


def test_a_belief_across_the_angle_wrap_reads_as_one_piece() -> None:
    rng = np.random.default_rng(3)
    inside = np.column_stack(
        [
            rng.normal(20.0, 0.5, 10_000),
            rng.normal(20.0, 0.5, 10_000),
            rng.normal(np.pi, 0.2, 10_000),
        ]
    )
    across = inside.copy()
    across[:, 2] = np.mod(across[:, 2] - np.pi, 2 * np.pi)  # centred on the wrap point 0
    h_inside = ParticleBelief(inside, ORIENTED, rng).entropy()
    h_across = ParticleBelief(across, ORIENTED, rng).entropy()
    closed = 1.5 * math.log(2 * math.pi * math.e) + math.log(0.5 * 0.5 * 0.2)
    # histogram bias in 3-D: about d h^2 / (24 sigma^2) for cells of side h ~ 0.65 sigma
    assert h_inside == pytest.approx(closed, abs=0.08)
    assert h_across == pytest.approx(h_inside, abs=1e-6)


def test_identical_particles_give_a_finite_floor() -> None:
    belief = ParticleBelief(np.full((500, 2), 3.3), PLANAR, np.random.default_rng(0))
    # the box at its floor (1e-3 of each width), cut into 8 x 8 (~ 500 / 8) cells, all mass in
    # one of them (Miller-Madow adds nothing for one occupied cell)
    floor = math.log(PLANAR.volume * (1e-3 / 8) ** 2)
    assert belief.entropy() == pytest.approx(floor, abs=1e-9)
