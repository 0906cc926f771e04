"""Tests of the Monte Carlo harness: seeds, metrics, the results store, resume, backends."""

from __future__ import annotations

import itertools
import json
import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from infoseek.experiments import executors, store
from infoseek.experiments.analysis import (
    GroupSummary,
    format_summary,
    summarise,
    time_to_localise,
)
from infoseek.experiments.bench import BenchPlan, run_bench
from infoseek.experiments.columns import TrialView
from infoseek.experiments.environments import make_env
from infoseek.experiments.policies import check_policy_path
from infoseek.experiments.record import TIMING_FIELDS, TrialRecord
from infoseek.experiments.seeds import trial_seeds
from infoseek.experiments.store import (
    ResultsStore,
    StoreConfigError,
    StoreCorruptError,
    StoreLockedError,
    read_records,
    read_rows,
)
from infoseek.experiments.trial import TrialSpec, min_separation, position_metrics, run_trial

TESTS_DIR = Path(__file__).resolve().parent
# Tiny but real: bearings-only env, few particles and steps, the random policy.
TINY_KWARGS = {"n_particles": 150}
TINY_STEPS = 4


class SleepyRandomPolicy:
    """Uniform random actions from its own seeded stream; sleeps if INFOSEEK_TEST_SLEEP is set.

    The sleep only slows the run down (for the kill test); the actions do not depend on it.
    """

    def __init__(self, env: Any, seed: int | None = None) -> None:
        self.env = env
        self.rng = np.random.default_rng(seed)
        self.sleep = float(os.environ.get("INFOSEEK_TEST_SLEEP", "0"))

    def act(self, observations: dict, infos: dict) -> dict:
        if self.sleep:
            time.sleep(self.sleep)
        actions = {}
        for agent in self.env.possible_agents:
            space = self.env.action_space(agent)
            actions[agent] = self.rng.uniform(space.low, space.high).astype(space.dtype)
        return {agent: actions[agent] for agent in self.env.agents}


def sleepy_random_policy(env: Any, seed: int | None = None, **options: Any) -> SleepyRandomPolicy:
    """Planner factory usable as ``--planner test_bench:sleepy_random_policy``."""
    return SleepyRandomPolicy(env, seed=seed)


class DyingRandomPolicy(SleepyRandomPolicy):
    """The random policy, whose worker process kills itself (SIGKILL) at step 2 of a trial
    whose policy seed is listed in ``INFOSEEK_TEST_KILL_SEEDS``, once per trial: a marker file
    in ``INFOSEEK_TEST_KILL_DIR`` records the death, and the retry runs the trial to its end
    (with ``INFOSEEK_TEST_KILL_ALWAYS=1``, every attempt dies). The actions are the random
    policy's, killed or not."""

    def __init__(self, env: Any, seed: int | None = None) -> None:
        super().__init__(env, seed=seed)
        listed = os.environ.get("INFOSEEK_TEST_KILL_SEEDS", "")
        self.doomed = seed is not None and str(seed) in listed.split(",")
        self.always = os.environ.get("INFOSEEK_TEST_KILL_ALWAYS") == "1"
        self.marker = Path(os.environ.get("INFOSEEK_TEST_KILL_DIR", ".")) / f"killed-{seed}"
        self.steps = 0

    def act(self, observations: dict, infos: dict) -> dict:
        self.steps += 1
        if self.doomed and self.steps == 2:
            try:
                self.marker.touch(exist_ok=self.always)
            except FileExistsError:  # this trial's worker died once already
                pass
            else:
                os.kill(os.getpid(), signal.SIGKILL)
        return super().act(observations, infos)


def dying_random_policy(env: Any, seed: int | None = None, **options: Any) -> DyingRandomPolicy:
    """Planner factory usable as ``--planner test_bench:dying_random_policy``."""
    return DyingRandomPolicy(env, seed=seed)


def tiny_plan(trials: int = 3, groups: list[tuple[str, int]] | None = None) -> BenchPlan:
    return BenchPlan(
        env="bearings_v0",
        env_kwargs=dict(TINY_KWARGS),
        steps=TINY_STEPS,
        seed=7,
        groups=groups or [("random", 1), ("random", 3), ("single", 2)],
        trials=trials,
    )


