"""Importing the library changes no process-wide setting and imports no RL library (issue 27).

Each check runs in a fresh interpreter, so nothing imported by other tests is seen.
"""

from __future__ import annotations

import os
import subprocess
import sys


def _run(code: str, **environ: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "INFOSEEK_HEAP_TUNING"} | environ
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )


def test_import_of_the_envs_tunes_no_heap_and_imports_no_rl_library() -> None:
    result = _run(
        "import sys\n"
        "import infoseek.envs, infoseek.planners\n"
        "from infoseek.envs import heap\n"
        "env = infoseek.envs.make('bearings_v0', n_particles=100)\n"
        "env.reset(seed=0)\n"
        "rl = ('stable_baselines3', 'torch', 'supersuit')\n"
        "heavy = sorted(m for m in rl if m in sys.modules)\n"
        "print(heap.tuned(), heavy)\n"
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.split("\n")[0] == "False []"


def test_heap_tuning_is_applied_where_asked() -> None:
    """The opt-in: the variable the ``infoseek`` command sets for its workers, or the call."""
    code = "from infoseek.envs import heap\nprint(heap.tune_from_environment())\n"
    assert _run(code, INFOSEEK_HEAP_TUNING="1").stdout.strip() == str(sys.platform == "linux")
    assert _run(code, INFOSEEK_HEAP_TUNING="0").stdout.strip() == "False"
    assert _run(code).stdout.strip() == "False"
    called = _run("from infoseek.envs import heap\nprint(heap.retain_freed_memory(), heap.tuned())")
    assert called.stdout.split() == [str(sys.platform == "linux")] * 2
