//! `fluxswarm._native`: the batched swarm environment of fluxswarm-gpu for Python. One
//! [`NativeEnv`] holds E environments of N members on one flow batch (the same
//! `fluxswarm_gpu::env::SwarmEnv` that `rollout` and `train` step) and exchanges numpy arrays:
//! observations `[E, N, 8]` float32, actions `[E, N, 2]` float32, rewards `[E, N, 3]` float32
//! (progress, energy, smoothness), flags `[E]` bool. The GIL is released while the flow steps.
//! The Gymnasium, PettingZoo and MOMAland interfaces are written in Python over it
//! (`fluxswarm/__init__.py`); errors arrive as `ValueError` (bad input) or `RuntimeError`
//! (the simulation failed), with the library's messages.

use std::sync::Mutex;

use fluxswarm_gpu::config::{Config, Resolved};
use fluxswarm_gpu::env::{OBS_DIM, SwarmEnv};
use fluxswarm_gpu::gpu::AdapterChoice;
use fluxswarm_gpu::gpu::params::GpuMemberDiag;
use fluxswarm_gpu::rollout::files::render_frame;
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn runtime_error(e: impl std::fmt::Display) -> PyErr {
    PyRuntimeError::new_err(e.to_string())
}

/// E swarm environments on one flow batch, stepped together.
#[pyclass(module = "fluxswarm._native")]
struct NativeEnv {
    /// `None` once closed.
    env: Mutex<Option<SwarmEnv>>,
    resolved: Resolved,
    n_env: usize,
    n_agents: usize,
    backend: String,
    /// Seconds the last `step` spent in the library's step (GIL released).
    last_step_s: Mutex<f64>,
}

impl NativeEnv {
    fn with_env<T>(&self, f: impl FnOnce(&mut SwarmEnv) -> PyResult<T>) -> PyResult<T> {
        let mut guard = self.env.lock().map_err(runtime_error)?;
        let env = guard
            .as_mut()
            .ok_or_else(|| value_error("the environment is closed: make a new one"))?;
        f(env)
    }
}

#[pymethods]
impl NativeEnv {
    /// `num_envs` environments of the configuration `config` (a TOML file merged over the
    /// paper's setup; `None`: the paper's setup) with `overrides` (`"section.key=value"`, as
    /// the CLI's `--set`), seeded with `seed`. `adapter`: "auto", "gpu" or "cpu" (the CLI's
    /// `--adapter`; `solver.backend` picks the backend as in the CLI).
    #[new]
    #[pyo3(signature = (num_envs, config=None, overrides=Vec::new(), seed=0, adapter="auto"))]
    fn new(
        num_envs: usize,
        config: Option<std::path::PathBuf>,
        overrides: Vec<String>,
        seed: u64,
        adapter: &str,
    ) -> PyResult<Self> {
        if num_envs == 0 {
            return Err(value_error("num_envs must be at least 1"));
        }
        let adapter = match adapter {
            "auto" => AdapterChoice::Auto,
            "gpu" => AdapterChoice::Gpu,
            "cpu" => AdapterChoice::Cpu,
            other => {
                return Err(value_error(format!(
                    "adapter {other:?}: give \"auto\", \"gpu\" or \"cpu\""
                )));
            }
        };
        let resolved = Config::load(config.as_deref(), &overrides).map_err(value_error)?;
        if resolved.config.swarm.count == 0 {
            return Err(value_error(
                "the environment needs a swarm: swarm.count is 0",
            ));
        }
        let opened =
            fluxswarm_gpu::sim::open(&resolved, num_envs, adapter).map_err(runtime_error)?;
        let backend = opened.header();
        let env = SwarmEnv::new(opened.batch, &resolved, seed).map_err(runtime_error)?;
        let n_agents = env.n_agents();
        Ok(Self {
            env: Mutex::new(Some(env)),
            resolved,
            n_env: num_envs,
            n_agents,
            backend,
            last_step_s: Mutex::new(0.0),
        })
    }

