"""The compiled-kernel settings and the reductions kernels share (:mod:`infoseek.envs.compiled`)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from infoseek.envs.compiled import describe, kernel_sources_digest, pairwise_sum, sources_digest


def _pairwise_reference(values: np.ndarray) -> float:
    """NumPy's pairwise summation written out recursively: below 8 values in sequence, up to
    128 with eight interleaved accumulators, above that the two halves (the first rounded down
    to a multiple of 8) summed apart and added."""
    n = values.shape[0]
    if n < 8:
        total = 0.0
        for value in values:
            total += value
        return total
    if n <= 128:
        lanes = list(values[:8])
        for start in range(8, n - n % 8, 8):
            for k in range(8):
                lanes[k] += values[start + k]
        total = ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + (
            (lanes[4] + lanes[5]) + (lanes[6] + lanes[7])
        )
        for value in values[n - n % 8 :]:
            total += value
        return total
    half = n // 2
    half -= half % 8
    return _pairwise_reference(values[:half]) + _pairwise_reference(values[half:])


#: NumPy before 2.3 sums a contiguous array in chunks of its buffer size (8192 values), each
#: pairwise, added in sequence; from 2.3 on the whole array pairwise, as ``pairwise_sum``.
_NUMPY_SUMS_WHOLE = tuple(int(part) for part in np.__version__.split(".")[:2]) >= (2, 3)


@pytest.mark.parametrize("size", [*range(0, 140), 255, 256, 257, 1023, 2000, 8192, 10_001])
def test_pairwise_sum_is_numpy_sum_bit_for_bit(size: int) -> None:
    rng = np.random.default_rng(size)
    # magnitudes over 17 decades make every difference of summation order visible
    values = rng.standard_normal(size) * np.exp(rng.uniform(-20.0, 20.0, size))
    assert pairwise_sum(values) == _pairwise_reference(values)
    rows = rng.standard_normal((3, size)) * np.exp(rng.uniform(-20.0, 20.0, (3, size)))
    if size <= 8192 or _NUMPY_SUMS_WHOLE:
        assert pairwise_sum(values) == np.sum(values)
        assert [pairwise_sum(row) for row in rows] == list(rows.sum(axis=1))


def test_kernels_compile_for_a_fixed_target_without_fast_math() -> None:
    settings = describe()
    assert settings["fastmath"] is False
    assert settings["svml"] is False
    assert settings["cpu_name"] in ("haswell", "generic", "host") or settings["cpu_name"]


def test_sources_digest_follows_the_files_that_define_kernels(tmp_path: Path) -> None:
    (tmp_path / "envs").mkdir()
    (tmp_path / "planners" / "information").mkdir(parents=True)
    kernel_file = tmp_path / "planners" / "information" / "k.py"
    kernel_file.write_text("@kernel\ndef f(x):\n    return x + 1\n")
    plain_file = tmp_path / "envs" / "plain.py"
    plain_file.write_text("def g(x):\n    return x\n")
    before = sources_digest(tmp_path)
    plain_file.write_text("def g(x):\n    return 2 * x\n")  # no kernel: no recompilation
    assert sources_digest(tmp_path) == before
    kernel_file.write_text("@kernel\ndef f(x):\n    return x + 2\n")
    assert sources_digest(tmp_path) != before
    assert len(kernel_sources_digest()) == 64


_LOAD_LOG = """
import numpy as np
from infoseek.envs import compiled
if {patched!r}:
    compiled.kernel_sources_digest = lambda: "another kernel source tree"
from infoseek.envs.log_weights import bayes_step
bayes_step(np.zeros((2, 5)), np.ones((2, 5)), np.ones(2, bool), 0.5)
"""


def test_a_kernel_is_compiled_again_when_another_kernel_file_changed(tmp_path: Path) -> None:
    """numba alone would load ``_accepted_rows`` from its cache although its callee
    ``pairwise_sum`` (another file) changed; the digest in the key makes it compile again."""

    def run(patched: bool) -> str:
        environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "NUMBA_DEBUG_CACHE": "1"}
        result = subprocess.run(
            [sys.executable, "-c", _LOAD_LOG.format(patched=patched)],
            env=environment,
            capture_output=True,
            text=True,
            check=True,
        )
        lines = (result.stdout + result.stderr).splitlines()
        return "\n".join(line for line in lines if "_accepted_rows" in line)

    assert "data saved" in run(patched=False)  # a cold cache: compiled and saved
    assert "data loaded" in run(patched=False)  # the same sources: loaded
    again = run(patched=True)  # the same file, other kernel sources: compiled again
    assert "data saved" in again and "data loaded" not in again
