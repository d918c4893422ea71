"""fluxswarm: the batched micro-robot swarm environment of fluxswarm-gpu in Python.

E environments of N members each step together on one flow batch (the WGSL kernels on a GPU,
or the CPU backend), exactly as the ``fluxswarm-gpu`` CLI steps them:

- :class:`VectorSwarmEnv`: a Gymnasium (>= 1.1) vector environment with same-step autoreset.
  Observations ``[E, N, 8]`` float32, actions ``[E, N, 2]``, vector rewards ``[E, N, 3]``
  (progress, energy, smoothness), flags ``[E]``.
- :func:`parallel_env`: one environment as a PettingZoo ``ParallelEnv`` (a MOMAland
  ``MOParallelEnv`` when MOMAland is installed): agents ``member_0`` .. ``member_{N-1}``,
  per-agent reward vectors of shape (3,), no autoreset.
- :class:`FlattenAgents` and :class:`ScalarizeReward`: wrappers for learners that expect one
  reward per environment.

The action space is the box [-1, 1]^2 per member. The environment clips each action's norm at
1 (thrust ``F_max * a / max(1, |a|)``), so the corners of the box act as their unit vectors.
docs/python.md has the details.
"""

from __future__ import annotations

import functools
from typing import Any, Optional, Sequence

import numpy as np
import gymnasium
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from ._native import NativeEnv, __version__

__all__ = [
    "NativeEnv",
    "VectorSwarmEnv",
    "SwarmParallelEnv",
    "parallel_env",
    "FlattenAgents",
    "ScalarizeReward",
    "OBJECTIVES",
    "AutoresetMode",
    "__version__",
]

#: The reward objectives, in the order of the last reward axis.
OBJECTIVES = ("progress", "energy", "smoothness")

_EPISODE_KEYS = ("steps", "progress", "energy", "smoothness", "scalar_return", "final_x_com_mm")


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(value.item() if isinstance(value, np.generic) else value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise ValueError(f"override value {value!r}: give a bool, number, string or list of them")


def _overrides(overrides, backend: str) -> list:
    """``--set`` strings from a dict ``{"section.key": value}`` (or strings ``"section.key=value"``
    as the CLI takes them), with ``solver.backend`` first so that an override can still set it."""
    sets = [f'solver.backend="{backend}"']
    if overrides is None:
        return sets
    if isinstance(overrides, dict):
        for key, value in overrides.items():
            sets.append(f"{key}={_toml_value(value)}")
        return sets
    if isinstance(overrides, str):
        raise ValueError('overrides: give a dict {"section.key": value} or a list of "section.key=value"')
    return sets + [str(o) for o in overrides]


def _native(num_envs, config, overrides, seed, backend, adapter, render_mode) -> NativeEnv:
    """The native batch both interfaces wrap, after checking what only Python sees."""
    if render_mode not in (None, "rgb_array"):
        raise ValueError(f"render_mode {render_mode!r}: give None or 'rgb_array'")
    return NativeEnv(num_envs, config, _overrides(overrides, backend), seed, adapter)


def _obs_space(n: int) -> spaces.Box:
    return spaces.Box(-np.inf, np.inf, shape=(n, 8), dtype=np.float32)


def _act_space(n: int) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, shape=(n, 2), dtype=np.float32)


