"""Tests of the steps :func:`~infoseek.planners.coordination.coordinate` is built from."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.planners.coordination import (
    PenaltySettings,
    _agreement_residual,
    _checked_initial_indices,
    _coordination_result,
    _final_penalties,
    _largest_change,
    _nominal_best_plans,
    _planned_tracks,
    _sweep,
    coordinate,
    horizon_separation_penalty,
)


def _line_controls(n: int) -> np.ndarray:
    """``(n, 2)`` controls on a line: ``(k, 0)`` for ``k = 0 .. n - 1``."""
    return np.column_stack([np.arange(n, dtype=np.float64), np.zeros(n)])


def test_initial_indices_are_copied_as_int64_and_checked() -> None:
    controls = [_line_controls(3), _line_controls(4)]
    given = np.array([2, 3])
    plans = _checked_initial_indices(given, controls)
    assert plans.dtype == np.int64 and plans.tolist() == [2, 3]
    plans[0] = 0
    assert given[0] == 2  # a copy
    with pytest.raises(ValueError, match=r"initial_indices must have shape \(2,\), got \(3,\)"):
        _checked_initial_indices([0, 0, 0], controls)
    with pytest.raises(ValueError, match=r"initial_indices\[1\] = 4 outside \[0, 4\)"):
        _checked_initial_indices([0, 4], controls)
    with pytest.raises(ValueError, match=r"initial_indices\[0\] = -1 outside \[0, 3\)"):
        _checked_initial_indices([-1, 0], controls)


def test_nominal_plans_are_the_argmax_against_the_centre_candidates() -> None:
    controls = [_line_controls(5), _line_controls(3)]  # centres: candidates 2 and 1
    seen: list[list[int]] = []

    def utility(i: int, plans: np.ndarray) -> np.ndarray:
        seen.append(plans.tolist())
        return -((np.arange(controls[i].shape[0]) - 1 - i) ** 2.0)  # best: candidate 1 + i

    plans = _nominal_best_plans(controls, utility)
    assert plans.dtype == np.int64 and plans.tolist() == [1, 2]
    assert seen == [[2, 1], [2, 1]]


@pytest.mark.parametrize(("schedule", "seen_by_1"), [("gauss-seidel", 2), ("jacobi", 0)])
def test_a_sweep_shows_each_vehicle_the_plans_its_schedule_exchanges(
    schedule: str, seen_by_1: int
) -> None:
    """Gauss-Seidel: vehicle 1 already sees vehicle 0's new plan; Jacobi: the old one."""
    controls = [_line_controls(3), _line_controls(3)]
    positions = [10.0 * c[:, None, :] + 100.0 * i for i, c in enumerate(controls)]  # apart
    settings = PenaltySettings(1.0, schedule=schedule, agreement_weight=0.0)  # type: ignore[arg-type]
    copies_seen: list[list[int]] = []

    def utility(i: int, plans: np.ndarray) -> np.ndarray:
        copies_seen.append(plans.tolist())
        return np.array([0.0, 1.0, 3.0]) if i == 0 else np.array([0.0, 2.0, 1.0])

    plans = np.array([0, 0], dtype=np.int64)
    copies = np.tile(plans, (2, 1))
    local = np.zeros(2)
    new = _sweep(plans, copies, local, utility, controls, positions, None, 1.0, settings)
    assert new.tolist() == [2, 1] and plans.tolist() == [0, 0]
    assert copies_seen == [[0, 0], [2 if seen_by_1 == 2 else 0, 0]]
    assert copies.tolist() == [[2, 0], [seen_by_1, 1]]  # own block: the new plan
    assert local.tolist() == [3.0, 2.0]


def test_largest_change_and_agreement_residual_are_control_distances() -> None:
    controls = [_line_controls(4), _line_controls(4)]
    old, new = np.array([0, 3]), np.array([2, 3])
    assert _largest_change(controls, old, new) == 2.0
    assert _largest_change(controls, new, new) == 0.0
    agreeing = np.tile(new, (2, 1))
    assert _agreement_residual(controls, agreeing, new) == 0.0
    stale = agreeing.copy()
    stale[1, 0] = 1  # vehicle 1 holds vehicle 0's plan 1, vehicle 0 planned 2
    assert _agreement_residual(controls, stale, new) == 1.0


def test_final_penalties_are_each_vehicles_penalty_against_the_others() -> None:
    # two steps; vehicles 0 and 1 are 0.5 apart at the second step only, vehicle 2 far away
    tracks = np.array(
        [[[0.0, 0.0], [0.0, 0.0]], [[3.0, 0.0], [0.5, 0.0]], [[9.0, 9.0], [9.0, 9.0]]]
    )
    settings = PenaltySettings(min_separation=1.0)
    penalties = _final_penalties(tracks, settings)
    assert penalties == pytest.approx([0.25, 0.25, 0.0])
    for i in range(3):
        expected = horizon_separation_penalty(tracks[i], np.delete(tracks, i, axis=0), 1.0)
        assert penalties[i] == expected


def test_the_result_describes_the_final_plans() -> None:
    controls = [_line_controls(3), _line_controls(3)]
    positions = [
        np.stack([c, c + 1.0], axis=1) + np.array([0.0, 5.0 * i]) for i, c in enumerate(controls)
    ]  # (3, 2 steps, 2)
    plans = np.array([1, 2], dtype=np.int64)
    tracks = _planned_tracks(positions, plans)
    assert tracks.shape == (2, 2, 2) and np.array_equal(tracks[1], positions[1][2])
    settings = PenaltySettings(min_separation=6.0)
    copies = np.array([[1, 0], [1, 2]])
    result = _coordination_result(
        controls,
        positions,
        plans,
        copies,
        np.array([0.5, 0.25]),
        settings,
        iterations=3,
        converged=False,
        beta=0.25,
        changes=[1.0, 0.0, 0.0],
    )
    assert np.array_equal(result.controls, [[1.0, 0.0], [2.0, 0.0]])
    assert np.array_equal(result.positions, tracks[:, 0, :])
    assert result.agreement_residual == 2.0  # vehicle 0 holds plan 0 for vehicle 1's plan 2
    gap = float(np.linalg.norm(tracks[0, 0] - tracks[1, 0]))  # the closer of the two steps
    assert result.max_violation == pytest.approx(6.0 - gap)
    assert result.utilities.tolist() == [0.5, 0.25] and result.changes == (1.0, 0.0, 0.0)
    assert (result.iterations, result.converged, result.beta) == (3, False, 0.25)


def test_coordinate_starts_from_the_nominal_plans_by_default() -> None:
    """Without ``initial_indices`` the first exchange is :func:`_nominal_best_plans`."""
    controls = [_line_controls(5), _line_controls(5)]
    positions = [10.0 * c + 100.0 * i for i, c in enumerate(controls)]
    weights = np.array([[0.0, 1.0], [0.7, 0.0]])

    def utility(i: int, plans: np.ndarray) -> np.ndarray:
        partner = plans[1 - i]
        return -((np.arange(5) - 2.0 - weights[i, 1 - i] * partner) ** 2)

    settings = PenaltySettings(min_separation=1.0, max_iterations=1)
    default = coordinate(controls, positions, utility, settings)
    nominal = _nominal_best_plans(controls, utility)
    explicit = coordinate(controls, positions, utility, settings, initial_indices=nominal)
    assert np.array_equal(default.indices, explicit.indices)
    assert default.changes == explicit.changes
