"""The Python package against its contract (SPEC section 8, docs/python.md): shapes and dtypes,
same-step autoreset, clear errors, the same numbers as the CLI's `rollout`, PettingZoo's API
and seed tests, and the wrappers. A small channel (30 x 2 mm, 300 x 20 cells, 3 members) on
the CPU backend keeps each test under a few seconds."""

import csv
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import fluxswarm

ROOT = pathlib.Path(__file__).resolve().parents[2]

SMALL = [
    "solver.backend=native",
    "domain.nx=300",
    "domain.ny=20",
    "domain.length_m=0.03",
    "domain.height_m=0.002",
    "domain.success_x_m=0.006",
    "domain.failure_x_m=0.024",
    "swarm.count=3",
    'swarm.layout="explicit"',
    "swarm.positions_m=[[0.014, 0.0006], [0.015, 0.0014], [0.016, 0.0006]]",
    "env.max_steps=6",
]
UPSTREAM = np.array([-1.0, 0.0], dtype=np.float32)


def small(num_envs=2, extra=(), seed=0):
    return fluxswarm.VectorSwarmEnv(num_envs=num_envs, overrides=SMALL + list(extra), seed=seed)


def test_shapes_dtypes_and_spaces():
    env = small()
    obs, info = env.reset(seed=1)
    assert obs.shape == (2, 3, 8) and obs.dtype == np.float32
    assert env.observation_space.contains(obs)
    assert env.single_action_space.shape == (3, 2)
    assert env.action_space.shape == (2, 3, 2)
    assert env.metadata["autoreset_mode"] == fluxswarm.AutoresetMode.SAME_STEP
    obs, rewards, terminated, truncated, infos = env.step(np.zeros((2, 3, 2), np.float32))
    assert rewards.shape == (2, 3, 3) and rewards.dtype == np.float32
    assert terminated.shape == (2,) and terminated.dtype == bool
    assert truncated.shape == (2,) and truncated.dtype == bool
    env.close()


def test_same_step_autoreset_reports_the_final_observation_and_info():
    env = small()
    env.reset(seed=2)
    actions = np.tile(UPSTREAM, (2, 3, 1))
    for step in range(1, 7):
        obs, rewards, terminated, truncated, infos = env.step(actions)
        if step < 6:
            assert "final_obs" not in infos, step
    # env.max_steps = 6: both environments truncate at step 6 and start again at once.
    assert truncated.all() and not terminated.any()
    assert infos["_final_obs"].all() and infos["_final_info"].all()
    final = infos["final_info"]
    assert list(final["outcome"]) == ["timeout", "timeout"]
    assert list(final["steps"]) == [6.0, 6.0]
    assert final["_progress"].all()
    # The returned observation is the new episode's first (the members are back at the start).
    assert not np.allclose(obs, infos["final_obs"])
    env.close()


def test_bad_arguments_raise_clear_python_errors():
    env = small()
    env.reset()
    with pytest.raises(ValueError, match=r"takes \[2, 3, 2\]"):
        env.step(np.zeros((2, 4, 2), np.float32))
    with pytest.raises(ValueError, match="NaN"):
        env.step(np.full((2, 3, 2), np.nan, np.float32))
    with pytest.raises(TypeError):
        env.native.step(np.zeros((2, 3, 2), np.float64))
    with pytest.raises(ValueError, match="outside the batch"):
        env.fields(5)
    env.close()
    with pytest.raises(ValueError, match="closed"):
        env.native.reset()
    with pytest.raises(ValueError, match="scael"):
        fluxswarm.VectorSwarmEnv(overrides=["inlet.scael=1"])
    with pytest.raises(ValueError, match="num_envs"):
        fluxswarm.VectorSwarmEnv(num_envs=0)
    with pytest.raises(ValueError, match="adapter"):
        fluxswarm.VectorSwarmEnv(adapter="tpu")
    with pytest.raises(ValueError, match="render_mode"):
        fluxswarm.parallel_env(overrides=SMALL, render_mode="human")
    with pytest.raises(ValueError, match="does not exist|cannot read|reading"):
        fluxswarm.VectorSwarmEnv(config="/nonexistent/config.toml")


