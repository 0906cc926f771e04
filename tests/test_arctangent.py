"""The float32 arctangent in IEEE arithmetic (:mod:`infoseek.envs.arctangent`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from infoseek.envs.arctangent import (
    arctan2_float32,
    fdlibm_arctan2_float32,
    numpy_arctan2_is_simd,
)


def _f32(bits: list[int]) -> np.ndarray:
    return np.array(bits, dtype=np.uint32).view(np.float32)


# (y, x, atan2f) as IEEE words: the values glibc 2.36's atan2f (fdlibm) returned on the machine
# that wrote the stored trials. In the first six the correctly rounded value is one unit away
# (0x3f2e68cd, 0xbfd74541, 0xc0324a4f, 0x3eafa20d, 0xc01943d5, 0xbf6ee701); the last three
# take the |y / x| >= 2^25 branch of the arctangent.
GLIBC_236 = [
    (0x42740099, 0x429678C0, 0x3F2E68CC),
    (0xC2B26D7F, 0xC11F1ABA, 0xBFD74540),
    (0xC1BA9C1B, 0xC27B12D7, 0xC0324A4E),
    (0x41F3CA63, 0x42AAA5FD, 0x3EAFA20E),
    (0xC2546450, 0xC2657132, 0xC01943D6),
    (0xC2AFADCD, 0x42822461, 0xBF6EE700),
    (0x427F8A14, 0x359F3E1F, 0x3FC90FDB),
    (0x3F800000, 0x32800000, 0x3FC90FDB),
    (0x40400000, 0xB3000000, 0x3FC90FDA),
]


def test_reproduces_the_fdlibm_values_the_stored_trials_were_written_with() -> None:
    y, x, expected = (_f32([row[i] for row in GLIBC_236]) for i in range(3))
    got = fdlibm_arctan2_float32(y, x)
    assert got.view(np.uint32).tolist() == expected.view(np.uint32).tolist()


def test_within_two_units_in_the_last_place_of_the_double_arctangent() -> None:
    """fdlibm's bound, against the float64 arctangent rounded to float32 (an independent
    implementation), on random words of every exponent and sign."""
    rng = np.random.default_rng(0)
    words = rng.integers(0, 2**32, size=(2, 200_000), dtype=np.uint64).astype(np.uint32)
    y, x = words[0].view(np.float32), words[1].view(np.float32)
    keep = np.isfinite(y) & np.isfinite(x)
    y, x = y[keep], x[keep]
    got = fdlibm_arctan2_float32(y, x)
    reference = np.arctan2(y.astype(np.float64), x.astype(np.float64)).astype(np.float32)
    ulps = np.abs(got.view(np.int32).astype(np.int64) - reference.view(np.int32).astype(np.int64))
    same_sign = np.signbit(got) == np.signbit(reference)
    assert np.all(same_sign | (reference == 0.0))
    assert ulps[same_sign].max() <= 2
    assert np.mean(ulps == 0) > 0.7  # most values are the correctly rounded ones


def _fdlibm_in_numpy(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """fdlibm's atan2f for finite non-zero arguments at most 2^60 apart, written independently
    with NumPy's float32 ufuncs (IEEE operations, one per ufunc: no contraction)."""
    f = np.float32
    hi = np.array([4.6364760399e-01, 7.8539812565e-01, 9.8279368877e-01, 1.5707962513e00], f)
    lo = np.array([5.0121582440e-09, 3.7748947079e-08, 3.4473217170e-08, 7.5497894159e-08], f)
    c = np.array(
        [3.3333334327e-01, -2.0000000298e-01, 1.4285714924e-01, -1.1111110449e-01]
        + [9.0908870101e-02, -7.6918758452e-02, 6.6610731184e-02, -5.8335702866e-02]
        + [4.9768779427e-02, -3.6531571299e-02, 1.6285819933e-02],
        f,
    )
    one, a = f(1.0), np.abs(y / x)
    node = np.searchsorted(np.array([0.4375, 0.6875, 1.1875, 2.4375], f), a, side="right") - 1
    t = np.select(
        [node == 0, node == 1, node == 2, node == 3],
        [(f(2) * a - one) / (f(2) + a), (a - one) / (a + one), (a - f(1.5)) / (one + f(1.5) * a)]
        + [-one / a],
        a,
    )
    z = t * t
    w = z * z
    s1 = z * (c[0] + w * (c[2] + w * (c[4] + w * (c[6] + w * (c[8] + w * c[10])))))
    s2 = w * (c[1] + w * (c[3] + w * (c[5] + w * (c[7] + w * c[9]))))
    k = np.maximum(node, 0)
    r = np.where(node < 0, t - t * (s1 + s2), hi[k] - ((t * (s1 + s2) - lo[k]) - t))
    r = np.where(a < f(2.0**-29), a, r)
    r = np.where(a >= f(2.0**25), hi[3] + lo[3], r)
    pi, pi_lo = f(3.1415927410e00), f(-8.7422776573e-08)
    left = np.where(np.signbit(y), (r - pi_lo) - pi, pi - (r - pi_lo))
    return np.where(np.signbit(x), left, np.where(np.signbit(y), -r, r)).astype(f)


