"""Tests of the decentralised penalty coordination (section III.D, eq. 27-30)."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.planners.coordination import (
    PenaltySettings,
    coordinate,
    horizon_separation_penalty,
    max_violation,
    separation_penalty,
)
from infoseek.planners.refinement import GridRefiner

GRID = np.linspace(-1.0, 1.0, 41)
OFFSETS = np.stack(np.meshgrid(GRID, GRID, indexing="ij"), axis=-1).reshape(-1, 2)


def _attracted(starts: np.ndarray, goals: np.ndarray):
    """Vehicles that can move by any offset in [-1, 1]^2; utility -||x - goal||^2."""
    controls = [OFFSETS.copy() for _ in starts]
    positions = [s + OFFSETS for s in starts]
    utilities = [-np.sum((p - g) ** 2, axis=1) for p, g in zip(positions, goals, strict=True)]
    return controls, positions, utilities


def test_penalty_matches_closed_form() -> None:
    rng = np.random.default_rng(0)
    p = rng.uniform(-2, 2, (7, 2))
    q = rng.uniform(-2, 2, (5, 2))
    for gamma in (2.0, 3.0, 2.5):
        expected = np.array(
            [sum(max(0.0, 1.3 - float(np.hypot(*(pi - qj)))) ** gamma for qj in q) for pi in p]
        )
        np.testing.assert_allclose(separation_penalty(p, q, 1.3, gamma), expected, rtol=1e-12)
    assert np.all(separation_penalty(p, np.empty((0, 2)), 1.0) == 0)
    # Horizon form with H = 1 is the one-step penalty; H = 2 sums both steps.
    np.testing.assert_allclose(
        horizon_separation_penalty(p[:, None, :], q[:, None, :], 1.3), separation_penalty(p, q, 1.3)
    )
    tracks_p = np.stack([p, p + 0.1], axis=1)
    tracks_q = np.stack([q, q - 0.2], axis=1)
    np.testing.assert_allclose(
        horizon_separation_penalty(tracks_p, tracks_q, 1.3),
        separation_penalty(p, q, 1.3) + separation_penalty(p + 0.1, q - 0.2, 1.3),
    )


@pytest.mark.parametrize("schedule", ["jacobi", "gauss-seidel"])
def test_penalty_separates_vehicles_pulled_to_one_point(schedule: str) -> None:
    starts = np.array([[-0.3, 0.0], [0.3, 0.05]])
    controls, positions, utilities = _attracted(starts, np.zeros((2, 2)))
    # Unpenalised, both go to the origin (independent argmax): violation ~ d_bar.
    independent = np.array([positions[i][np.argmax(utilities[i])] for i in range(2)])
    assert np.linalg.norm(independent[0] - independent[1]) < 0.1
    settings = PenaltySettings(
        min_separation=1.0, schedule=schedule, max_iterations=40, feasibility_tolerance=0.02
    )
    result = coordinate(controls, positions, lambda i, plans: utilities[i], settings)
    assert result.converged
    gap = np.linalg.norm(result.positions[0] - result.positions[1])
    assert gap >= 1.0 - 0.02
    # Not pushed further than necessary: the pair stays centred near the goal.
    assert gap <= 1.2
    assert result.max_violation <= 0.02
    assert result.beta < settings.beta  # the penalty had to be tightened
    assert result.agreement_residual == 0.0
    np.testing.assert_array_equal(result.copies, np.tile(result.indices, (2, 1)))


@pytest.mark.parametrize("schedule", ["jacobi", "gauss-seidel"])
def test_no_interaction_gives_independent_argmax(schedule: str) -> None:
    starts = np.array([[-5.0, 0.0], [5.0, 0.0], [0.0, 6.0]])
    goals = np.array([[-5.5, 0.3], [5.2, -0.7], [0.4, 6.6]])
    controls, positions, utilities = _attracted(starts, goals)
    settings = PenaltySettings(min_separation=1.0, schedule=schedule)
    result = coordinate(controls, positions, lambda i, plans: utilities[i], settings)
    expected = [int(np.argmax(u)) for u in utilities]
    np.testing.assert_array_equal(result.indices, expected)
    assert result.converged and result.iterations == 1


@pytest.mark.parametrize("schedule", ["jacobi", "gauss-seidel"])
def test_coupled_utility_copies_agree(schedule: str) -> None:
    """A utility that depends on the partners' plans (as the pairwise one does)."""
    starts = np.array([[-3.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    controls, positions, base = _attracted(starts, starts)
    calls: list[np.ndarray] = []

    def utility(i: int, plans: np.ndarray) -> np.ndarray:
        calls.append(plans.copy())
        partners = np.array([positions[j][plans[j]] for j in range(3) if j != i])
        # Reward being far (up to 4 units) from the partners' planned positions.
        spread = np.minimum(np.linalg.norm(positions[i][:, None] - partners, axis=-1), 4.0)
        return base[i] + 0.5 * spread.sum(axis=1)

    settings = PenaltySettings(min_separation=1.0, schedule=schedule, max_iterations=30)
    result = coordinate(controls, positions, utility, settings)
    assert result.converged
    assert result.agreement_residual == 0.0
    np.testing.assert_array_equal(result.copies, np.tile(result.indices, (3, 1)))
    # Each final plan is the best response to the others' final plans (a fixed point).
    for i in range(3):
        assert (
            utility(i, result.indices)[result.indices[i]]
            >= utility(i, result.indices).max() - 1e-12
        )


def test_settings_validation() -> None:
    with pytest.raises(ValueError, match="alpha"):
        PenaltySettings(min_separation=1.0, alpha=1.0)
    with pytest.raises(ValueError, match="gamma"):
        PenaltySettings(min_separation=1.0, gamma=1.5)
    with pytest.raises(ValueError, match="schedule"):
        PenaltySettings(min_separation=1.0, schedule="async")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="utility"):
        coordinate(
            [OFFSETS], [OFFSETS], lambda i, p: np.zeros(3), PenaltySettings(min_separation=1.0)
        )


def test_max_violation() -> None:
    assert max_violation(np.array([[0.0, 0.0], [0.4, 0.0]]), 1.0) == pytest.approx(0.6)
    assert max_violation(np.array([[0.0, 0.0], [2.0, 0.0]]), 1.0) == 0.0


@pytest.mark.parametrize("dim", [1, 2])
def test_grid_refiner_finds_the_interpolant_optimum_and_is_never_worse(dim: int) -> None:
    """On a smooth utility sampled on the grid, the refined control is within the cell, never
    worse than the grid choice on the true utility by more than the interpolation error, and
    close to the true optimum inside the cell (a cubic spline of a quadratic is exact)."""
    rng = np.random.default_rng(3)
    axes = [np.linspace(-1.0, 1.0, 9)] * dim
    refiner = GridRefiner(axes, 33 if dim == 1 else 17)
    mesh = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, dim)
    tracks = np.repeat(mesh[:, None, :2] if dim == 2 else np.c_[mesh, mesh][:, None], 3, axis=1)
    far = np.full((1, 3, 2), 100.0)  # no separation penalty
    for _ in range(20):
        optimum = rng.uniform(-1.5, 1.5, dim)  # sometimes outside the bounds
        values = -np.sum((mesh - optimum) ** 2, axis=-1)  # quadratic: interpolated exactly
        index = int(np.argmax(values))
        u, track = refiner.refine(index, values, tracks, far, 1.0, 2.0, 1.0)
        assert np.all(np.abs(u - mesh[index]) <= 0.25 + 1e-12)
        assert np.all(u >= -1.0) and np.all(u <= 1.0)
        expected = np.clip(optimum, mesh[index] - 0.25, mesh[index] + 0.25)
        expected = np.clip(expected, -1.0, 1.0)
        step = 0.25 / (16 if dim == 1 else 8)
        np.testing.assert_allclose(u, expected, atol=step / 2 + 1e-12)
        assert -np.sum((u - optimum) ** 2) >= values[index] - 1e-12
        # interpolated tracks are exact for tracks linear in the control
        np.testing.assert_allclose(track[0], np.r_[u, u][:2] if dim == 1 else u, atol=1e-12)


def test_grid_refiner_avoids_a_partner_and_keeps_the_grid_choice_on_ties() -> None:
    axes = [np.linspace(-1.0, 1.0, 5)]
    refiner = GridRefiner(axes, 9)
    nodes = axes[0]
    tracks = np.stack([np.c_[nodes, np.zeros(5)]] * 2, axis=1)  # (5, 2, 2): position = (u, 0)
    flat = np.zeros(5)
    u, _ = refiner.refine(2, flat, tracks, np.full((1, 2, 2), 50.0), 1.0, 2.0, 1.0)
    assert u[0] == 0.0  # a flat utility and no partner nearby: the grid choice is kept
    partner = np.array([[[0.3, 0.0], [0.3, 0.0]]])  # a partner just right of the choice
    u, track = refiner.refine(2, flat, tracks, partner, 1.0, 2.0, 10.0)
    assert u[0] == pytest.approx(-0.5)  # pushed to the far edge of the cell
    np.testing.assert_allclose(track[:, 0], -0.5, atol=1e-12)
    with pytest.raises(ValueError, match="points_per_axis"):
        GridRefiner(axes, 1)


@pytest.mark.parametrize("gamma", [2.0, 2.5, 3.0])
@pytest.mark.parametrize(("n_others", "horizon"), [(1, 1), (3, 3), (9, 3), (4, 1)])
def test_compiled_penalties_equal_the_numpy_expressions_bit_for_bit(gamma, n_others, horizon):
    from infoseek.planners.coordination import _horizon_violation

    rng = np.random.default_rng(n_others * 10 + horizon)
    tracks = rng.uniform(-2.0, 2.0, (25, horizon, 2))
    others = rng.uniform(-2.0, 2.0, (n_others, horizon, 2))
    per_candidate = others[None] + rng.normal(0.0, 0.3, (25, n_others, horizon, 2))
    for partners in (others, per_candidate):
        gaps = np.linalg.norm(tracks[:, None, :, :] - partners, axis=-1)
        expected = np.sum(np.maximum(0.0, 1.7 - gaps) ** gamma, axis=(-2, -1))
        got = horizon_separation_penalty(tracks, partners, 1.7, gamma)
        assert got.dtype == expected.dtype and got.tobytes() == expected.tobytes()
    fleet = rng.uniform(-1.0, 1.0, (n_others + 1, horizon, 2))
    expected_worst = max(max_violation(fleet[:, h, :], 1.2) for h in range(horizon))
    assert _horizon_violation(fleet, 1.2) == expected_worst


def test_compiled_gauss_seidel_choice_equals_the_general_local_solve():
    from infoseek.planners.coordination import _gauss_seidel_choice, _local_choice

    rng = np.random.default_rng(21)
    settings = PenaltySettings(min_separation=1.5)
    for _ in range(40):
        n, c, h = rng.integers(1, 6), rng.integers(1, 12), rng.integers(1, 4)
        positions = [rng.uniform(0.0, 3.0, (c, h, 2)) for _ in range(n)]
        plans = rng.integers(0, c, n)
        utilities = np.round(rng.standard_normal(c), 1)  # ties
        for i in range(n):
            previous = int(rng.integers(0, c))
            exchanged = plans.copy()
            exchanged[i] = previous
            expected = _local_choice(i, utilities, positions, plans, exchanged, 0.3, settings)
            fleet = np.stack(positions)
            assert _gauss_seidel_choice(utilities, fleet, plans, i, previous, 0.3, 1.5) == expected
