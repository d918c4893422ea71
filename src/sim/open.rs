//! Which backend runs a batch (`solver.backend`, SPEC section 8), and the start-up self-check
//! that guards the WGSL path on a real GPU:
//! - `native`: the CPU backend; no adapter is opened at all;
//! - `adapter`: the WGSL kernels on the adapter `--adapter` picks (lavapipe included);
//! - `auto` (default): the kernels on a real GPU if one is found and one control step on a
//!   small, awkward grid (61 x 13 cells, two members) agrees with the CPU step within the
//!   kernel tests' tolerance (1e-4 of the largest value of each field); the CPU backend
//!   otherwise, with the reason in [`Opened::why`]. Nothing the GPU path does may crash `auto`:
//!   an error or a panic while opening or checking the adapter falls back to the CPU.

use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::config::{Backend, Layout, Resolved};
use crate::gpu::{AdapterChoice, GpuContext, probe};

use super::{CpuBatch, FlowBatch, GpuBatch, SimError};

/// Largest |gpu - cpu| allowed after the self-check's control step, relative to the largest
/// |cpu| of each field: the whole-step kernel tests' tolerance.
pub const SELF_CHECK_TOLERANCE: f32 = 1e-4;

/// A batch ready to step, with what runs it and why.
pub struct Opened {
    /// The batch, on the backend chosen.
    pub batch: Box<dyn FlowBatch>,
    /// Why this backend runs, for the run header (e.g. "solver.backend = \"native\"").
    pub why: String,
    /// Warnings to show the user (a failed self-check, a loop-capping driver).
    pub warnings: Vec<String>,
}

impl Opened {
    /// The run header's line: what runs the step and why.
    pub fn header(&self) -> String {
        format!("control step: {} ({})", self.batch.describe(), self.why)
    }
}

/// Opens a batch of `n_env` environments on the backend `resolved.config.solver.backend`
/// asks for; `adapter` is the `--adapter` choice for the WGSL path.
pub fn open(resolved: &Resolved, n_env: usize, adapter: AdapterChoice) -> Result<Opened, SimError> {
    match resolved.config.solver.backend {
        Backend::Native => Ok(Opened {
            batch: Box::new(CpuBatch::new(resolved, n_env)?),
            why: "solver.backend = \"native\"".into(),
            warnings: Vec::new(),
        }),
        Backend::Adapter => open_adapter(resolved, n_env, adapter, "solver.backend = \"adapter\""),
        // An explicit software adapter is a request for the kernels there.
        Backend::Auto if adapter == AdapterChoice::Cpu => open_adapter(
            resolved,
            n_env,
            adapter,
            "solver.backend = \"auto\" with --adapter cpu",
        ),
        Backend::Auto => open_auto(resolved, n_env, adapter),
    }
}

fn open_adapter(
    resolved: &Resolved,
    n_env: usize,
    adapter: AdapterChoice,
    why: &str,
) -> Result<Opened, SimError> {
    let ctx = GpuContext::new(adapter)?;
    let warnings = probe::check_loop_cap(&ctx)?.into_iter().collect();
    Ok(Opened {
        batch: Box::new(GpuBatch::new(&ctx, resolved, n_env)?),
        why: why.into(),
        warnings,
    })
}

fn open_auto(
    resolved: &Resolved,
    n_env: usize,
    adapter: AdapterChoice,
) -> Result<Opened, SimError> {
    let found = catch_unwind(|| GpuContext::new(AdapterChoice::Gpu));
    match found {
        Ok(Ok(ctx)) => Ok(open_auto_on(&ctx, resolved, n_env, false)?),
        Ok(Err(e)) if adapter == AdapterChoice::Gpu => Err(e.into()),
        Ok(Err(e)) => {
            let seen = match &e {
                crate::gpu::GpuError::NoAdapter { seen, .. } => format!(" (adapters seen: {seen})"),
                other => format!(" ({other})"),
            };
            cpu_fallback(
                resolved,
                n_env,
                format!("solver.backend = \"auto\": no GPU adapter found{seen}"),
                None,
            )
        }
        Err(_) => cpu_fallback(
            resolved,
            n_env,
            "solver.backend = \"auto\": opening the GPU adapter panicked".into(),
            Some("opening the GPU adapter panicked; running on the CPU backend".into()),
        ),
    }
}

fn cpu_fallback(
    resolved: &Resolved,
    n_env: usize,
    why: String,
    warning: Option<String>,
) -> Result<Opened, SimError> {
    Ok(Opened {
        batch: Box::new(CpuBatch::new(resolved, n_env)?),
        why,
        warnings: warning.into_iter().collect(),
    })
}

