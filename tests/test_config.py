"""``SearchConfig`` checks its settings in a fixed order (of several bad settings the first
checked is the one reported), normalises what it accepts to plain Python values, and builds
the filter's likelihood model and the discrete control grid."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from infoseek.envs.belief import DEFAULT_TEMPERING_ESS
from infoseek.envs.config import SearchConfig

SMALL = {"n_particles": 100}

#: Bad settings in the order the constructor checks them: each pair's first is reported.
ORDERED_BAD = [
    ("sensor_kwargs", 3),
    ("vehicle", "submarine"),
    ("target_motion", "teleport"),
    ("domain_size", (-1, 40)),
    ("n_agents", 0),
    ("dt", 0),
    ("separation_penalty", -1),
    ("resample_threshold", 2),
    ("tempering_ess", 1.0),
    ("filter_max_snr", 0),
    ("localization_mass", 0),
    ("terminate_on_localization", 1),
    ("message_loss", 2),
    ("entropy_bins", (0, 4)),
    ("belief_grid", (0, 1)),
    ("belief_moments", 1),
    ("render_mode", "x"),
    ("belief_in_infos", 0),
    ("name", ""),
    ("start_center", (1,)),
    ("action_type", "y"),
]


@pytest.mark.parametrize(
    ("first", "second"),
    list(zip(ORDERED_BAD, ORDERED_BAD[1:], strict=False)),
    ids=[f"{a[0]}-before-{b[0]}" for a, b in zip(ORDERED_BAD, ORDERED_BAD[1:], strict=False)],
)
def test_of_two_bad_settings_the_first_checked_is_reported(
    first: tuple[str, Any], second: tuple[str, Any]
) -> None:
    with pytest.raises((TypeError, ValueError)) as error:
        SearchConfig(**SMALL, **dict([first, second]))
    assert first[0] in str(error.value)
    assert second[0] not in str(error.value)


def test_flags_take_numpy_bools_as_bools_and_reject_numbers() -> None:
    config = SearchConfig(
        **SMALL,
        terminate_on_localization=np.bool_(True),
        belief_moments=np.bool_(False),
        belief_in_infos=True,
    )
    flags = (config.terminate_on_localization, config.belief_moments, config.belief_in_infos)
    assert flags == (True, False, True)
    assert all(type(flag) is bool for flag in flags)
    with pytest.raises(TypeError, match="^terminate_on_localization must be a bool, got 1$"):
        SearchConfig(**SMALL, terminate_on_localization=1)
    with pytest.raises(TypeError, match="^belief_moments must be True or False, got 'x'$"):
        SearchConfig(**SMALL, belief_moments="x")
    with pytest.raises(TypeError, match="^belief_in_infos must be True or False, got 0$"):
        SearchConfig(**SMALL, belief_in_infos=0)


def test_belief_grid_is_two_python_ints() -> None:
    grid = SearchConfig(**SMALL, belief_grid=(np.int64(3), 4)).belief_grid
    assert grid == (3, 4) and all(type(g) is int for g in grid)
    for bad in ((1.0, 2), (True, 2), (2,), 3, "ab"):
        with pytest.raises(ValueError, match="^belief_grid must be two integers >= 1, got "):
            SearchConfig(**SMALL, belief_grid=bad)


def test_tempering_ess_defaults_by_motion_and_stays_below_one() -> None:
    assert SearchConfig(**SMALL).tempering_ess == DEFAULT_TEMPERING_ESS
    assert SearchConfig(**SMALL, target_motion="random_walk").tempering_ess == 0.0
    assert SearchConfig(**SMALL, tempering_ess=0).tempering_ess == 0.0
    with pytest.raises(ValueError, match=r"^tempering_ess must be in \[0, 1\), got 1.0$"):
        SearchConfig(**SMALL, tempering_ess=1.0)
    with pytest.raises(ValueError, match=r"^tempering_ess must lie in \[0.0, 1.0\], got 1.5$"):
        SearchConfig(**SMALL, tempering_ess=1.5)


def test_filter_sensor_is_the_sensor_or_its_noise_floored_view() -> None:
    plain = SearchConfig(**SMALL, sensor="beacon")
    assert plain.filter_max_snr is None and plain.filter_sensor is plain.sensor
    floored = SearchConfig(**SMALL, sensor="beacon", filter_max_snr=30)
    assert floored.filter_max_snr == 30.0 and type(floored.filter_max_snr) is float
    assert floored.filter_sensor is not floored.sensor
    assert floored.filter_sensor.max_snr == 30.0  # type: ignore[attr-defined]
    with pytest.raises(ValueError, match="^filter_max_snr needs a sensor that offers with_max_snr"):
        SearchConfig(**SMALL, sensor="bearing", filter_max_snr=30.0)


def test_discrete_controls_vary_the_last_axis_fastest() -> None:
    config = SearchConfig(
        **SMALL, vehicle="quadrotor", action_type="discrete", n_discrete_actions=3
    )
    low, high = config.control_low, config.control_high
    assert len(low) == 2
    table = config.discrete_controls
    assert table is not None and not table.flags.writeable
    assert config.action_space.n == 9  # type: ignore[attr-defined]
    axis = [np.linspace(low[k], high[k], 3) for k in range(2)]
    np.testing.assert_array_equal(table[:, 0], np.repeat(axis[0], 3))
    np.testing.assert_array_equal(table[:, 1], np.tile(axis[1], 3))
    continuous = SearchConfig(**SMALL, vehicle="quadrotor", n_discrete_actions=3)
    assert continuous.discrete_controls is None and continuous.n_discrete_actions == 3
    assert continuous.action_space.shape == (2,)