class VectorSwarmEnv(VectorEnv):
    """E swarm environments as one Gymnasium vector environment (same-step autoreset).

    ``step`` returns rewards ``[E, N, 3]``. When an environment's episode ends, the returned
    observation is already its next episode's first one; ``infos["final_obs"]`` holds the
    last observation and ``infos["final_info"]`` the episode's metrics (``steps``, ``outcome``,
    ``progress``, ``energy``, ``smoothness``, ``scalar_return``, ``final_x_com_mm``,
    ``diverged``), each with its ``_``-prefixed mask. A diverged environment (its flow blew up)
    reports ``terminated``, so that no learner bootstraps from its state.

    Args:
        num_envs: environments in the batch (E).
        config: a TOML file merged over the paper's setup (None: the paper's setup).
        overrides: ``{"section.key": value}`` (or ``"section.key=value"`` strings, as the CLI's
            ``--set``), applied over the configuration.
        seed: seeds the start phases and jitter (``reset(seed=...)`` reseeds).
        backend: ``solver.backend``: ``"auto"`` (the WGSL kernels on a GPU after a self-check,
            else the CPU backend), ``"adapter"`` or ``"native"``.
        adapter: ``"auto"``, ``"gpu"`` or ``"cpu"``, as the CLI's ``--adapter``.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": ["rgb_array"]}

    def __init__(
        self,
        num_envs: int = 1,
        config: Optional[str] = None,
        overrides=None,
        seed: int = 0,
        backend: str = "auto",
        adapter: str = "auto",
        render_mode: Optional[str] = None,
    ):
        self.native = _native(num_envs, config, overrides, seed, backend, adapter, render_mode)
        self.num_envs = self.native.num_envs
        self.num_agents = self.native.num_agents
        self.render_mode = render_mode
        n = self.num_agents
        self.single_observation_space = _obs_space(n)
        self.single_action_space = _act_space(n)
        self.observation_space = gymnasium.vector.utils.batch_space(
            self.single_observation_space, self.num_envs
        )
        self.action_space = gymnasium.vector.utils.batch_space(
            self.single_action_space, self.num_envs
        )
        #: The joint state of each environment (every member's observation, what a centralised
        #: critic sees): the observation itself, ``[E, N, 8]``.
        self.state_space = self.observation_space
        #: Reward bounds are not finite (the success and failure bonuses are +-10 a member).
        self.reward_space = spaces.Box(-np.inf, np.inf, shape=(self.num_envs, n, 3), dtype=np.float32)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        """Resets every environment; returns ``(obs [E, N, 8], {})``."""
        if seed is not None:
            self.action_space.seed(seed)
        obs = self.native.reset(seed)
        return obs, {}

    def step(self, actions):
        """One control step of every environment with actions ``[E, N, 2]``."""
        actions = np.ascontiguousarray(actions, dtype=np.float32)
        obs, rewards, terminated, truncated, diverged, final_obs, episodes = self.native.step(
            actions
        )
        terminated = terminated | diverged
        infos: dict[str, Any] = {}
        done = terminated | truncated
        if done.any():
            infos["final_obs"] = final_obs
            infos["_final_obs"] = done
            info: dict[str, Any] = {
                key: np.zeros(self.num_envs, dtype=np.float64) for key in _EPISODE_KEYS
            }
            info["outcome"] = np.array([""] * self.num_envs, dtype=object)
            info["diverged"] = diverged
            for e, ep in enumerate(episodes):
                if ep is not None:
                    for key in _EPISODE_KEYS:
                        info[key][e] = ep[key]
                    info["outcome"][e] = ep["outcome"]
            info.update({f"_{k}": done for k in list(info)})
            infos["final_info"] = info
            infos["_final_info"] = done
        return obs, rewards, terminated, truncated, infos

    def fields(self, env: int = 0):
        """u_x, u_y (m/s) and p (Pa) at the cell centres of environment ``env``, ``[ny, nx]``."""
        return self.native.fields(env)

    def render(self):
        """The frame of environment 0 as an RGB array ``[height, width, 3]`` uint8."""
        return self.native.render(0)

    def close_extras(self, **kwargs):
        self.native.close()


def _parallel_base():
    try:
        from momaland.utils.env import MOParallelEnv

        return MOParallelEnv
    except ImportError:
        from pettingzoo import ParallelEnv

        return ParallelEnv


class SwarmParallelEnv(_parallel_base()):
    """One swarm environment as a PettingZoo ``ParallelEnv`` with vector rewards.

    Agents ``member_0`` .. ``member_{N-1}``; each gets an observation of shape (8,), acts with
    shape (2,) and is rewarded with a float32 vector of shape (3,) (progress, energy,
    smoothness). When the episode ends, ``agents`` is empty until ``reset``.
    """

    metadata = {"name": "fluxswarm_v0", "render_modes": ["rgb_array"], "is_parallelizable": True}

    def __init__(
        self,
        config: Optional[str] = None,
        overrides=None,
        seed: int = 0,
        backend: str = "auto",
        adapter: str = "auto",
        render_mode: Optional[str] = None,
    ):
        self.native = _native(1, config, overrides, seed, backend, adapter, render_mode)
        n = self.native.num_agents
        self.possible_agents = [f"member_{i}" for i in range(n)]
        self.agents: list[str] = []
        self.render_mode = render_mode
        self.reward_spaces = {a: self.reward_space(a) for a in self.possible_agents}
        self._obs = np.zeros((n, 8), dtype=np.float32)

    @functools.lru_cache(maxsize=None)
    def observation_space(self, agent):
        return spaces.Box(-np.inf, np.inf, shape=(8,), dtype=np.float32)

    @functools.lru_cache(maxsize=None)
    def action_space(self, agent):
        return spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)

    @functools.lru_cache(maxsize=None)
    def reward_space(self, agent):
        return spaces.Box(-np.inf, np.inf, shape=(3,), dtype=np.float32)

    def _split(self, array):
        return {a: array[i] for i, a in enumerate(self.possible_agents)}

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        obs = self.native.reset(seed)[0]
        self.agents = list(self.possible_agents)
        self._obs = obs
        return self._split(obs), {a: {} for a in self.agents}

    def step(self, actions):
        if not self.agents:
            raise ValueError("the episode has ended: call reset() before step()")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"actions are missing for {missing}")
        joint = np.stack([np.asarray(actions[a], dtype=np.float32) for a in self.possible_agents])
        obs, rewards, terminated, truncated, diverged, final_obs, episodes = self.native.step(
            joint[None]
        )
        done = bool(terminated[0] or truncated[0] or diverged[0])
        last = final_obs[0] if done else obs[0]
        term = bool(terminated[0] or diverged[0])
        info = {"episode": episodes[0]} if done else {}
        out = (
            self._split(last),
            self._split(rewards[0]),
            {a: term for a in self.agents},
            {a: bool(truncated[0]) for a in self.agents},
            {a: dict(info) for a in self.agents},
        )
        self._obs = last
        if done:
            self.agents = []
        return out

    def state(self) -> np.ndarray:
        """The joint state: every member's observation, shape (N, 8)."""
        return self._obs.copy()

    @property
    def state_space(self):
        return spaces.Box(-np.inf, np.inf, shape=(len(self.possible_agents), 8), dtype=np.float32)

    def render(self):
        return self.native.render(0)

    def close(self):
        self.native.close()


