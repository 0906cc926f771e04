"""Smoke test of an installed infoseek wheel (run by .ci/wheel inside a fresh virtual environment).

Usage: ``python smoke.py VENV WHEEL``. Checks that ``infoseek`` is imported from ``VENV`` (not
from a checkout), that the wheel carries the package data (``py.typed`` files, the shipped
model) and the licence, that both environments can be made, reset and stepped to the end of an
episode, and that the ``infoseek`` console script runs.
"""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

#: Files every wheel must hold besides the modules.
REQUIRED_FILES = (
    "infoseek/envs/py.typed",
    "infoseek/planners/py.typed",
    "infoseek/baselines/py.typed",
    "infoseek/experiments/py.typed",
    "infoseek/baselines/models/ppo_bearings_v0_4agents/model.zip",
    "infoseek-{version}.dist-info/licenses/LICENSE",
)


def check_wheel(wheel: Path, version: str) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    required = [name.format(version=version) for name in REQUIRED_FILES]
    missing = [name for name in required if name not in names]
    assert not missing, f"{wheel.name} lacks {missing}"
    metadata = zipfile.ZipFile(wheel).read(f"infoseek-{version}.dist-info/METADATA").decode()
    assert "License-Expression: MIT" in metadata, "the wheel's metadata has no SPDX licence"


def step_episode(env_id: str) -> int:
    import numpy as np

    import infoseek.envs

    env = infoseek.envs.make(env_id, n_agents=2, n_particles=200, max_cycles=3)
    env.reset(seed=0)
    for index, agent in enumerate(env.agents):
        env.action_space(agent).seed(index)
    steps = 0
    while env.agents:
        actions = {agent: env.action_space(agent).sample() for agent in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        assert all(np.isfinite(reward) for reward in rewards.values()), rewards
        assert all(env.observation_space(a).contains(o) for a, o in observations.items())
        steps += 1
    return steps


def main(venv: Path, wheel: Path) -> None:
    import infoseek.envs

    location = Path(infoseek.envs.__file__).resolve()
    assert venv.resolve() in location.parents, f"infoseek.envs imported from {location}"
    from importlib.metadata import version

    check_wheel(wheel, version("infoseek"))
    for env_id in ("bearings_v0", "beacon_v0"):
        assert step_episode(env_id) == 3, env_id
    script = venv / "bin" / "infoseek"
    help_text = subprocess.run([str(script), "--help"], check=True, capture_output=True, text=True)
    assert "demo" in help_text.stdout and "bench" in help_text.stdout
    print(f"wheel smoke test passed: {wheel.name} installed in {location.parent.parent}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
