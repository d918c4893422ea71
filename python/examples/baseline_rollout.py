"""A baseline rollout through the Gymnasium vector interface: E environments push straight
upstream (the `upstream` controller of `fluxswarm-gpu rollout`) until K episodes have ended;
prints each episode's outcome and metrics.

Usage: python examples/baseline_rollout.py [--envs E] [--episodes K] [--seed S]
                                           [--set section.key=value ...]
"""

import argparse

import numpy as np

import fluxswarm


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--envs", type=int, default=4)
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()

    env = fluxswarm.VectorSwarmEnv(num_envs=args.envs, overrides=args.sets, seed=args.seed)
    print(env.native.backend)
    env.reset()
    upstream = np.tile(np.array([-1.0, 0.0], np.float32), (args.envs, env.num_agents, 1))
    finished = 0
    print("env,steps,outcome,progress,energy,smoothness")
    while finished < args.episodes:
        _, _, _, _, infos = env.step(upstream)
        if "final_info" in infos:
            info = infos["final_info"]
            for e in np.flatnonzero(infos["_final_info"]):
                print(f"{e},{int(info['steps'][e])},{info['outcome'][e]},{info['progress'][e]:.3f},"
                      f"{info['energy'][e]:.4f},{info['smoothness'][e]:.4f}")
                finished += 1
    env.close()


if __name__ == "__main__":
    main()
