"""MOMAland's own MOMAPPO (continuous, JAX) trained on a fluxswarm scenario: an independent
check of our candle learner (docs/python.md; the protocol is in docs/controllability.md).

MOMAland 0.2's `momaland.learning.cooperative_momappo.continuous_momappo` is used unchanged:
its `train(args, env, weights, key)` with its own defaults (256-256 tanh actor and critic,
Adam 1e-3 annealed, gamma 0.99, GAE 0.99, clip 0.2, 1280 steps per update, 2 epochs of 2
minibatches, no entropy bonus) and its own wrappers (clip_actions_v0, normalize_obs_v0,
agent_indicator_v0, a running reward normaliser per objective and the linear scalarisation by
`--weights`). Its script keeps its state in module globals; `train_momappo` sets them as its
`__main__` does. It trains on one environment and counts each step as one timestep.

Two adapters, both declared, none changing the numbers our environment returns:
- `normalize_obs_v0` needs finite observation bounds. Our features are already scaled by
  SPEC section 3's constants, so the adapter declares the box [-1, 1]. That makes MOMAland's
  rescale to [-1, 1] the identity. Nothing is clipped.
- MOMAland's critic takes a flat global state, so `state()` is the (8 N,) concatenation of
  the members' observations, the same joint state our critic reads.

Then the trained actor is evaluated like our runs (`eval --envs E --episodes K --seed S`):
on the vector environment, once sampled and once with the mean action. The per-episode CSVs
and a summary go to `--out`.

Needs `pip install "momaland[learning]==0.2.0"` beside fluxswarm. It brings JAX, flax,
distrax, optax, supersuit and morl_baselines, whose requirements include torch.

Usage (from the repository root):
    python python/examples/momappo_frontier.py --config configs/frontier-fine-085.toml \
        --steps 108000 --seed 1 --weights 9 1 1 --eval-episodes 40 --eval-seed 201 \
        --out runs/momappo-frontier-fine-085
"""

import argparse
import csv
import json
import math
import os
import sys
import time

import numpy as np

import fluxswarm


def declared_bounds(env):
    """`env` with the observation box [-1, 1] and a flat `state()` (module header); everything
    else is passed through."""
    from gymnasium import spaces
    from pettingzoo.utils.wrappers import BaseParallelWrapper

    box = spaces.Box(-1.0, 1.0, shape=(8,), dtype=np.float32)
    flat = spaces.Box(-np.inf, np.inf, shape=(8 * len(env.possible_agents),), dtype=np.float32)

    class DeclaredBounds(BaseParallelWrapper):
        possible_agents = property(lambda self: self.env.possible_agents)
        agents = property(lambda self: self.env.agents)
        metadata = env.metadata

        def observation_space(self, agent):
            return box

        def state(self):
            return self.env.state().reshape(-1)

        @property
        def state_space(self):
            return flat

    return DeclaredBounds(env)


def momappo_args(steps, seed):
    """MOMAland's own argument parser with its defaults, as its command line would give them."""
    from momaland.learning.cooperative_momappo import continuous_momappo as cm

    argv = sys.argv
    sys.argv = [
        "continuous_momappo", "--env-id", "fluxswarm", "--ref-point", "0", "0", "0",
        "--seed", str(seed), "--timesteps-per-weight", str(steps), "--track", "false",
    ]
    try:
        return cm.parse_args()
    finally:
        sys.argv = argv