def test_fields_and_render():
    env = small(num_envs=1)
    env.reset()
    env.step(np.tile(UPSTREAM, (1, 3, 1)))
    ux, uy, p = env.fields(0)
    assert ux.shape == uy.shape == p.shape == (20, 300)
    assert np.isfinite(ux).all() and ux.max() > 0
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    env.close()


def cli_binary():
    path = os.environ.get("FLUXSWARM_BIN") or str(ROOT / "target" / "release" / "fluxswarm-gpu")
    if not pathlib.Path(path).exists():
        pytest.skip(f"no CLI binary at {path} (build it, or set FLUXSWARM_BIN)")
    return path


def test_the_same_numbers_as_the_cli_rollout(tmp_path):
    """`rollout --policy upstream` and the Python loop with the same configuration, seed and
    actions give the same episodes (the CLI writes 6 decimals) and the same swarm track."""
    sets = SMALL + ["inlet.random_phase=true", "env.position_jitter_m=1e-4"]
    args = [cli_binary(), "rollout", "--policy", "upstream", "--envs", "2", "--episodes", "2",
            "--seed", "7", "--out", str(tmp_path / "cli")]
    for s in sets:
        args += ["--set", s]
    subprocess.run(args, check=True, capture_output=True)
    with open(tmp_path / "cli" / "episodes.csv") as f:
        cli = {int(r["env"]): r for r in csv.DictReader(f)}
    with open(tmp_path / "cli" / "swarm.csv") as f:
        x_cli = {(int(r["env"]), int(r["step"])): float(r["x_com_mm"]) for r in csv.DictReader(f)}

    env = fluxswarm.VectorSwarmEnv(num_envs=2, overrides=sets, seed=7)
    obs, _ = env.reset()
    done = {}
    step = 0
    while len(done) < 2:
        obs, rewards, terminated, truncated, infos = env.step(np.tile(UPSTREAM, (2, 3, 1)))
        step += 1
        for e in range(2):
            if e not in done:
                ux, uy, p = env.fields(e)  # fields stay readable mid-episode
            if "final_info" in infos and infos["_final_info"][e] and e not in done:
                done[e] = {k: infos["final_info"][k][e] for k in ("steps", "outcome", "progress", "energy", "smoothness")}
    for e in range(2):
        assert int(done[e]["steps"]) == int(cli[e]["steps"])
        assert done[e]["outcome"] == cli[e]["outcome"]
        for k in ("progress", "energy", "smoothness"):
            assert abs(done[e][k] - float(cli[e][k])) <= 5e-7 * max(1.0, abs(float(cli[e][k]))), k
    assert x_cli[(0, 0)] > 0
    env.close()


def test_overrides_as_a_dict_reach_the_configuration():
    env = fluxswarm.VectorSwarmEnv(
        num_envs=1,
        overrides={
            "domain.nx": 300,
            "domain.length_m": 0.03,
            "domain.success_x_m": 0.006,
            "domain.failure_x_m": 0.024,
            "swarm.count": 2,
            "swarm.layout": "explicit",
            "swarm.positions_m": [[0.014, 0.0006], [0.015, 0.0014]],
            "inlet.random_phase": True,
            "inlet.scale": np.float64(0.8),
        },
        backend="native",
    )
    text = env.native.config_toml()
    assert "scale = 0.8" in text and "random_phase = true" in text
    assert env.num_agents == 2 and "CPU backend" in env.native.backend
    with pytest.raises(ValueError, match="override value"):
        fluxswarm.VectorSwarmEnv(overrides={"inlet.scale": object()})
    env.close()


def test_pettingzoo_parallel_api_and_seed_tests():
    from pettingzoo.test import parallel_api_test, parallel_seed_test

    parallel_api_test(fluxswarm.parallel_env(overrides=SMALL), num_cycles=20)
    parallel_seed_test(
        lambda: fluxswarm.parallel_env(overrides=SMALL + ["inlet.random_phase=true"]),
        num_cycles=10,
    )


