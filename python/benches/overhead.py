"""The binding's own cost per step (issue 20 item 5): wall time of `VectorSwarmEnv.step` and of
`NativeEnv.step` minus the library's control step (`NativeEnv.last_step_s`), in microseconds, at
E = 1, 16 and 64, on the CPU backend unless --backend says otherwise (`adapter`: the WGSL kernels,
as on a GPU machine). The step itself is timed too, for scale.

Usage: python benches/overhead.py [--steps K] [--backend native|adapter|auto] [--adapter auto|gpu|cpu]
                                  [--set section.key=value ...]
"""

import argparse
import time

import numpy as np

import fluxswarm


def measure(num_envs, steps, sets, backend, adapter):
    env = fluxswarm.VectorSwarmEnv(
        num_envs=num_envs, overrides=sets, backend=backend, adapter=adapter, seed=1
    )
    env.reset()
    actions = np.tile(np.array([-1.0, 0.0], np.float32), (num_envs, env.num_agents, 1))
    rows = {}
    for name, step in (("native", env.native.step), ("vector", env.step)):
        step(actions)  # warm-up
        wall, inner = [], []
        for _ in range(steps):
            t0 = time.perf_counter()
            step(actions)
            wall.append(time.perf_counter() - t0)
            inner.append(env.native.last_step_s)
        wall, inner = np.array(wall), np.array(inner)
        rows[name] = (np.median(wall - inner) * 1e6, np.median(inner) * 1e3)
    env.close()
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--backend", choices=["native", "adapter", "auto"], default="native")
    parser.add_argument("--adapter", choices=["auto", "gpu", "cpu"], default="auto")
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()
    print("envs,binding_us_native_step,binding_us_vector_step,library_step_ms")
    for e in (1, 16, 64):
        r = measure(e, args.steps, args.sets, args.backend, args.adapter)
        print(f"{e},{r['native'][0]:.1f},{r['vector'][0]:.1f},{r['vector'][1]:.3f}")


if __name__ == "__main__":
    main()
