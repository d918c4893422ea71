"""A random policy through PettingZoo's parallel API: one environment, every member samples its
action from its action space, until the episode ends.

Usage: python examples/random_pettingzoo.py [--seed S] [--set section.key=value ...]
"""

import argparse

import numpy as np

import fluxswarm


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()

    env = fluxswarm.parallel_env(overrides=args.sets, seed=args.seed)
    observations, infos = env.reset(seed=args.seed)
    for i, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(args.seed + i)
    returns = {a: np.zeros(3) for a in env.possible_agents}
    steps = 0
    while env.agents:
        actions = {a: env.action_space(a).sample() for a in env.agents}
        observations, rewards, terminations, truncations, infos = env.step(actions)
        for a, r in rewards.items():
            returns[a] += r
        steps += 1
    episode = infos[env.possible_agents[0]]["episode"]
    print(f"{steps} steps, outcome {episode['outcome']}")
    mean = np.mean(list(returns.values()), axis=0)
    print("mean return per member (progress, energy, smoothness):", np.round(mean, 3))
    env.close()


if __name__ == "__main__":
    main()