def train_momappo(env, args, weights):
    """Runs MOMAland's `train` for one weight vector; returns the actor module and its
    parameters. Sets the module globals its `__main__` sets."""
    import jax
    from momaland.learning.cooperative_momappo import continuous_momappo as cm

    np.random.seed(args.seed)
    env.reset(seed=args.seed)
    cm.args = args
    cm.env = env
    cm.current_timestep = 0
    cm.start_time = time.time()
    cm.single_action_space = env.action_space(env.possible_agents[0])
    cm.actor = cm.Actor(
        cm.single_action_space.shape[0], net_arch=args.actor_net_arch, activation=args.activation
    )
    cm.critic = cm.Critic(net_arch=args.critic_net_arch, activation=args.activation)
    cm.vmapped_get_value = jax.vmap(cm.critic.apply, in_axes=(None, 0))
    cm.critic.apply = jax.jit(cm.critic.apply)
    out = cm.train(args, env, np.asarray(weights, dtype=np.float64), jax.random.PRNGKey(args.seed))
    return cm.actor, out["runner_state"][0].params


def load_actor(args, env, path):
    """The actor module and the parameters saved in `path` by an earlier run."""
    import flax.serialization
    import jax
    from momaland.learning.cooperative_momappo import continuous_momappo as cm

    n = len(env.possible_agents)
    actor = cm.Actor(2, net_arch=args.actor_net_arch, activation=args.activation)
    template = actor.init(jax.random.PRNGKey(0), np.zeros(8 + n, dtype=np.float32))
    with open(path, "rb") as f:
        return actor, flax.serialization.from_bytes(template, f.read())


def actor_inputs(obs):
    """What MOMAland's wrappers feed the actor: the observation rescaled from the declared
    box [-1, 1] to [-1, 1] (the identity) and a one-hot agent indicator of height 1 (the box's
    maximum). obs [E, N, 8] -> [E, N, 8 + N]."""
    e, n, _ = obs.shape
    indicator = np.broadcast_to(np.eye(n, dtype=np.float32), (e, n, n))
    return np.concatenate([obs, indicator], axis=-1)


def check_actor_inputs(env, seed):
    """The hand-built inputs equal what MOMAland's wrapper stack gives, on a first observation."""
    from supersuit import agent_indicator_v0, clip_actions_v0, normalize_obs_v0

    wrapped = agent_indicator_v0(normalize_obs_v0(clip_actions_v0(env), env_min=-1.0, env_max=1.0))
    obs, _ = wrapped.reset(seed=seed)
    raw, _ = env.reset(seed=seed)
    by_hand = actor_inputs(np.stack([raw[a] for a in env.possible_agents])[None])[0]
    through = np.stack([obs[a] for a in env.possible_agents])
    if not np.allclose(by_hand, through, atol=1e-6):
        raise RuntimeError("the actor's inputs differ from MOMAland's wrappers")


