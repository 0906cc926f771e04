"""Tests for infoseek.envs.vehicles: closed-form kinematics, broadcasting and validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from infoseek.envs.vehicles import (
    VEHICLE_REGISTRY,
    Airplane,
    Quadrotor,
    Vehicle,
    make_vehicle,
)

RNG = np.random.default_rng(0)


def test_airplane_constant_turn_traces_circle() -> None:
    speed, omega, dt = 1.5, 0.3, 0.7
    plane = Airplane(speed=speed, max_turn_rate=0.5)
    radius = speed / omega
    heading0 = 0.4
    state = np.array([[2.0, -1.0, heading0]])
    # centre of the turning circle: to the left of the initial heading
    centre = state[0, :2] + radius * np.array([-np.sin(heading0), np.cos(heading0)])
    for k in range(1, 60):
        state = plane.step(state, np.array([[omega]]), dt)
        assert np.linalg.norm(state[0, :2] - centre) == pytest.approx(radius, rel=1e-12)
        expected_heading = np.mod(heading0 + omega * k * dt + np.pi, 2 * np.pi) - np.pi
        assert state[0, 2] == pytest.approx(expected_heading, abs=1e-9)
        # closed-form position on the circle
        ang = heading0 + omega * k * dt
        closed = centre + radius * np.array([np.sin(ang), -np.cos(ang)])
        np.testing.assert_allclose(state[0, :2], closed, atol=1e-9)


def test_airplane_integration_is_exact_not_euler() -> None:
    """One long step equals many short steps (true only for exact arc integration)."""
    plane = Airplane(speed=1.0, max_turn_rate=0.5)
    s0 = np.array([[5.0, 5.0, -2.0]])
    u = np.array([[-0.45]])
    big = plane.step(s0, u, 3.0)
    small = s0
    for _ in range(300):
        small = plane.step(small, u, 0.01)
    np.testing.assert_allclose(big, small, atol=1e-9)


def test_airplane_straight_and_small_turn_continuity() -> None:
    plane = Airplane(speed=2.0, max_turn_rate=0.5)
    s0 = np.array([[1.0, 2.0, np.pi / 3]])
    straight = plane.step(s0, np.array([[0.0]]), 2.5)
    np.testing.assert_allclose(
        straight[0], [1.0 + 5.0 * np.cos(np.pi / 3), 2.0 + 5.0 * np.sin(np.pi / 3), np.pi / 3]
    )
    tiny = plane.step(s0, np.array([[1e-12]]), 2.5)
    np.testing.assert_allclose(tiny, straight, atol=1e-10)
    # the speed is fixed: chord never longer than speed * dt
    us = np.linspace(-0.5, 0.5, 11)[:, None]
    moved = np.linalg.norm(plane.step(s0, us, 2.5)[:, :2] - s0[0, :2], axis=1)
    assert np.all(moved <= 5.0 + 1e-12)
    assert np.all(moved > 4.0)


def test_airplane_heading_wrapped() -> None:
    plane = Airplane()
    s = np.array([[0.0, 0.0, np.pi - 0.1], [0.0, 0.0, -np.pi + 0.1]])
    out = plane.step(s, np.array([[0.5], [-0.5]]), 1.0)
    assert np.all(out[:, 2] >= -np.pi) and np.all(out[:, 2] < np.pi)
    np.testing.assert_allclose(out[:, 2], [-np.pi + 0.4, np.pi - 0.4])


def test_controls_are_clipped_to_bounds() -> None:
    plane = Airplane(max_turn_rate=0.2)
    s = np.zeros((1, 3))
    np.testing.assert_allclose(plane.step(s, [[5.0]], 1.0), plane.step(s, [[0.2]], 1.0))
    quad = Quadrotor(max_accel=0.5, max_speed=10.0)
    q = np.zeros((1, 4))
    np.testing.assert_allclose(quad.step(q, [[3.0, -3.0]], 1.0), quad.step(q, [[0.5, -0.5]], 1.0))


@pytest.mark.parametrize("vehicle", [Airplane(), Quadrotor()])
def test_broadcasting(vehicle) -> None:
    n_s, n_u = vehicle.state_dim, vehicle.control_dim
    rng = np.random.default_rng(1)
    states = rng.uniform(-1, 1, (3, n_s))
    controls = rng.uniform(vehicle.control_low, vehicle.control_high, (3, n_u))
    batch = vehicle.step(states, controls, 0.5)
    assert batch.shape == (3, n_s)
    for a in range(3):
        np.testing.assert_allclose(batch[a], vehicle.step(states[a], controls[a], 0.5))
    candidates = rng.uniform(vehicle.control_low, vehicle.control_high, (7, n_u))
    cand = vehicle.step(states[:1], candidates, 0.5)
    assert cand.shape == (7, n_s)
    for c in range(7):
        np.testing.assert_allclose(cand[c], vehicle.step(states[0], candidates[c], 0.5))
    with pytest.raises(ValueError, match="broadcast"):
        vehicle.step(states, candidates, 0.5)
    np.testing.assert_array_equal(vehicle.position(states), states[:, :2])


def test_quadrotor_constant_acceleration_closed_form() -> None:
    quad = Quadrotor(max_accel=1.0, max_speed=100.0)
    s = quad.initial_states(np.array([[3.0, 4.0]]), RNG)
    a = np.array([[0.6, -0.8]])
    dt = 0.5
    for k in range(1, 11):
        s = quad.step(s, a, dt)
        t = k * dt
        np.testing.assert_allclose(s[0, :2], [3.0, 4.0] + 0.5 * a[0] * t**2, atol=1e-12)
        np.testing.assert_allclose(s[0, 2:], a[0] * t, atol=1e-12)


def test_quadrotor_saturates_at_max_speed() -> None:
    quad = Quadrotor(max_accel=1.0, max_speed=2.0)
    s = np.zeros((1, 4))
    for _ in range(20):
        s = quad.step(s, [[1.0, 1.0]], 1.0)
    assert np.linalg.norm(s[0, 2:]) == pytest.approx(2.0)
    np.testing.assert_allclose(s[0, 2:], [np.sqrt(2), np.sqrt(2)])


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dt=st.floats(0.01, 3.0))
def test_quadrotor_never_exceeds_max_speed(seed: int, dt: float) -> None:
    quad = Quadrotor(max_accel=1.5, max_speed=2.0)
    rng = np.random.default_rng(seed)
    s = quad.initial_states(rng.uniform(0, 40, (5, 2)), rng)
    for _ in range(30):
        u = rng.uniform(-1.5, 1.5, (5, 2))
        new = quad.step(s, u, dt)
        assert np.all(np.linalg.norm(new[:, 2:], axis=1) <= 2.0 + 1e-12)
        # position moves by the mean velocity, so never faster than max_speed
        assert np.all(np.linalg.norm(new[:, :2] - s[:, :2], axis=1) <= 2.0 * dt + 1e-12)
        s = new


def test_control_bounds_exposed_and_read_only() -> None:
    plane = Airplane(speed=1.0, max_turn_rate=0.7)
    np.testing.assert_array_equal(plane.control_low, [-0.7])
    np.testing.assert_array_equal(plane.control_high, [0.7])
    quad = Quadrotor(max_accel=1.2, max_speed=3.0)
    np.testing.assert_array_equal(quad.control_low, [-1.2, -1.2])
    np.testing.assert_array_equal(quad.control_high, [1.2, 1.2])
    with pytest.raises(ValueError):
        quad.control_high[0] = 9.0
    for v in (plane, quad):
        assert isinstance(v, Vehicle)
        assert len(v.state_names) == v.state_dim
        assert v.control_low.shape == (v.control_dim,)


def test_initial_states() -> None:
    pos = np.array([[1.0, 2.0], [3.0, 4.0]])
    s = Airplane().initial_states(pos, RNG)
    np.testing.assert_array_equal(s, [[1, 2, np.pi / 4], [3, 4, np.pi / 4]])
    q = Quadrotor().initial_states(pos, RNG)
    np.testing.assert_array_equal(q, [[1, 2, 0, 0], [3, 4, 0, 0]])


def test_registry_and_factory() -> None:
    assert set(VEHICLE_REGISTRY) == {"airplane", "quadrotor"}
    plane = make_vehicle("airplane", speed=2.0)
    assert isinstance(plane, Airplane) and plane.speed == 2.0
    assert make_vehicle(plane) is plane
    with pytest.raises(ValueError, match="airplane.*quadrotor"):
        make_vehicle("helicopter")
    with pytest.raises(TypeError, match="keyword"):
        make_vehicle(plane, speed=3.0)
    with pytest.raises(TypeError, match="spec"):
        make_vehicle(3)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: Airplane(speed=0.0), "speed"),
        (lambda: Airplane(speed=np.inf), "speed"),
        (lambda: Airplane(max_turn_rate=-1.0), "max_turn_rate"),
        (lambda: Quadrotor(max_accel=np.nan), "max_accel"),
        (lambda: Quadrotor(max_speed=0), "max_speed"),
    ],
)
def test_bad_parameters(factory, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        factory()


def test_bad_parameter_types() -> None:
    with pytest.raises(TypeError, match="speed"):
        Airplane(speed="fast")  # type: ignore[arg-type]


@pytest.mark.parametrize("vehicle", [Airplane(), Quadrotor()])
def test_bad_step_inputs(vehicle) -> None:
    n_s, n_u = vehicle.state_dim, vehicle.control_dim
    s, u = np.zeros((2, n_s)), np.zeros((2, n_u))
    with pytest.raises(ValueError, match="states"):
        vehicle.step(np.zeros((2, n_s + 1)), u, 1.0)
    with pytest.raises(ValueError, match="controls"):
        vehicle.step(s, np.zeros((2, n_u + 1)), 1.0)
    with pytest.raises(ValueError, match="dt"):
        vehicle.step(s, u, 0.0)
    with pytest.raises(ValueError, match="states"):
        vehicle.step(np.full((2, n_s), np.nan), u, 1.0)
    with pytest.raises(ValueError, match="controls"):
        vehicle.step(s, np.full((2, n_u), np.nan), 1.0)
    with pytest.raises(ValueError, match="positions"):
        vehicle.initial_states(np.zeros((2, 3)), RNG)
    with pytest.raises(TypeError, match="rng"):
        vehicle.initial_states(np.zeros((2, 2)), 0)
    with pytest.raises(ValueError, match="states"):
        vehicle.position(np.zeros((2, n_s + 2)))