def deterministic(records: list[TrialRecord]) -> dict[str, dict[str, Any]]:
    """Stored rows by key, without the timing fields (which legitimately differ between runs)."""
    rows = [record.to_row() for record in records]
    return {r["key"]: {k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in rows}


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> dict[str, TrialRecord]:
    """The tiny plan (random and single-node MI planner) run serially, uninterrupted."""
    out = tmp_path_factory.mktemp("reference")
    result = run_bench(tiny_plan(), out, backend="serial", progress=False)
    assert result.ran == 9 and result.skipped == 0
    return {record.key: record for record in read_records(out)}


# ------------------------------------------------------------------------------------ seeds
def test_trial_seeds_are_pure_and_share_the_target_across_groups() -> None:
    a = trial_seeds(7, "bearings_v0", "single", 4, 3)
    assert a == trial_seeds(7, "bearings_v0", "single", 4, 3)
    pairwise = trial_seeds(7, "bearings_v0", "pairwise", 4, 3)
    ten = trial_seeds(7, "bearings_v0", "pairwise", 10, 3)
    # same env seed (common random numbers), different policy seeds
    assert a[0] == pairwise[0] == ten[0]
    assert len({a[1], pairwise[1], ten[1]}) == 3
    others = {
        trial_seeds(8, "bearings_v0", "single", 4, 3)[0],
        trial_seeds(7, "beacon_v0", "single", 4, 3)[0],
        trial_seeds(7, "bearings_v0", "single", 4, 4)[0],
    }
    assert a[0] not in others and len(others) == 3
    assert all(0 <= s < 2**63 for s in (*a, *others))


def test_env_seed_gives_every_fleet_size_the_same_target() -> None:
    from infoseek.envs import make

    targets = []
    for n_agents in (2, 4, 10):
        env = make("bearings_v0", n_agents=n_agents, n_particles=100)
        env.reset(seed=trial_seeds(7, "bearings_v0", "pairwise", n_agents, 5)[0])
        targets.append(env.unwrapped.true_target())
    np.testing.assert_array_equal(targets[0], targets[1])
    np.testing.assert_array_equal(targets[0], targets[2])


# ---------------------------------------------------------------------------------- metrics
def test_position_metrics_match_brute_force(rng: np.random.Generator) -> None:
    class View:
        particles = rng.uniform(0, 10, size=(300, 3))
        weights = rng.dirichlet(np.ones(300))

    truth = np.array([4.0, 6.0])
    mass, error = position_metrics(View, truth, radius=1.5)
    estimate = sum(w * p[:2] for w, p in zip(View.weights, View.particles, strict=True))
    brute_mass = sum(
        w
        for w, p in zip(View.weights, View.particles, strict=True)
        if np.linalg.norm(p[:2] - estimate) <= 1.5
    )
    assert mass == pytest.approx(brute_mass, abs=1e-12)
    assert error == pytest.approx(np.linalg.norm(estimate - truth), abs=1e-12)


def test_min_separation_matches_brute_force(rng: np.random.Generator) -> None:
    states = rng.uniform(0, 20, size=(6, 4))
    brute = min(
        np.linalg.norm(states[i, :2] - states[j, :2]) for i in range(6) for j in range(i + 1, 6)
    )
    assert min_separation(states) == pytest.approx(brute, abs=1e-12)
    assert min_separation(states[:1]) is None


def test_time_to_localise_and_censored_summary() -> None:
    assert time_to_localise([0.0, 0.5, 0.9, 0.2]) == 2
    assert time_to_localise([0.0, 0.89, None]) is None
    records = [
        TrialView(
            planner="p",
            n_agents=2,
            trial=trial,
            env_seed=trial,
            radius=1.0,
            truth=None,
            mass_agent0=np.array(m, dtype=float),
            error_agent0=None,
            plan_time=np.array([0.001, 0.003]),
        )
        for trial, m in enumerate(([0, 0.95, 1], [0, 0.1, 0.92], [0, 0.1, 0.2], [0, 0.1, 0.3]))
    ]
    (row,) = summarise(records, steps=2)
    # times 1, 2 and two censored at 2 -> [1, 2, 2, 2]
    assert row.trials == 4 and row.never == 2
    assert row.ttl_mean == pytest.approx(1.75)
    assert row.ttl_quartiles == pytest.approx(tuple(np.percentile([1, 2, 2, 2], [25, 50, 75])))
    assert row.final_mass == pytest.approx(np.mean([1, 0.92, 0.2, 0.3]))
    assert row.plan_ms == pytest.approx(2.0)


def test_trial_record_matches_the_environment(reference: dict[str, TrialRecord]) -> None:
    """Replay one trial by hand: the record's series equal the env's own per-step infos."""
    from infoseek.envs import make
    from infoseek.experiments.policies import make_policy

    record = reference["random/agents=3/trial=1"]
    env = make("bearings_v0", n_agents=3, max_cycles=TINY_STEPS, **TINY_KWARGS)
    observations, infos = env.reset(seed=record.env_seed)
    policy = make_policy("random", env, seed=record.policy_seed)
    masses = [[infos[a]["posterior_mass"] for a in env.possible_agents]]
    entropies = [infos["vehicle_0"]["entropy"]]
    while env.agents:
        observations, _, _, _, infos = env.step(policy.act(observations, infos))
        masses.append([infos[a]["posterior_mass"] for a in env.possible_agents])
        entropies.append(infos["vehicle_0"]["entropy"])
    truth = env.unwrapped.true_target()
    assert record.n_steps == TINY_STEPS
    for name in ("mass_agent0", "mass_team", "error_agent0", "entropy_team", "min_separation"):
        assert len(getattr(record, name)) == TINY_STEPS + 1, name
    masses = np.array(masses)
    np.testing.assert_allclose(record.mass_agent0, masses[:, 0], atol=1e-9)
    np.testing.assert_allclose(record.mass_team, masses.mean(axis=1), atol=1e-9)
    np.testing.assert_allclose(record.entropy_agent0, entropies, atol=1e-12)
    np.testing.assert_allclose(record.truth, truth)
    assert all(s > 0 for s in record.min_separation)
    final_estimate = env.unwrapped.agent_belief("vehicle_0").mmse()[:2]
    assert record.error_agent0[-1] == pytest.approx(np.linalg.norm(final_estimate - truth[:2]))


# ------------------------------------------------------------------------------ environments
def test_a_default_spelled_out_is_the_stored_configuration_of_no_keyword(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--env-kwarg roughening=<its default>`` is the configuration of no keyword: the store
    written without it resumes with it (the default read off a built environment's config)."""
    from infoseek.envs import make
    from infoseek.experiments.cli import main

    default = make("bearings_v0", n_particles=100).unwrapped.config.roughening
    spelled = BenchPlan("bearings_v0", {"roughening": default}, 3, 0, [("random", 1)], 1)
    assert spelled.config() == BenchPlan("bearings_v0", {}, 3, 0, [("random", 1)], 1).config()
    other = BenchPlan("bearings_v0", {"roughening": default + 0.1}, 3, 0, [("random", 1)], 1)
    assert other.config()["env_kwargs"] == {"roughening": pytest.approx(default + 0.1)}
    argv = ["bench", "--planner", "random", "--agents", "1", "--trials", "2", "--steps", "2"]
    argv += ["--particles", "100", "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 0
    capsys.readouterr()
    assert main([*argv, "--env-kwarg", f"roughening={default}"]) == 0
    assert "0 trial(s) run, 2 of 2 already stored" in capsys.readouterr().out


def test_make_env_passes_belief_in_infos_to_the_constructor() -> None:
    """The harness's environments put every belief in the infos through their config (no
    attribute set on the environment, which would differ from its config)."""
    env = make_env("bearings_v0", n_agents=2, n_particles=100)
    assert env.unwrapped.config.belief_in_infos is True
    assert "belief_in_infos" not in vars(env.unwrapped)
    _, infos = env.reset(seed=1)
    assert all(infos[agent]["belief"] == env.unwrapped.belief(agent) for agent in env.agents)


# ------------------------------------------------------------------------------------ store
CONFIG = {"env": "x", "env_kwargs": {}, "steps": 3, "seed": 0, "version": "t"}


def test_store_append_is_durable_unique_and_torn_tail_is_dropped(tmp_path: Path) -> None:
    trials = tmp_path / "s" / store.TRIALS_NAME
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        assert s.append({"key": "a", "v": 1.5})
        assert not s.append({"key": "a", "v": 2.0})  # never stored twice
        assert s.append({"key": "b", "v": float("nan")})
        # durable at once: the journal holds both before the writer closes
        assert [json.loads(line)["key"] for line in trials.read_text().splitlines()] == ["a", "b"]
    assert trials.read_bytes() == b""  # closing moved them into a part
    assert store.part_keys(tmp_path / "s") == ["a", "b"]
    with open(trials, "ab") as f:
        f.write(b'{"key": "c", "v"')  # a killed writer's torn line
    with pytest.warns(store.StoreWarning, match="incomplete last line"):
        assert [r["key"] for r in read_rows(tmp_path / "s")] == ["a", "b"]
    with pytest.warns(store.StoreWarning):
        assert read_rows(tmp_path / "s")[1]["v"] is None  # strict JSON: NaN -> null
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        assert s.keys == {"a", "b"}
        assert trials.read_bytes() == b""  # truncated back to the last full line
        s.append({"key": "c", "v": 3})
    assert store.part_keys(tmp_path / "s") == ["a", "b", "c"]
    assert [r["v"] for r in read_rows(tmp_path / "s")] == [1.5, None, 3]


def test_store_keeps_a_killed_writers_journal_and_counts_every_trial_once(
    tmp_path: Path,
) -> None:
    """A writer killed before compacting leaves its trials in the journal; one killed between
    writing the part and emptying the journal leaves them in both: each is read once, and the
    next writer moves them into a part exactly once."""
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        s.append({"key": "a", "v": [0.1, 0.2]})
    journal = tmp_path / "s" / store.TRIALS_NAME
    journal.write_bytes(
        store.encode_journal_line({"key": "a", "v": [0.1, 0.2]})
        + store.encode_journal_line({"key": "b", "v": [1.0]})
    )
    assert [r["key"] for r in read_rows(tmp_path / "s")] == ["a", "b"]
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        assert s.keys == {"a", "b"}
        assert journal.read_bytes() == b""  # compacted on open
    assert store.part_keys(tmp_path / "s") == ["a", "b"]
    # series are single precision in a part, the rest as written
    (a, b) = read_rows(tmp_path / "s")
    assert a["v"] == [float(np.float32(0.1)), float(np.float32(0.2))] and b["v"] == [1.0]


def test_store_refuses_other_configurations_and_foreign_dirs(tmp_path: Path) -> None:
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        s.append({"key": "a"})
    files = [p for p in (tmp_path / "s").rglob("*") if p.is_file()]
    before = {p: p.read_bytes() for p in files}
    with pytest.raises(StoreConfigError, match="steps: stored 3, requested 4"):
        ResultsStore(tmp_path / "s", {**CONFIG, "steps": 4})
    assert {p: p.read_bytes() for p in (tmp_path / "s").rglob("*") if p.is_file()} == before
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "notes.txt").write_text("mine")
    with pytest.raises(StoreConfigError, match="not an infoseek results directory"):
        ResultsStore(tmp_path / "foreign", CONFIG)
    assert sorted(p.name for p in (tmp_path / "foreign").iterdir()) == ["notes.txt"]


def test_store_detects_damage_and_concurrent_writers(tmp_path: Path) -> None:
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        s.append({"key": "a"})
        with pytest.raises(StoreLockedError):
            ResultsStore(tmp_path / "s", CONFIG)
        s.append({"key": "b"})
    trials = tmp_path / "s" / store.TRIALS_NAME
    line = store.encode_journal_line
    trials.write_bytes(line({"key": "a"}) + b"not json\n" + line({"key": "b"}))
    with pytest.raises(StoreCorruptError, match="line 2"):
        read_rows(tmp_path / "s")


def test_a_series_of_nulls_is_stored(tmp_path: Path) -> None:
    """One-vehicle trials have no separation: ``min_separation`` is all nulls, a list column
    pyarrow cannot cast (``infoseek bench --agents 1`` failed when compacting)."""
    with ResultsStore(tmp_path / "s", CONFIG) as s:
        s.append({"key": "a", "min_separation": [None, None], "mass": [0.5, 1.0]})
        s.append({"key": "b", "min_separation": [None, None, None], "mass": [0.25]})
    assert [r["min_separation"] for r in read_rows(tmp_path / "s")] == [[None] * 2, [None] * 3]
    assert [r["mass"] for r in read_rows(tmp_path / "s")] == [[0.5, 1.0], [0.25]]


# ----------------------------------------------------------------------------- bench / resume
def test_bench_resumes_from_a_partial_store_with_a_torn_line(
    tmp_path: Path, reference: dict[str, TrialRecord]
) -> None:
    out = tmp_path / "run"
    with ResultsStore(out, tiny_plan().config()) as s:
        for spec in tiny_plan().specs()[::2]:  # every other trial "finished" before the kill
            s.append(run_trial(spec).to_row())
    with open(out / store.TRIALS_NAME, "ab") as f:
        f.write(b'{"key": "random/agents=3/trial=2", "mass_age')
    result = run_bench(tiny_plan(), out, backend="serial", progress=False)
    assert (result.ran, result.skipped) == (4, 5)
    keys = store.part_keys(out)
    assert sorted(keys) == sorted(set(keys)) and len(keys) == 9  # each trial exactly once
    assert deterministic(read_records(out)) == deterministic(list(reference.values()))
    again = run_bench(tiny_plan(), out, backend="serial", progress=False)
    assert (again.ran, again.skipped) == (0, 9)
    assert len(store.part_keys(out)) == 9


def test_bench_adds_groups_to_an_existing_run(tmp_path: Path) -> None:
    sleepy = "test_bench:sleepy_random_policy"
    first = run_bench(tiny_plan(trials=1, groups=[("random", 2)]), tmp_path, progress=False)
    result = run_bench(
        tiny_plan(trials=2, groups=[("random", 2), (sleepy, 2)]), tmp_path, progress=False
    )
    assert (result.ran, result.skipped) == (3, 1)
    assert {r.key for r in result.records} == {
        "random/agents=2/trial=0",
        "random/agents=2/trial=1",
        f"{sleepy}/agents=2/trial=0",
        f"{sleepy}/agents=2/trial=1",
    }
    assert result.records[0] == first.records[0]  # the stored trial is kept as it was
    assert len(read_records(tmp_path)) == 4


def test_bench_plan_rejects_bad_requests() -> None:
    with pytest.raises(ValueError, match="--trials"):
        tiny_plan(trials=0)
    with pytest.raises(ValueError, match="unknown planner 'nope'"):
        tiny_plan(groups=[("nope", 2)])
    with pytest.raises(ValueError, match="--agents"):
        tiny_plan(groups=[("random", 0)])
    with pytest.raises(ValueError, match="unknown backend"):
        executors.execute([TrialSpec("bearings_v0", {}, 1, "random", 1, 0, 1, 2)], backend="mpi")
    with pytest.raises(ValueError, match="no such file"):
        check_policy_path(str(TESTS_DIR / "no-such-model.zip"))


def test_trained_policy_hook_resolves_through_baselines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--policy PATH`` trials load ``PATH`` with ``infoseek.baselines.load_policy``."""
    import infoseek.baselines

    model = tmp_path / "model.zip"
    model.write_bytes(b"weights")
    loaded: list[tuple[str, int | None]] = []

    def fake_load_policy(path: str, env: Any, *, seed: int | None = None) -> Any:
        loaded.append((path, seed))
        return SleepyRandomPolicy(env, seed=seed)

    # setitem on the module dict: getattr would import the real (torch-based) loader first
    monkeypatch.setitem(vars(infoseek.baselines), "load_policy", fake_load_policy)
    assert check_policy_path(str(model)) == f"policy:{model.resolve()}"  # no store
    label = check_policy_path(str(model), tmp_path / "run")
    assert label == "policy:../model.zip"  # relative to the store: portable
    result = run_bench(tiny_plan(trials=2, groups=[(label, 2)]), tmp_path / "run", progress=False)
    assert [r.key for r in result.records] == [f"{label}/agents=2/trial={k}" for k in (0, 1)]
    # once while the plan is validated (before anything is written), then once per trial
    path = str(model.resolve())
    assert loaded == [(path, 0)] + [(path, r.policy_seed) for r in result.records]

    monkeypatch.setitem(vars(infoseek.baselines), "load_policy", None)
    with pytest.raises(ValueError, match="load_policy"):
        check_policy_path(str(model))


def test_process_backend_gives_identical_records(
    tmp_path: Path, reference: dict[str, TrialRecord]
) -> None:
    result = run_bench(tiny_plan(), tmp_path, backend="process", workers=2, progress=False)
    assert result.ran == 9
    assert deterministic(read_records(tmp_path)) == deterministic(list(reference.values()))


def test_process_backend_stopped_early_leaves_no_workers_running() -> None:
    """Closing the trial stream after the first record (what Ctrl-C or a failed trial does)
    terminates the pool's workers at once, instead of leaving a ~20 s receding-horizon trial
    running in a worker that the process would wait for at exit."""
    plan = BenchPlan(
        env="bearings_v0",
        env_kwargs={},
        steps=60,
        seed=7,
        groups=[("random", 1), ("horizon", 4)],
        trials=1,
    )
    before = set(multiprocessing.active_children())
    stream = executors.execute(plan.specs(), backend="process", workers=2)
    spec, _ = next(stream)
    assert spec.planner == "random"  # the horizon trial is still running in the other worker
    assert len(set(multiprocessing.active_children()) - before) == 2
    stream.close()
    assert set(multiprocessing.active_children()) - before == set()


@pytest.mark.parametrize("backend", ["serial", "process"])
def test_trials_are_generated_as_workers_free_up(backend: str) -> None:
    """A plan of 10^9 trials: the backends draw specs as trials finish, never all at once."""
    plan = BenchPlan(
        env="bearings_v0",
        env_kwargs={"n_particles": 100},
        steps=1,
        seed=7,
        groups=[("random", 1)],
        trials=10**9,
    )
    drawn = 0

    def counted() -> Iterator[TrialSpec]:
        nonlocal drawn
        for spec in plan.iter_specs():
            drawn += 1
            yield spec

    stream = executors.execute(counted(), backend=backend, workers=2)
    keys = [spec.key for spec, _ in itertools.islice(stream, 3)]
    stream.close()
    assert keys == [f"random/agents=1/trial={k}" for k in range(3)] or backend == "process"
    assert drawn <= 3 + executors.IN_FLIGHT_PER_WORKER * 2


def _peak_rss_of_a_stopped_bench(out: Path, trials: int, workers: int) -> tuple[int, int]:
    """Peak resident memory (KiB) and exit status of ``infoseek bench --trials TRIALS``
    stopped with SIGINT once 4 trials are journaled (limited to 4 GiB of address space, so
    a bench that lists every trial fails fast instead of filling the machine)."""
    environ = {**os.environ, "PYTHONPATH": str(TESTS_DIR), "INFOSEEK_TEST_SLEEP": "0.1"}
    args = ["--planner", "test_bench:sleepy_random_policy", "--agents", "1", "--steps", "2"]
    args += ["--particles", "100", "--workers", str(workers), "--no-progress"]
    limit = "import resource; resource.setrlimit(resource.RLIMIT_AS, (2**32, 2**32)); "
    script = limit + "import sys; from infoseek.experiments.launch import main; sys.exit(main())"
    process = subprocess.Popen(
        [sys.executable, "-c", script, "bench", "--trials", str(trials), *args]
        + ["--out", str(out)],
        env=environ,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    journal = out / store.TRIALS_NAME
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:  # ended by itself (an error): report its status
            process.returncode = os.waitstatus_to_exitcode(status)
            return usage.ru_maxrss, process.returncode
        if journal.exists() and journal.read_bytes().count(b"\n") >= 4:
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            process.returncode = os.waitstatus_to_exitcode(status)
            return usage.ru_maxrss, process.returncode
        time.sleep(0.05)
    process.kill()  # did not stop on SIGINT (e.g. busy listing 10^9 trials)
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    return usage.ru_maxrss, process.returncode


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS, wait4")
@pytest.mark.parametrize("workers", [1, 2])
def test_memory_of_a_bench_does_not_grow_with_the_trials_asked_for(
    tmp_path: Path, workers: int
) -> None:
    small, small_code = _peak_rss_of_a_stopped_bench(tmp_path / "small", 40, workers)
    huge, huge_code = _peak_rss_of_a_stopped_bench(tmp_path / "huge", 10**9, workers)
    assert (small_code, huge_code) == (130, 130)  # stopped like Ctrl-C, trials stored
    assert len(read_records(tmp_path / "huge")) >= 4
    assert huge < 1.1 * small + 30_000, (small, huge)  # KiB


@pytest.mark.ray
def test_ray_backend_gives_identical_records(
    tmp_path: Path, reference: dict[str, TrialRecord]
) -> None:
    pytest.importorskip("ray")
    result = run_bench(tiny_plan(), tmp_path, backend="ray", workers=2, progress=False)
    assert result.ran == 9
    assert deterministic(read_records(tmp_path)) == deterministic(list(reference.values()))


DYING = "test_bench:dying_random_policy"


def _run_with_killed_workers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, backend: str
) -> tuple[list[TrialRecord], list[str]]:
    """Run a plan of 4 trials on ``backend`` (2 workers) with the workers of trials 1 and 2
    killed mid-trial; returns the stored records and the markers of the deaths."""
    plan = tiny_plan(trials=4, groups=[(DYING, 2)])
    doomed = [spec.policy_seed for spec in plan.specs() if spec.trial in (1, 2)]
    markers = tmp_path / "markers"
    markers.mkdir()
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(TESTS_DIR), *sys.path]))
    monkeypatch.setenv("INFOSEEK_TEST_KILL_SEEDS", ",".join(map(str, doomed)))
    monkeypatch.setenv("INFOSEEK_TEST_KILL_DIR", str(markers))
    out = tmp_path / "killed"
    result = run_bench(plan, out, backend=backend, workers=2, progress=False)
    assert (result.ran, result.skipped) == (4, 0)
    return read_records(out), sorted(p.name for p in markers.iterdir())


def _unkilled_reference(tmp_path: Path) -> dict[str, dict[str, Any]]:
    """The same 4 trials run serially, no worker killed."""
    plan = tiny_plan(trials=4, groups=[(DYING, 2)])
    run_bench(plan, tmp_path / "reference", backend="serial", progress=False)
    return deterministic(read_records(tmp_path / "reference"))


@pytest.mark.parametrize("backend", ["process", "concurrent.futures:ProcessPoolExecutor"])
def test_a_trial_whose_worker_died_is_rerun_and_stored_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, backend: str
) -> None:
    """Two workers SIGKILLed mid-trial (the process pool, and any Executor given as
    module:factory, breaks): the trials in flight are resubmitted to a fresh pool, and the
    store ends with every trial exactly once, each equal to an uninterrupted serial run."""
    records, deaths = _run_with_killed_workers(tmp_path, monkeypatch, backend)
    assert len(deaths) == 2  # both doomed trials did kill their worker once
    keys = store.part_keys(tmp_path / "killed")
    assert sorted(keys) == [f"{DYING}/agents=2/trial={k}" for k in range(4)]
    monkeypatch.delenv("INFOSEEK_TEST_KILL_SEEDS")
    assert deterministic(records) == _unkilled_reference(tmp_path)


@pytest.mark.ray
def test_ray_retries_a_trial_whose_worker_died(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ray reruns a task whose worker was SIGKILLed (max_retries > 0); no trial lost or
    stored twice."""
    pytest.importorskip("ray")
    records, deaths = _run_with_killed_workers(tmp_path, monkeypatch, "ray")
    assert len(deaths) == 2
    keys = store.part_keys(tmp_path / "killed")
    assert sorted(keys) == [f"{DYING}/agents=2/trial={k}" for k in range(4)]
    monkeypatch.delenv("INFOSEEK_TEST_KILL_SEEDS")
    assert deterministic(records) == _unkilled_reference(tmp_path)


def test_a_worker_that_keeps_dying_fails_the_run_naming_its_trial(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A trial whose worker dies more than MAX_RETRIES times is reported with its seeds; the
    trials finished before are stored."""
    monkeypatch.setattr(executors, "MAX_RETRIES", 1)
    plan = tiny_plan(trials=2, groups=[(DYING, 2)])
    doomed = plan.specs()[1]
    markers = tmp_path / "markers"
    markers.mkdir()
    monkeypatch.setenv("INFOSEEK_TEST_KILL_SEEDS", str(doomed.policy_seed))
    monkeypatch.setenv("INFOSEEK_TEST_KILL_DIR", str(markers))
    monkeypatch.setenv("INFOSEEK_TEST_KILL_ALWAYS", "1")
    factory = "concurrent.futures:ProcessPoolExecutor"
    with pytest.raises(executors.TrialFailedError, match="its worker died 2 times") as error:
        run_bench(plan, tmp_path / "out", backend=factory, workers=1, progress=False)
    assert doomed.describe() in str(error.value)
    assert store.part_keys(tmp_path / "out") == [f"{DYING}/agents=2/trial=0"]


def test_an_executor_factory_backend_gives_identical_records(
    tmp_path: Path, reference: dict[str, TrialRecord]
) -> None:
    """``--backend module:factory``: any concurrent.futures.Executor, built with max_workers."""
    factory = "concurrent.futures:ThreadPoolExecutor"
    result = run_bench(tiny_plan(), tmp_path, backend=factory, workers=2, progress=False)
    assert result.ran == 9
    assert deterministic(read_records(tmp_path)) == deterministic(list(reference.values()))
    with pytest.raises(ValueError, match="has no 'NoSuchExecutor'"):
        run_bench(tiny_plan(), tmp_path, backend="concurrent.futures:NoSuchExecutor")


def test_killed_cli_run_resumes_to_the_uninterrupted_result(tmp_path: Path) -> None:
    """SIGKILL a ``bench`` subprocess after some trials are stored, rerun, compare."""
    args = [
        sys.executable,
        "-m",
        "infoseek.experiments.cli",
        "bench",
        "--planner",
        "test_bench:sleepy_random_policy",
        "--agents",
        "2",
        "--trials",
        "8",
        "--steps",
        "3",
        "--particles",
        "100",
        "--workers",
        "1",
        "--no-progress",
    ]
    environ = {**os.environ, "PYTHONPATH": str(TESTS_DIR), "INFOSEEK_TEST_SLEEP": "0.08"}
    killed_dir = tmp_path / "killed"
    process = subprocess.Popen(
        [*args, "--out", str(killed_dir)],
        env=environ,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    trials = killed_dir / store.TRIALS_NAME
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and process.poll() is None:
        if trials.exists() and trials.read_bytes().count(b"\n") >= 2:
            break
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert process.returncode == -signal.SIGKILL, process.stderr.read().decode()
    stored_before = len(read_records(killed_dir))
    assert 2 <= stored_before < 8
    environ["INFOSEEK_TEST_SLEEP"] = "0"
    rerun = subprocess.run(
        [*args, "--out", str(killed_dir)], env=environ, capture_output=True, text=True
    )
    assert rerun.returncode == 0, rerun.stderr
    assert f"{8 - stored_before} trial(s) run, {stored_before} of 8 already stored" in rerun.stdout
    fresh_dir = tmp_path / "fresh"
    fresh = subprocess.run(
        [*args, "--out", str(fresh_dir)], env=environ, capture_output=True, text=True
    )
    assert fresh.returncode == 0, fresh.stderr
    keys = store.part_keys(killed_dir)
    assert len(keys) == 8 == len(set(keys))
    assert deterministic(read_records(killed_dir)) == deterministic(read_records(fresh_dir))
    shutil.rmtree(tmp_path)


RL_RESULTS = Path(__file__).resolve().parents[1] / "experiments" / "results" / "rl"
SHIPPED = Path(__file__).resolve().parents[1] / "baselines" / "models"


def test_policy_labels_are_portable_and_readable(tmp_path: Path) -> None:
    from infoseek.experiments.policy_labels import display_name, policy_file, portable_label

    shipped = SHIPPED / "ppo_bearings_v0_4agents" / "model.zip"
    store_dir = tmp_path / "results" / "bench"
    model = tmp_path / "results" / "ppo_run" / "model.zip"
    assert portable_label(shipped, store_dir) == "policy:shipped/ppo_bearings_v0_4agents"
    assert portable_label(model, store_dir) == "policy:../ppo_run/model.zip"
    moved = tmp_path / "elsewhere" / "bench"  # the store and its models moved together
    assert policy_file("policy:../ppo_run/model.zip", moved) == moved.parent / "ppo_run/model.zip"
    assert policy_file("policy:shipped/ppo_bearings_v0_4agents", moved) == shipped.resolve()
    assert display_name("policy:../ppo_run/model.zip") == "policy ppo_run"
    assert (
        display_name("policy:shipped/ppo_bearings_v0_4agents") == "policy ppo_bearings_v0_4agents"
    )
    assert display_name("policy:/old/run/checkpoints/model_20_steps.zip") == (
        "policy checkpoints/model_20_steps"
    )
    row = GroupSummary("policy:shipped/ppo_bearings_v0_4agents", 4, 1, 1.0, (1, 1, 1), 0, 1, 1)
    assert "policy ppo_bearings_v0_4agents      4" in format_summary([row], 20)


def test_the_committed_rl_bench_resumes_and_verifies_from_another_checkout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fresh_cli: Callable[..., Any]
) -> None:
    """The README's RL bench command, run against a copy of experiments/results/rl somewhere
    else, finds every trial stored (the groups are keyed by portable labels, not by the path of
    the checkout that wrote them), and a stored trial of a policy group reproduces there, with
    ``infoseek verify`` in a fresh process (pinned numerics: this test process loaded NumPy and
    torch unpinned, whose last bits depend on the CPU)."""
    pytest.importorskip("stable_baselines3")
    from infoseek.experiments.cli import main

    copy = tmp_path / "another" / "rl"
    shutil.copytree(RL_RESULTS, copy)
    policies = [
        SHIPPED / "ppo_bearings_v0_4agents" / "model.zip",
        copy / "ppo_fixed_grid_reward_1m" / "model.zip",
        copy / "ppo_20_step_episodes" / "model.zip",
    ]
    argv = ["bench", "--env", "bearings_v0", *[f"--policy={p}" for p in policies]]
    for planner in ("single", "pairwise", "random", "lawnmower"):
        argv += ["--planner", planner]
    argv += ["--agents", "4", "--trials", "200", "--steps", "20", "--seed", "0"]
    assert (
        main([*argv, "--workers", "1", "--no-progress", "--out", str(copy / "bench_20_steps")]) == 0
    )
    out = capsys.readouterr().out
    assert "0 trial(s) run, 1400 of 1400 already stored" in out
    assert "policy ppo_bearings_v0_4agents" in out and "..." not in out
    group = "policy:../ppo_20_step_episodes/model.zip/4"
    verify = ["verify", str(copy / "bench_20_steps"), "--trials", "1", "--group", group]
    checked = fresh_cli([*verify, "--workers", "1", "--no-progress"])
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert "1 stored trial(s) rerun: 1 reproduced exactly" in checked.stdout


def test_changed_settings_turn_the_base_env_into_the_other() -> None:
    """``changed_settings`` gives exactly the registered keywords that differ, and a study plan
    with them is the other environment's defaults on the base environment's code."""
    from infoseek.envs.registration import registry
    from infoseek.experiments.environments import changed_settings

    settings = changed_settings("beacon_v1", "beacon_v0")
    assert settings == {"resample_threshold": 0.5, "tempering_ess": 0.5}
    v0, v1 = registry["beacon_v0"].kwargs, registry["beacon_v1"].kwargs
    assert {**v0, **settings, "name": v1["name"]} == v1
    assert changed_settings("beacon_v0", "beacon_v0") == {}
    with pytest.raises(ValueError, match="unknown environment 'beacon_v9'"):
        changed_settings("beacon_v9", "beacon_v0")
    plan = BenchPlan.for_study("beacon_v0", [("single", 4)], 3, particles=100, settings=settings)
    assert plan.config()["env_kwargs"] == {**settings, "n_particles": 100}
