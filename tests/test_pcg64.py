"""NumPy's PCG64 generator drawn in compiled code (infoseek.envs.pcg64): the numbers and the
state afterwards are NumPy's, checked against NumPy itself and against the PCG64 recurrence
written out with Python integers."""

from __future__ import annotations

import platform

import numpy as np
import pytest

from infoseek.envs import pcg64

_MULTIPLIER = 0x2360ED051FC65DA44385DF649FCCF645  # PCG64's 128-bit multiplier
_MASK = (1 << 128) - 1


def _raw_by_recurrence(state: int, increment: int, count: int) -> list[int]:
    """PCG64 XSL-RR outputs from the recurrence itself (O'Neill 2014), independent of NumPy."""
    outputs = []
    for _ in range(count):
        state = (state * _MULTIPLIER + increment) & _MASK
        high, low = state >> 64, state & ((1 << 64) - 1)
        folded, rotation = high ^ low, high >> 58
        outputs.append(((folded >> rotation) | (folded << (64 - rotation))) & ((1 << 64) - 1))
    return outputs


@pytest.mark.skipif(
    platform.machine() not in ("x86_64", "AMD64"), reason="the layout check is exercised on x86-64"
)
def test_default_generators_take_the_compiled_path_on_x86_64() -> None:
    addresses = pcg64.state_addresses([np.random.default_rng(0), np.random.default_rng(1)])
    assert addresses is not None and addresses.shape == (2,) and addresses.dtype == np.uint64


def test_outputs_follow_the_pcg64_recurrence() -> None:
    rng = np.random.default_rng(12345)
    start = rng.bit_generator.state["state"]
    expected = _raw_by_recurrence(start["state"], start["inc"], 64)
    addresses = pcg64.state_addresses([rng])
    assert addresses is not None
    doubles = [pcg64.next_double(addresses[0]) for _ in range(64)]
    assert doubles == [(u >> 11) * 2.0**-53 for u in expected]
    assert rng.bit_generator.state["state"]["state"] == _raw_state_after(start, 64)


def _raw_state_after(start: dict[str, int], steps: int) -> int:
    state = start["state"]
    for _ in range(steps):
        state = (state * _MULTIPLIER + start["inc"]) & _MASK
    return state


@pytest.mark.parametrize("seed", [0, 7, 2006])
def test_normals_and_uniforms_equal_numpys_and_leave_the_same_state(seed: int) -> None:
    ours, theirs = np.random.default_rng(seed), np.random.default_rng(seed)
    addresses = pcg64.state_addresses([ours])
    assert addresses is not None
    normals = np.array([pcg64.standard_normal(addresses[0]) for _ in range(20000)])
    expected = theirs.standard_normal(20000)
    assert np.array_equal(normals, expected)
    # both of the ziggurat's slow paths were taken: the tail beyond r and a wedge
    assert np.abs(expected).max() > 3.6541528853610088
    assert np.array_equal(pcg64.uniforms([ours, ours, ours]), theirs.random(3))
    assert ours.bit_generator.state == theirs.bit_generator.state


def test_many_normals_equal_numpys_through_the_roughening_kernel() -> None:
    """Two million normals (about 2 % through the slow paths) as the filter draws them."""
    from infoseek.envs.roughening import jitter

    rngs = [np.random.default_rng(s) for s in (11, 12)]
    zeros = np.zeros((2, 500_000, 2))
    wide = np.array([-1e300, -1e300]), np.array([1e300, 1e300])
    out = jitter(zeros, np.ones((2, 2)), rngs, *wide, np.zeros(2, dtype=bool))
    for row, seed in enumerate((11, 12)):
        assert np.array_equal(out[row], np.random.default_rng(seed).standard_normal((500_000, 2)))


@pytest.mark.parametrize(
    "bit_generator", [np.random.Philox, np.random.MT19937, np.random.SFC64, np.random.PCG64DXSM]
)
def test_other_bit_generators_are_left_to_numpy(bit_generator: type) -> None:
    other = np.random.Generator(bit_generator(3))
    assert pcg64.state_addresses([other]) is None
    assert pcg64.state_addresses([np.random.default_rng(0), other]) is None
    expected = np.random.Generator(bit_generator(3)).random(2)
    assert np.array_equal(pcg64.uniforms([other, other]), expected)