def evaluate(actor, params, config, overrides, envs, episodes, seed, deterministic):
    """`episodes` episodes on `envs` environments from `seed`, the actor's mean action or a
    sample, clipped to the action box as clip_actions_v0 does. As the CLI's `eval` counts
    them: each environment's first floor(K/E) episodes, plus one for the first K mod E
    environments (so that short episodes are not over-counted). Returns one dict per episode
    in the order they end."""
    import jax

    env = fluxswarm.VectorSwarmEnv(num_envs=envs, config=config, overrides=overrides, seed=seed)
    obs, _ = env.reset(seed=seed)

    def mean_and_std(params, x):
        pi = actor.apply(params, x)
        return pi.mean(), pi.stddev()

    mean_and_std = jax.jit(mean_and_std)
    rng = np.random.default_rng(seed)
    quota = [episodes // envs + (e < episodes % envs) for e in range(envs)]
    counted = [0] * envs
    rows = []
    while len(rows) < episodes:
        mean, std = (np.asarray(a, dtype=np.float32) for a in mean_and_std(params, actor_inputs(obs)))
        action = mean if deterministic else mean + std * rng.standard_normal(mean.shape, np.float32)
        action = np.clip(np.asarray(action, dtype=np.float32), -1.0, 1.0)
        obs, _, _, _, infos = env.step(action)
        if "final_info" in infos:
            info = infos["final_info"]
            for e in np.flatnonzero(infos["_final_info"]):
                if counted[e] < quota[e]:
                    counted[e] += 1
                    rows.append({
                        "episode": len(rows), "env": int(e), "outcome": info["outcome"][e],
                        "steps": int(info["steps"][e]), "progress": float(info["progress"][e]),
                        "energy": float(info["energy"][e]),
                        "smoothness": float(info["smoothness"][e]),
                        "final_x_com_mm": float(info["final_x_com_mm"][e]),
                    })
    env.close()
    return rows


def wilson(successes, n, z=1.96):
    """The Wilson 95 % interval of a proportion."""
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def summarise(rows):
    n = len(rows)
    wins = sum(r["outcome"] == "success" for r in rows)
    lo, hi = wilson(wins, n)
    return {
        "episodes": n, "successes": wins, "success_rate": wins / n if n else 0.0,
        "wilson95": [lo, hi],
        "failures": sum(r["outcome"] == "failure" for r in rows),
        "timeouts": sum(r["outcome"] == "timeout" for r in rows),
        "mean_steps": float(np.mean([r["steps"] for r in rows])) if n else 0.0,
        "mean_progress": float(np.mean([r["progress"] for r in rows])) if n else 0.0,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default=None, help="a TOML config (default: the paper's)")
    parser.add_argument("--set", action="append", default=[], dest="sets",
                        help="section.key=value, as the CLI's --set")
    parser.add_argument("--steps", type=int, default=108000, help="training timesteps")
    parser.add_argument("--seed", type=int, default=1, help="the training seed")
    parser.add_argument("--weights", type=float, nargs=3, default=[9.0, 1.0, 1.0],
                        help="progress, energy, smoothness weights (normalised to sum 1)")
    parser.add_argument("--eval-envs", type=int, default=4)
    parser.add_argument("--eval-episodes", type=int, default=40)
    parser.add_argument("--eval-seed", type=int, default=201)
    parser.add_argument("--out", default="runs/momappo")
    parser.add_argument("--eval-only", action="store_true",
                        help="evaluate OUT/actor.msgpack again instead of training")
    args = parser.parse_args()

    import flax.serialization

    weights = np.asarray(args.weights) / np.sum(args.weights)
    os.makedirs(args.out, exist_ok=True)
    env = declared_bounds(
        fluxswarm.parallel_env(config=args.config, overrides=args.sets, seed=args.seed))
    check_actor_inputs(env, args.seed)
    margs = momappo_args(args.steps, args.seed)
    actor_file = os.path.join(args.out, "actor.msgpack")
    if args.eval_only:
        actor, params = load_actor(margs, env, actor_file)
        train_s = None
    else:
        started = time.time()
        actor, params = train_momappo(env, margs, weights)
        train_s = time.time() - started
        with open(actor_file, "wb") as f:
            f.write(flax.serialization.to_bytes(params))

    summary = {
        "config": args.config, "overrides": args.sets, "seed": args.seed,
        "weights": weights.tolist(), "steps": args.steps, "train_s": train_s,
        "momappo": {k: v for k, v in vars(margs).items() if isinstance(v, (int, float, str, list))},
    }
    for mode, deterministic in (("sampled", False), ("deterministic", True)):
        rows = evaluate(actor, params, args.config, args.sets, args.eval_envs,
                        args.eval_episodes, args.eval_seed, deterministic)
        with open(os.path.join(args.out, f"eval-{mode}.csv"), "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        summary[mode] = summarise(rows)
        s = summary[mode]
        print(f"{mode}: {s['successes']}/{s['episodes']} successes "
              f"({100 * s['success_rate']:.0f} %, Wilson 95 % {100 * s['wilson95'][0]:.0f}-"
              f"{100 * s['wilson95'][1]:.0f} %), {s['failures']} failures, {s['timeouts']} timeouts, "
              f"mean {s['mean_steps']:.0f} steps")
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    env.close()


if __name__ == "__main__":
    main()
