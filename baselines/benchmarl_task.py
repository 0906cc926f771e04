"""BenchMARL tasks for the infoseek environments (``bearings_v0``, ``beacon_v0``).

BenchMARL (``pip install benchmarl``; written against 1.5.2) runs its algorithms on a *task*: a
:class:`benchmarl.environments.TaskClass` that builds a TorchRL environment and tells the
algorithms which entries of its specs are the observation, the info, the action and the global
state. This module provides that class for the infoseek environments, so any BenchMARL
algorithm can be trained on them::

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    from infoseek.baselines.benchmarl_task import InfoseekTask

    task = InfoseekTask.BEARINGS_V0.get_task({"n_agents": 2, "n_particles": 500})
    experiment = Experiment(
        task=task,
        algorithm_config=MappoConfig.get_from_yaml(),
        model_config=MlpConfig.get_from_yaml(),
        critic_model_config=MlpConfig.get_from_yaml(),
        seed=0,
        config=ExperimentConfig.get_from_yaml(),
    )
    experiment.run()

The task config is the environment's keyword arguments (its manual,
``infoseek.envs.bearings_v0`` / ``beacon_v0``); keys left out keep the version's defaults, so
``get_task()`` without a config is the registered environment. ``action_type`` must not be
given: BenchMARL chooses continuous or discrete actions (both are supported; the experiment's
``prefer_continuous_actions`` and the algorithm decide) and the task sets ``action_type`` from
that choice.

**What the algorithms see.** The environment is wrapped with TorchRL's ``PettingZooWrapper``
(parallel API, categorical discrete actions). All agents form the single group ``"vehicle"``.

* observation: ``("vehicle", "observation")``, the per-agent observation of the manual;
* info: ``("vehicle", "info", ...)``, the per-agent info numbers and arrays (entropy, posterior
  mass, ...): BenchMARL's loggers report their means, and they are dropped from the training
  batches, so no network reads them;
* state: ``"state"``, the centralised :meth:`~infoseek.envs.InformationSeekingEnv.state`
  (``env.state_space``: every vehicle's state and every agent's belief summary; never the true
  target). TorchRL reads it only because the wrapper is built with ``return_state=True``.

:meth:`InfoseekTaskClass.state_spec` returns that state, and this is what makes the difference
between the PPO variants: BenchMARL's MAPPO critic takes the state spec as its (centralised)
input whenever a task provides one, and falls back to the concatenated agent observations
otherwise; IPPO's critic always reads each agent's own observation. Rendering is not wired
(``has_render`` is ``False``), so BenchMARL never asks for videos.

Importing this module imports BenchMARL and TorchRL; ``import infoseek.baselines`` does not
import it (use the full module path).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from typing import Any

from benchmarl.environments.common import Task, TaskClass
from torchrl.data import Composite
from torchrl.envs import EnvBase
from torchrl.envs.libs.pettingzoo import PettingZooWrapper

from infoseek.envs import make, registry

__all__ = ["GROUP", "InfoseekTask", "InfoseekTaskClass"]

GROUP = "vehicle"
"""The agent group of every infoseek task (agents ``vehicle_0``, ``vehicle_1``, ...)."""


def _keep_only(spec: Composite, groups: list[str], key: str) -> Composite:
    """A copy of ``spec`` with only the entry ``key`` under each group and no global state."""
    spec = spec.clone()
    for group in groups:
        for name in list(spec[group].keys()):
            if name != key:
                del spec[group][name]
    if "state" in spec.keys():
        del spec["state"]
    return spec


class InfoseekTaskClass(TaskClass):
    """One infoseek environment as a BenchMARL task (see the module docstring).

    Args:
        name: The task name: the environment id in any case (``"BEARINGS_V0"`` or
            ``"bearings_v0"``); :class:`InfoseekTask` members pass their own name.
        config: Keyword arguments of the environment (``n_agents``, ``n_particles``,
            ``max_cycles``, ...); ``None`` or ``{}`` means the version's defaults.

    Raises:
        ValueError: ``name`` is not a registered environment id, or ``config`` sets
            ``action_type`` (BenchMARL chooses the action type).
    """

    def __init__(self, name: str, config: Mapping[str, Any] | None) -> None:
        env_id = name.lower()
        if env_id not in registry:
            raise ValueError(f"unknown infoseek task {name!r}; valid ids are {sorted(registry)}")
        config = dict(config or {})
        if "action_type" in config:
            raise ValueError(
                "the BenchMARL task sets action_type itself (from the experiment's "
                "prefer_continuous_actions and the algorithm); remove it from the task config"
            )
        super().__init__(name=name, config=config)
        self.env_id = env_id

    def get_env_fun(
        self,
        num_envs: int,
        continuous_actions: bool,
        seed: int | None,
        device: Any,
    ) -> Callable[[], EnvBase]:
        """A constructor of the wrapped environment (one copy; BenchMARL batches copies)."""
        kwargs = copy.deepcopy(dict(self.config))
        kwargs["action_type"] = "continuous" if continuous_actions else "discrete"
        env_id = self.env_id

        def make_env() -> EnvBase:
            return PettingZooWrapper(
                make(env_id, **kwargs),
                return_state=True,
                categorical_actions=True,
                seed=seed,
                device=device,
            )

        return make_env

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return True

    def has_render(self, env: EnvBase) -> bool:
        return False

    def max_steps(self, env: EnvBase) -> int:
        """The episode length: ``max_cycles`` of the config or of the version's defaults."""
        return int(self.config.get("max_cycles", registry[self.env_id].kwargs["max_cycles"]))

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return dict(env.group_map)

    def observation_spec(self, env: EnvBase) -> Composite:
        return _keep_only(env.observation_spec, list(self.group_map(env)), "observation")

    def info_spec(self, env: EnvBase) -> Composite | None:
        return _keep_only(env.observation_spec, list(self.group_map(env)), "info")

    def state_spec(self, env: EnvBase) -> Composite | None:
        """The centralised state ``"state"`` (shape ``env.state_space.shape``)."""
        return Composite({"state": env.observation_spec["state"].clone()})

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "infoseek"


class InfoseekTask(Task):
    """The infoseek tasks, one member per registered environment version.

    ``InfoseekTask.BEARINGS_V0.get_task(config)`` returns the :class:`InfoseekTaskClass`;
    without a config (or from :meth:`get_from_yaml` without a path) the version's defaults are
    used, since infoseek ships no BenchMARL YAML files.
    """

    BEARINGS_V0 = None
    BEACON_V0 = None

    @staticmethod
    def associated_class() -> type[InfoseekTaskClass]:
        return InfoseekTaskClass

    def get_task(self, config: Mapping[str, Any] | None = None) -> InfoseekTaskClass:
        """The task with ``config`` (environment keywords; ``None``: the defaults)."""
        return InfoseekTaskClass(name=self.name, config=config)

    def get_from_yaml(self, path: str | None = None) -> InfoseekTaskClass:
        """The task with the config of the YAML file ``path`` (``None``: the defaults)."""
        if path is None:
            return self.get_task()
        import yaml

        with open(path, encoding="utf-8") as handle:
            return self.get_task(yaml.safe_load(handle) or {})