def parallel_env(**kwargs) -> SwarmParallelEnv:
    """One swarm environment as a PettingZoo/MOMAland parallel environment (see
    :class:`SwarmParallelEnv` for the arguments)."""
    return SwarmParallelEnv(**kwargs)


class FlattenAgents(VectorEnv):
    """Members flattened into the batch: E x N single-agent environments with observations
    ``[E * N, 8]``, actions ``[E * N, 2]`` and rewards ``[E * N, 3]`` (or scalars after
    :class:`ScalarizeReward`); an environment's members end together."""

    metadata = VectorSwarmEnv.metadata

    def __init__(self, env: VectorSwarmEnv):
        self.env = env
        self.num_envs = env.num_envs * env.num_agents
        self.single_observation_space = spaces.Box(-np.inf, np.inf, shape=(8,), dtype=np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.observation_space = gymnasium.vector.utils.batch_space(
            self.single_observation_space, self.num_envs
        )
        self.action_space = gymnasium.vector.utils.batch_space(
            self.single_action_space, self.num_envs
        )

    def _flat(self, x):
        return x.reshape((self.num_envs,) + x.shape[2:])

    def _per_member(self, flags):
        return np.repeat(flags, self.env.num_agents)

    def reset(self, *, seed=None, options=None):
        obs, info = self.env.reset(seed=seed, options=options)
        return self._flat(obs), info

    def step(self, actions):
        actions = np.asarray(actions, dtype=np.float32).reshape(
            self.env.num_envs, self.env.num_agents, 2
        )
        obs, rewards, terminated, truncated, infos = self.env.step(actions)
        out = {}
        if "final_obs" in infos:
            out["final_obs"] = self._flat(infos["final_obs"])
            out["_final_obs"] = self._per_member(infos["_final_obs"])
            out["final_info"] = {
                k: self._per_member(v) for k, v in infos["final_info"].items()
            }
            out["_final_info"] = self._per_member(infos["_final_info"])
        return (
            self._flat(obs),
            self._flat(rewards),
            self._per_member(terminated),
            self._per_member(truncated),
            out,
        )

    def close_extras(self, **kwargs):
        self.env.close()


class ScalarizeReward(gymnasium.vector.VectorWrapper):
    """Rewards weighted over the objectives (progress, energy, smoothness): the last axis of the
    reward, 3, becomes a scalar ``w . r``."""

    def __init__(self, env: VectorEnv, weights: Sequence[float] = (1.0, 1.0, 1.0)):
        super().__init__(env)
        w = np.asarray(weights, dtype=np.float32)
        if w.shape != (3,):
            raise ValueError(f"weights have shape {w.shape}: give 3 (progress, energy, smoothness)")
        self.weights = w

    def step(self, actions):
        obs, rewards, terminated, truncated, infos = self.env.step(actions)
        return obs, rewards @ self.weights, terminated, truncated, infos