def test_equals_an_independent_numpy_transcription_of_fdlibm() -> None:
    """The compiled (vectorised) code against the same algorithm in NumPy ufuncs, on random
    words of every exponent and sign and on bearings between nearby points."""
    rng = np.random.default_rng(2)
    words = rng.integers(0, 2**32, size=(2, 200_000), dtype=np.uint64).astype(np.uint32)
    y, x = words[0].view(np.float32), words[1].view(np.float32)
    gap = np.abs(np.frexp(y)[1].astype(int) - np.frexp(x)[1].astype(int))
    keep = np.isfinite(y) & np.isfinite(x) & (y != 0) & (x != 0) & (gap < 55) & (x != 1)
    near = rng.uniform(-50.0, 50.0, size=(2, 200_000)).astype(np.float32)
    y = np.concatenate([y[keep], near[0]])
    x = np.concatenate([x[keep], near[1]])
    with np.errstate(over="ignore", under="ignore"):
        expected = _fdlibm_in_numpy(y, x)
    assert np.array_equal(fdlibm_arctan2_float32(y, x).view(np.uint32), expected.view(np.uint32))


@pytest.mark.parametrize(
    ("y", "x", "expected"),
    [
        (0.0, 1.0, 0.0),
        (-0.0, 1.0, -0.0),
        (0.0, -1.0, math.pi),
        (-0.0, -1.0, -math.pi),
        (0.0, -0.0, math.pi),
        (-0.0, 0.0, -0.0),
        (1.0, 0.0, math.pi / 2),
        (-1.0, -0.0, -math.pi / 2),
        (math.inf, math.inf, math.pi / 4),
        (-math.inf, -math.inf, -3 * math.pi / 4),
        (2.0, math.inf, 0.0),
        (-2.0, -math.inf, -math.pi),
        (math.inf, -5.0, math.pi / 2),
        (1.0, 1.0, math.pi / 4),
        (-1.0, -1.0, -3 * math.pi / 4),
    ],
)
def test_special_values_follow_ieee_754(y: float, x: float, expected: float) -> None:
    got = fdlibm_arctan2_float32(np.array([y], np.float32), np.array([x], np.float32))[0]
    assert got == np.float32(expected)
    assert np.signbit(got) == np.signbit(np.float32(expected))


def test_nan_propagates_and_shapes_are_kept() -> None:
    y = np.array([[np.nan, 1.0], [2.0, 3.0]], np.float32)
    x = np.array([[1.0, np.nan], [2.0, -3.0]], np.float32)
    got = fdlibm_arctan2_float32(y, x)
    assert got.shape == (2, 2) and got.dtype == np.float32
    assert np.isnan(got[0]).all()
    np.testing.assert_allclose(got[1], [math.pi / 4, 3 * math.pi / 4], rtol=1e-7)


def test_non_contiguous_input_gives_the_contiguous_values() -> None:
    rng = np.random.default_rng(1)
    y, x = rng.normal(size=(2, 6, 8)).astype(np.float32)
    expected = fdlibm_arctan2_float32(np.ascontiguousarray(y.T), np.ascontiguousarray(x.T))
    assert np.array_equal(fdlibm_arctan2_float32(y.T, x.T), expected)


def test_bad_input_names_the_argument() -> None:
    good = np.zeros(3, np.float32)
    with pytest.raises(
        TypeError, match="fdlibm_arctan2_float32: y must be a float32 array, got dtype float64"
    ):
        fdlibm_arctan2_float32(np.zeros(3), good)
    with pytest.raises(TypeError, match="x must be a float32 array, got list"):
        fdlibm_arctan2_float32(good, [0.0, 0.0, 0.0])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"one shape, got \(3,\) and \(2,\)"):
        fdlibm_arctan2_float32(good, np.zeros(2, np.float32))


def test_planners_use_numpy_only_where_numpy_has_its_own_simd_loop(
    fresh_python: Callable[..., Any],
) -> None:
    """Natively the dispatch follows NumPy's; in the pinned environment (NumPy's baseline
    loop, i.e. the C library's atan2f) the values are fdlibm's computed here."""
    rng = np.random.default_rng(4)
    y, x = rng.normal(size=(2, 1000)).astype(np.float32)
    expected = np.arctan2(y, x) if numpy_arctan2_is_simd() else fdlibm_arctan2_float32(y, x)
    assert np.array_equal(arctan2_float32(y, x), expected)
    with pytest.raises(TypeError, match="arctan2_float32: x must be a float32 array"):
        arctan2_float32(y, x.astype(np.float64))
    probe = (
        "import numpy as np; from infoseek.envs.arctangent import *; "
        "y = np.array([0x42740099], np.uint32).view(np.float32); "
        "x = np.array([0x429678C0], np.uint32).view(np.float32); "
        "print(numpy_arctan2_is_simd(), hex(int(arctan2_float32(y, x).view(np.uint32)[0])))"
    )
    pinned = fresh_python(probe, pinned=True)
    assert pinned.stdout.split() == ["False", "0x3f2e68cc"], pinned.stderr
