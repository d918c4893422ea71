//! Shared test helpers: one GPU device per test, preferring the software adapter (what CI has),
//! GPU tests serialised within a test binary, small configurations and deterministic noise.
#![allow(dead_code)]

pub mod cli;

use std::sync::{Mutex, MutexGuard};

use fluxswarm_gpu::config::{Config, Resolved};
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};

static GPU_LOCK: Mutex<()> = Mutex::new(());

/// A fresh device, held exclusively: the CPU adapter (any adapter if there is no CPU one: Mesa's
/// lavapipe, or SwiftShader, which also reports `Cpu`, where `VK_ICD_FILENAMES` names it), or
/// a real GPU only when `FLUXSWARM_TEST_ADAPTER=gpu` (`scripts/device-check` sets it, so that the
/// kernels are checked against their twins on the GPU's own driver).
pub fn gpu() -> (MutexGuard<'static, ()>, GpuContext) {
    let guard = GPU_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let ctx = match std::env::var("FLUXSWARM_TEST_ADAPTER").as_deref() {
        Ok("gpu") => GpuContext::new(AdapterChoice::Gpu),
        Ok("cpu") => GpuContext::new(AdapterChoice::Cpu),
        Ok(other) if !other.is_empty() => {
            panic!("FLUXSWARM_TEST_ADAPTER={other}: use gpu, cpu, or leave it unset")
        }
        _ => GpuContext::new(AdapterChoice::Cpu).or_else(|_| GpuContext::new(AdapterChoice::Auto)),
    }
    .unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
    // Once per test binary, past the harness's capture (it takes only print!/eprint!): which
    // driver the GPU tests ran on (lavapipe, SwiftShader with VK_ICD_FILENAMES, GL llvmpipe).
    static SAID: std::sync::Once = std::sync::Once::new();
    SAID.call_once(|| {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "GPU tests on: {}", ctx.describe());
    });
    (guard, ctx)
}

/// A channel of nx x ny cells of 0.1 mm (the paper's spacing), no swarm, with extra `--set`
/// overrides (later ones win, so a test can set `swarm.count` again).
pub fn small_config(nx: u32, ny: u32, extra: &[&str]) -> Resolved {
    let length = nx as f64 * 1e-4;
    let mut sets = vec![
        format!("domain.nx={nx}"),
        format!("domain.ny={ny}"),
        format!("domain.length_m={length}"),
        format!("domain.height_m={}", ny as f64 * 1e-4),
        format!("domain.success_x_m={}", 0.2 * length),
        format!("domain.failure_x_m={}", 0.8 * length),
        "swarm.count=0".to_string(),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    Config::load(None, &sets).unwrap_or_else(|e| panic!("test config: {e}"))
}

/// Deterministic pseudo-random numbers in [-1, 1), from the project's generator started at the
/// raw state `seed`.
pub struct Noise(fluxswarm_gpu::rng::Rng);

impl Noise {
    pub fn new(seed: u64) -> Self {
        Self(fluxswarm_gpu::rng::Rng(seed))
    }

    pub fn next(&mut self) -> f32 {
        (self.0.next_u64() >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }

    pub fn vec(&mut self, n: usize, scale: f32) -> Vec<f32> {
        (0..n).map(|_| scale * self.next()).collect()
    }
}

/// A random body field of `cells` cells: a quarter fully solid, a tenth partly solid, the rest
/// fluid, each with a small random body velocity ([chi, u_body, v_body, 0]).
pub fn random_body(n: &mut Noise, cells: usize) -> Vec<[f32; 4]> {
    (0..cells)
        .map(|_| {
            let r = n.next();
            let chi = if r > 0.5 {
                1.0
            } else if r > 0.3 {
                0.5 * (r + 1.0)
            } else {
                0.0
            };
            [chi, 0.05 * n.next(), 0.05 * n.next(), 0.0]
        })
        .collect()
}

/// Largest |a - b| and largest |b|.
pub fn max_diff(a: &[f32], b: &[f32]) -> (f32, f32) {
    assert_eq!(a.len(), b.len());
    let d = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    let m = b.iter().map(|y| y.abs()).fold(0.0, f32::max);
    (d, m)
}

/// `small_config` with members at explicit positions (mm) and extra overrides.
pub fn swarm_config(nx: u32, ny: u32, pos_mm: &[[f64; 2]], extra: &[&str]) -> Resolved {
    let list: Vec<String> = pos_mm
        .iter()
        .map(|p| format!("[{}, {}]", p[0] * 1e-3, p[1] * 1e-3))
        .collect();
    let mut sets = vec![
        format!("swarm.count={}", pos_mm.len()),
        "swarm.layout=explicit".to_string(),
        format!("swarm.positions_m=[{}]", list.join(", ")),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let refs: Vec<&str> = sets.iter().map(String::as_str).collect();
    small_config(nx, ny, &refs)
}

/// Swarm environments on the WGSL kernels of `ctx` (what the GPU tests exercise).
pub fn gpu_env(
    ctx: &GpuContext,
    r: &Resolved,
    n_env: usize,
    seed: u64,
) -> fluxswarm_gpu::env::SwarmEnv {
    let batch = fluxswarm_gpu::sim::GpuBatch::new(ctx, r, n_env).unwrap();
    fluxswarm_gpu::env::SwarmEnv::new(Box::new(batch), r, seed).unwrap()
}