/// `auto` on a given adapter: the self-check, then the kernels, or the CPU backend with a
/// warning that names what failed. `fault` perturbs the GPU side of the self-check (for the
/// test that it falls back). A software adapter is used as a GPU here (tests run it on
/// lavapipe); [`open`] passes only real GPUs.
pub fn open_auto_on(
    ctx: &GpuContext,
    resolved: &Resolved,
    n_env: usize,
    fault: bool,
) -> Result<Opened, SimError> {
    let attempt = catch_unwind(AssertUnwindSafe(|| -> Result<GpuBatch, SimError> {
        if let Some(w) = probe::check_loop_cap(ctx)? {
            return Err(SimError::SelfCheck(w));
        }
        self_check(ctx, resolved, fault)?;
        GpuBatch::new(ctx, resolved, n_env)
    }));
    let failure = match attempt {
        Ok(Ok(batch)) => {
            return Ok(Opened {
                batch: Box::new(batch),
                why: "solver.backend = \"auto\": a GPU that passed the start-up self-check".into(),
                warnings: Vec::new(),
            });
        }
        Ok(Err(e)) => e.to_string(),
        Err(_) => "the WGSL path panicked".to_string(),
    };
    let warning = format!(
        "the WGSL kernels on {} failed at start-up ({failure}); running on the CPU backend instead. \
         `--set solver.backend=adapter` forces the kernels; please report this with `fluxswarm-gpu info`",
        ctx.describe()
    );
    cpu_fallback(
        resolved,
        n_env,
        "solver.backend = \"auto\": the GPU failed the start-up self-check".into(),
        Some(warning),
    )
}

/// The self-check's configuration: the run's physics and schemes on a 61 x 13 grid of the
/// run's cell size, with two members of the run's radius (none if they would not fit).
pub fn self_check_config(resolved: &Resolved) -> Resolved {
    let mut r = resolved.clone();
    let c = &mut r.config;
    let (dx, dy) = (c.dx(), c.domain.height_m / c.domain.ny as f64);
    let (nx, ny) = (61u32, 13u32);
    c.domain.nx = nx;
    c.domain.ny = ny;
    c.domain.length_m = nx as f64 * dx;
    c.domain.height_m = ny as f64 * dy;
    c.domain.success_x_m = 0.2 * c.domain.length_m;
    c.domain.failure_x_m = 0.8 * c.domain.length_m;
    let fits = c.swarm.radius_m < 4.0 * dy && c.swarm.radius_m < 10.0 * dx;
    c.swarm.count = if fits { 2 } else { 0 };
    c.swarm.layout = Layout::Explicit;
    c.swarm.positions_m = if fits {
        vec![[20.3 * dx, 5.0 * dy], [33.7 * dx, 8.2 * dy]]
    } else {
        Vec::new()
    };
    c.swarm.pinned.clear();
    r
}

/// One control step of the kernels against the CPU step from the same state, with thrust.
pub fn self_check(ctx: &GpuContext, resolved: &Resolved, fault: bool) -> Result<(), SimError> {
    let r = self_check_config(resolved);
    let mut gpu = GpuBatch::new(ctx, &r, 2)?;
    let mut cpu = CpuBatch::new(&r, 2)?;
    let n = r.config.swarm.count as usize;
    let actions: Vec<[f32; 2]> = (0..2 * n)
        .map(|k| [-0.8 + 0.5 * k as f32, 0.6 - 0.4 * k as f32])
        .collect();
    for b in [&mut gpu as &mut dyn FlowBatch, &mut cpu] {
        b.reset_env_with_phase(1, 0.02)?; // mid-systole in the paper's waveform
        b.set_all_actions(&actions)?;
    }
    if fault {
        let mut s = gpu.state()?;
        s.u.iter_mut().for_each(|u| *u *= 1.01);
        let forces = gpu.member_forces().to_vec();
        gpu.set_state(&s, &forces)?;
    }
    gpu.step()?;
    cpu.step()?;
    let (g, c) = (gpu.state()?, cpu.state()?);
    let members = |s: &super::BatchState| -> Vec<f32> {
        s.members
            .iter()
            .flat_map(|m| [m.pos[0], m.pos[1], m.vel[0], m.vel[1]])
            .collect()
    };
    for (name, a, b) in [
        ("u", g.u.clone(), c.u.clone()),
        ("v", g.v.clone(), c.v.clone()),
        ("p", g.p.clone(), c.p.clone()),
        ("members", members(&g), members(&c)),
    ] {
        let scale = b.iter().fold(0.0f32, |m, x| m.max(x.abs())).max(1e-30);
        let diff = a.iter().zip(&b).fold(0.0f32, |m, (x, y)| {
            if (x - y).is_nan() {
                f32::INFINITY
            } else {
                m.max((x - y).abs())
            }
        });
        if diff > SELF_CHECK_TOLERANCE * scale {
            return Err(SimError::SelfCheck(format!(
                "after one control step {name} differs from the CPU step by {:.2e} of its largest value (tolerance {SELF_CHECK_TOLERANCE:e})",
                diff / scale
            )));
        }
    }
    Ok(())
}