    /// Environments in the batch (E).
    #[getter]
    fn num_envs(&self) -> usize {
        self.n_env
    }

    /// Members (agents) per environment (N).
    #[getter]
    fn num_agents(&self) -> usize {
        self.n_agents
    }

    /// Observation entries per member (8).
    #[getter]
    fn obs_dim(&self) -> usize {
        OBS_DIM
    }

    /// Control step in seconds.
    #[getter]
    fn control_dt_s(&self) -> f64 {
        self.resolved.config.time.control_dt_s
    }

    /// Control steps after which an episode is truncated.
    #[getter]
    fn max_steps(&self) -> u32 {
        self.resolved.config.env.max_steps
    }

    /// What runs the flow and why (the CLI's run header).
    #[getter]
    fn backend(&self) -> String {
        self.backend.clone()
    }

    /// Seconds the last `step` spent in the library's control step itself (the rest of a
    /// `step` call is the binding's own cost: checks, copies, the GIL).
    #[getter]
    fn last_step_s(&self) -> PyResult<f64> {
        Ok(*self.last_step_s.lock().map_err(runtime_error)?)
    }

    /// The whole configuration as TOML (what `rollout` saves as config.toml).
    fn config_toml(&self) -> String {
        self.resolved.config.to_toml()
    }

    /// Resets every environment (reseeded with `seed` when given); observations `[E, N, 8]`.
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<u64>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let obs = self.with_env(|env| {
            if let Some(s) = seed {
                env.reseed(s);
            }
            py.detach(|| env.reset()).map_err(runtime_error)
        })?;
        PyArray1::from_vec(py, obs).reshape([self.n_env, self.n_agents, OBS_DIM])
    }

    /// One control step of every environment with actions `[E, N, 2]` (float32; the norm of
    /// each action is clipped at 1). Returns `(obs, rewards, terminated, truncated, diverged,
    /// final_obs, episodes)`: obs `[E, N, 8]` (a finished environment's new episode already),
    /// rewards `[E, N, 3]`, three flags `[E]`, `final_obs` `[E, N, 8]` (the last observation
    /// where an episode ended, zeros elsewhere) and, per environment, `None` or a dict of the
    /// finished episode's metrics.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &self,
        py: Python<'py>,
        actions: PyReadonlyArray3<'py, f32>,
    ) -> PyResult<(
        Bound<'py, PyArray3<f32>>,
        Bound<'py, PyArray3<f32>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray3<f32>>,
        Vec<Option<Bound<'py, PyDict>>>,
    )> {
        let (e, n) = (self.n_env, self.n_agents);
        if actions.shape() != [e, n, 2] {
            return Err(value_error(format!(
                "actions have shape {:?}; this environment takes [{e}, {n}, 2] (environments, members, x and y)",
                actions.shape()
            )));
        }
        let flat = actions.as_slice().map_err(|_| {
            value_error("actions must be a C-contiguous array: pass np.ascontiguousarray(actions)")
        })?;
        let acts: Vec<[f32; 2]> = flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        if acts.iter().any(|a| !a[0].is_finite() || !a[1].is_finite()) {
            return Err(value_error("actions hold NaN or infinity"));
        }
        let (out, took) = self.with_env(|env| {
            py.detach(|| {
                let start = std::time::Instant::now();
                env.step(&acts).map(|o| (o, start.elapsed().as_secs_f64()))
            })
            .map_err(runtime_error)
        })?;
        *self.last_step_s.lock().map_err(runtime_error)? = took;
        let t = out.transition;
        let mut final_obs = vec![0.0f32; e * n * OBS_DIM];
        for (k, f) in t.final_obs.iter().enumerate() {
            if let Some(f) = f {
                final_obs[k * n * OBS_DIM..(k + 1) * n * OBS_DIM].copy_from_slice(f);
            }
        }
        let episodes = t
            .episodes
            .iter()
            .map(|s| {
                s.as_ref()
                    .map(|s| -> PyResult<Bound<'py, PyDict>> {
                        let d = PyDict::new(py);
                        d.set_item("episode", s.episode)?;
                        d.set_item("steps", s.steps)?;
                        d.set_item("outcome", s.outcome.to_string())?;
                        d.set_item("progress", s.progress)?;
                        d.set_item("energy", s.energy)?;
                        d.set_item("smoothness", s.smoothness)?;
                        d.set_item("scalar_return", s.scalar_return)?;
                        d.set_item("final_x_com_mm", s.final_x_com_mm)?;
                        Ok(d)
                    })
                    .transpose()
            })
            .collect::<PyResult<Vec<_>>>()?;
        Ok((
            PyArray1::from_vec(py, t.obs).reshape([e, n, OBS_DIM])?,
            PyArray1::from_vec(py, t.rewards).reshape([e, n, 3])?,
            PyArray1::from_vec(py, t.terminated),
            PyArray1::from_vec(py, t.truncated),
            PyArray1::from_vec(py, t.diverged),
            PyArray1::from_vec(py, final_obs).reshape([e, n, OBS_DIM])?,
            episodes,
        ))
    }

    /// The inlet phase of each environment, seconds into the waveform period `[E]`.
    fn phase_s<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let v = self.with_env(|env| {
            Ok((0..self.n_env)
                .map(|k| env.batch().waveform_time_s(k))
                .collect::<Vec<f64>>())
        })?;
        Ok(PyArray1::from_vec(py, v))
    }

    /// u_x, u_y (m/s) and p (Pa) at the cell centres of environment `env`, each `[ny, nx]`.
    #[pyo3(signature = (env=0))]
    #[allow(clippy::type_complexity)]
    fn fields<'py>(
        &self,
        py: Python<'py>,
        env: usize,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray2<f32>>,
    )> {
        self.check_env(env)?;
        let f = self.with_env(|s| s.batch().fields(env).map_err(runtime_error))?;
        let shape = [f.ny, f.nx];
        Ok((
            PyArray1::from_vec(py, f.ux_cells()).reshape(shape)?,
            PyArray1::from_vec(py, f.uy_cells()).reshape(shape)?,
            PyArray1::from_vec(py, f.p).reshape(shape)?,
        ))
    }

    /// The frame of environment `env` (the u_x field, the members and their last thrust) as
    /// an RGB array `[height, width, 3]` uint8, as `rollout --frames-every` draws it.
    #[pyo3(signature = (env=0))]
    fn render<'py>(&self, py: Python<'py>, env: usize) -> PyResult<Bound<'py, PyArray3<u8>>> {
        self.check_env(env)?;
        let n = self.n_agents;
        let image = self.with_env(|s| {
            let members = s.batch().members()[env * n..(env + 1) * n].to_vec();
            let forces: Vec<GpuMemberDiag> = s
                .batch()
                .member_forces()
                .get(env * n..(env + 1) * n)
                .map_or_else(|| vec![GpuMemberDiag::default(); n], <[_]>::to_vec);
            render_frame(s, env, s.episode_step(env), &members, &forces).map_err(runtime_error)
        })?;
        let (w, h) = (image.width() as usize, image.height() as usize);
        PyArray1::from_vec(py, image.into_raw()).reshape([h, w, 3])
    }

    /// Releases the flow batch; any later call raises ValueError.
    fn close(&self) -> PyResult<()> {
        self.env.lock().map_err(runtime_error)?.take();
        Ok(())
    }

    /// Whether [`Self::close`] was called.
    #[getter]
    fn closed(&self) -> PyResult<bool> {
        Ok(self.env.lock().map_err(runtime_error)?.is_none())
    }
}

impl NativeEnv {
    fn check_env(&self, env: usize) -> PyResult<()> {
        if env >= self.n_env {
            return Err(value_error(format!(
                "environment {env} is outside the batch of {}",
                self.n_env
            )));
        }
        Ok(())
    }
}

/// The compiled core of the `fluxswarm` package.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeEnv>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
