//! Arguments and start-up steps shared by the subcommands.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fluxswarm_gpu::config::{Backend, Config, Resolved};
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext, probe};

#[derive(Debug, Args, Clone)]
pub struct ConfigArgs {
    /// TOML file merged over the embedded paper configuration (configs/paper.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override one key, e.g. `--set domain.nx=500` (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub sets: Vec<String>,
    /// Adapter: a real GPU if present (auto), a GPU only, or the software adapter (cpu).
    #[arg(long, value_enum, default_value_t = AdapterChoice::Auto)]
    pub adapter: AdapterChoice,
}

/// Writes `out/animation.gif` from the frames in `out/frames` whose names start with `prefix`.
pub fn write_gif(out: &std::path::Path, prefix: &str) -> anyhow::Result<()> {
    use fluxswarm_gpu::output::gif;
    let frames = gif::frames_in(&out.join("frames"), prefix);
    let path = out.join("animation.gif");
    gif::write(&frames, &path, gif::README_WIDTH, 80)?;
    log::info!("{} frames -> {}", frames.len(), path.display());
    Ok(())
}

/// What runs the control step, for run headers: the adapter, or the native backend (with
/// the adapter that only holds its buffers).
pub fn runs_on(ctx: &GpuContext, resolved: &Resolved) -> String {
    match resolved.config.solver.backend {
        Backend::Adapter => ctx.describe(),
        Backend::Native => format!(
            "native CPU backend, {} threads (buffers on {})",
            rayon::current_num_threads(),
            ctx.describe()
        ),
    }
}

/// On a software adapter with the adapter backend, says that the native backend is faster.
pub fn suggest_native(ctx: &GpuContext, resolved: &Resolved) {
    if ctx.is_software() && resolved.config.solver.backend == Backend::Adapter {
        log::info!(
            "no GPU: `--set solver.backend=native` runs the same control step about 4x faster on these CPU cores (README, Performance)"
        );
    }
}

impl ConfigArgs {
    /// Loads and validates the configuration (before any GPU work).
    pub fn load(&self) -> anyhow::Result<Resolved> {
        Ok(Config::load(self.config.as_deref(), &self.sets)?)
    }

    /// Opens the adapter, prints which one runs, and warns about a loop-capping driver.
    pub fn open_gpu(&self) -> anyhow::Result<GpuContext> {
        let ctx = GpuContext::new(self.adapter)?;
        log::info!("{}", ctx.banner());
        if let Some(warning) = probe::check_loop_cap(&ctx).context("driver self-check")? {
            log::warn!("{warning}");
        }
        Ok(ctx)
    }
}