def test_parallel_env_has_vector_rewards_and_ends_without_autoreset():
    env = fluxswarm.parallel_env(overrides=SMALL)
    obs, infos = env.reset(seed=4)
    assert env.agents == ["member_0", "member_1", "member_2"]
    assert env.reward_space("member_0").shape == (3,)
    assert env.state().shape == (3, 8)
    for _ in range(6):
        obs, rewards, terms, truncs, infos = env.step({a: UPSTREAM for a in env.agents})
    assert rewards["member_1"].shape == (3,) and rewards["member_1"].dtype == np.float32
    assert all(truncs.values()) and env.agents == []
    assert infos["member_0"]["episode"]["outcome"] == "timeout"
    with pytest.raises(ValueError, match="reset"):
        env.step({})
    env.close()


def test_flattened_agents_and_scalarised_rewards():
    env = fluxswarm.ScalarizeReward(fluxswarm.FlattenAgents(small()), weights=(9.0, 1.0, 1.0))
    obs, _ = env.reset(seed=5)
    assert obs.shape == (6, 8)
    obs, rewards, terminated, truncated, infos = env.step(np.tile(UPSTREAM, (6, 1)))
    assert rewards.shape == (6,)

    raw = small()
    raw.reset(seed=5)
    _, vector, _, _, _ = raw.step(np.tile(UPSTREAM, (2, 3, 1)))
    np.testing.assert_allclose(rewards, vector.reshape(6, 3) @ np.array([9.0, 1.0, 1.0], np.float32), rtol=1e-6)
    env.close()
    raw.close()


def test_momaland_api_test():
    """MOMAland's API test (for AEC environments) on our parallel environment through
    MOMAland's own conversion. (MOMAland 0.2's wrapper tests import
    `gymnasium.wrappers.normalize`, gone in Gymnasium 1.x, so they cannot run here.)"""
    pytest.importorskip("momaland")
    from momaland.test.api_test import api_test
    from momaland.utils.conversions import mo_parallel_to_aec
    from momaland.utils.env import MOParallelEnv

    env = fluxswarm.parallel_env(overrides=SMALL)
    assert isinstance(env, MOParallelEnv)
    api_test(mo_parallel_to_aec(env), num_cycles=20)


@pytest.mark.parametrize("example", ["baseline_rollout.py", "random_pettingzoo.py"])
def test_the_examples_run(example):
    path = ROOT / "python" / "examples" / example
    args = [sys.executable, str(path)]
    for s in SMALL:
        args += ["--set", s]
    if example == "baseline_rollout.py":
        args += ["--envs", "2", "--episodes", "2"]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    assert "timeout" in out or "failure" in out or "success" in out, out


def test_momaland_momappo_example_trains_and_evaluates(tmp_path):
    """MOMAland's own MOMAPPO through the example, for one update of 1280 steps on the small
    channel, then its evaluation; skipped where MOMAland's learning stack is not installed
    (`pip install "./python[momappo]"`: JAX and torch, too heavy for CI)."""
    pytest.importorskip("momaland.learning.cooperative_momappo.continuous_momappo")
    path = ROOT / "python" / "examples" / "momappo_frontier.py"
    args = [sys.executable, str(path), "--steps", "1280", "--eval-envs", "2",
            "--eval-episodes", "3", "--out", str(tmp_path)]
    for s in SMALL:
        args += ["--set", s]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    assert "sampled: " in out and "deterministic: " in out, out
    import json

    summary = json.loads((tmp_path / "summary.json").read_text())
    for mode in ("sampled", "deterministic"):
        s = summary[mode]
        assert s["episodes"] == 3
        assert s["successes"] + s["failures"] + s["timeouts"] == 3
        with open(tmp_path / f"eval-{mode}.csv") as f:
            assert len(list(csv.DictReader(f))) == 3


def test_the_overhead_benchmark_runs():
    path = ROOT / "python" / "benches" / "overhead.py"
    args = [sys.executable, str(path), "--steps", "3"]
    for s in SMALL:
        args += ["--set", s]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout.splitlines()
    assert out[0].startswith("envs,") and [r.split(",")[0] for r in out[1:]] == ["1", "16", "64"]
