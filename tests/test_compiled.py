"""The compiled-kernel settings and the reductions kernels share (:mod:`infoseek.envs.compiled`)."""

from __future__ import annotations

import numpy as np
import pytest

from infoseek.envs.compiled import describe, pairwise_sum


@pytest.mark.parametrize("size", [*range(0, 140), 255, 256, 257, 1023, 2000, 10_001])
def test_pairwise_sum_is_numpy_sum_bit_for_bit(size: int) -> None:
    rng = np.random.default_rng(size)
    # magnitudes over 17 decades make every difference of summation order visible
    values = rng.standard_normal(size) * np.exp(rng.uniform(-20.0, 20.0, size))
    assert pairwise_sum(values) == np.sum(values)
    rows = rng.standard_normal((3, size)) * np.exp(rng.uniform(-20.0, 20.0, (3, size)))
    expected = rows.sum(axis=1)
    assert [pairwise_sum(row) for row in rows] == list(expected)


def test_kernels_compile_for_a_fixed_target_without_fast_math() -> None:
    settings = describe()
    assert settings["fastmath"] is False
    assert settings["svml"] is False
    assert settings["cpu_name"] in ("haswell", "generic", "host") or settings["cpu_name"]
