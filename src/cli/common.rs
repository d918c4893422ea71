//! Arguments and start-up steps shared by the subcommands.

use std::path::PathBuf;

use clap::Args;
use fluxswarm_gpu::config::{Config, Resolved};
use fluxswarm_gpu::gpu::AdapterChoice;
use fluxswarm_gpu::sim::{Opened, open};

#[derive(Debug, Args, Clone)]
pub struct ConfigArgs {
    /// TOML file merged over the embedded paper configuration (configs/paper.toml).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Override one key, e.g. `--set domain.nx=500` (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub sets: Vec<String>,
    /// Adapter for the WGSL kernels: a real GPU if present (auto), a GPU only, or the software
    /// adapter (cpu; with `solver.backend = "auto"` this runs the kernels on it).
    #[arg(long, value_enum, default_value_t = AdapterChoice::Auto)]
    pub adapter: AdapterChoice,
}

/// Writes `out/animation.gif` from the frames in `out/frames` whose names start with `prefix`
/// and lie in `window`.
pub fn write_gif(
    out: &std::path::Path,
    prefix: &str,
    window: fluxswarm_gpu::output::gif::Window,
) -> anyhow::Result<()> {
    use fluxswarm_gpu::output::gif;
    let mut frames = gif::frames_in(&out.join("frames"), prefix);
    let all = frames.len();
    frames.retain(|f| window.holds(f));
    if all > 0 && frames.is_empty() {
        anyhow::bail!(
            "no frame of {} lies in --gif-episode / --gif-steps ({window:?}): the frames are \
             env0_ep<episode>_s<step>.png; widen the window or write frames more often",
            out.join("frames").display()
        );
    }
    let path = out.join("animation.gif");
    gif::write(&frames, &path, gif::README_WIDTH, 80)?;
    log::info!("{} frames -> {}", frames.len(), path.display());
    Ok(())
}

/// What runs the control step and why, for the `config.toml` header (`report` reads the
/// text after "adapter").
pub fn runs_on(opened: &Opened) -> String {
    format!("{}; {}", opened.batch.describe(), opened.why)
}

pub use fluxswarm_gpu::config::{RUN_KEYS, TRANSFER_KEYS};

/// Applies `--set` overrides to a trained policy's saved configuration: [`TRANSFER_KEYS`]
/// change the scenario around the policy (a transfer test, written into `config.toml`),
/// [`RUN_KEYS`] how the step runs; any other key is an error that says why.
pub fn apply_policy_sets(resolved: &mut Resolved, sets: &[String]) -> anyhow::Result<()> {
    let is_transfer = |s: &String| {
        let key = s.split_once('=').map_or(s.as_str(), |(k, _)| k).trim();
        TRANSFER_KEYS.contains(&key)
    };
    let (transfer, run): (Vec<String>, Vec<String>) = sets.iter().cloned().partition(is_transfer);
    if !transfer.is_empty() {
        *resolved = resolved.config.with_sets(&transfer)?;
    }
    apply_run_sets(resolved, &run, "a trained policy", &TRANSFER_KEYS)
}

/// Applies `--set` overrides of [`RUN_KEYS`] to a saved configuration (a resumed run, a
/// trained policy); any other key is an error that says why, naming the keys `also` that the
/// caller accepts besides (already applied).
pub fn apply_run_sets(
    resolved: &mut Resolved,
    sets: &[String],
    what: &str,
    also: &[&str],
) -> anyhow::Result<()> {
    for set in sets {
        let (key, value) = set.split_once('=').unwrap_or((set.as_str(), ""));
        let value = value.trim().trim_matches('"');
        match key.trim() {
            "solver.backend" => {
                resolved.config.solver.backend = match value {
                    "auto" => fluxswarm_gpu::config::Backend::Auto,
                    "adapter" => fluxswarm_gpu::config::Backend::Adapter,
                    "native" => fluxswarm_gpu::config::Backend::Native,
                    other => {
                        anyhow::bail!("--set solver.backend={other}: use auto, adapter or native")
                    }
                }
            }
            "solver.pressure_sweep" => {
                resolved.config.solver.pressure_sweep = match value {
                    "auto" => fluxswarm_gpu::config::PressureSweep::Auto,
                    "sequential" => fluxswarm_gpu::config::PressureSweep::Sequential,
                    "scan" => fluxswarm_gpu::config::PressureSweep::Scan,
                    other => anyhow::bail!(
                        "--set solver.pressure_sweep={other}: use auto, sequential or scan"
                    ),
                }
            }
            other => anyhow::bail!(
                "{what} runs in the configuration saved with it, which `--set {other}=...` would change: drop --config/--set for it (only {} may be set: they change how the step runs, not what it computes{})",
                RUN_KEYS.join(" and "),
                if also.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; and, to test how a policy transfers, the scenario keys {}",
                        also.join(", ")
                    )
                }
            ),
        }
    }
    Ok(())
}

impl ConfigArgs {
    /// Loads and validates the configuration (before any GPU work).
    pub fn load(&self) -> anyhow::Result<Resolved> {
        Ok(Config::load(self.config.as_deref(), &self.sets)?)
    }

    /// Opens a batch of `n_env` environments on the backend `solver.backend` picks, and says
    /// which runs and why (and any warning, e.g. a failed GPU self-check).
    pub fn open_batch(&self, resolved: &Resolved, n_env: usize) -> anyhow::Result<Opened> {
        let opened = open(resolved, n_env, self.adapter)?;
        log::info!("{}", opened.header());
        for w in &opened.warnings {
            log::warn!("{w}");
        }
        Ok(opened)
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message
/// already holds (typed errors that name their source, like `CheckpointError::Read`).
pub fn error_chain(e: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if message.contains(&text) {
            continue;
        }
        if !message.is_empty() {
            message.push_str(": ");
        }
        message.push_str(&text);
    }
    message
}

#[cfg(test)]
mod tests {
    use super::error_chain;

    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let io = || std::io::Error::new(std::io::ErrorKind::NotFound, "no policy.safetensors");
        // Its message names its source, which is also its `source()`.
        let typed = anyhow::Error::new(fluxswarm_gpu::checkpoint::CheckpointError::Read {
            path: "runs/x".into(),
            source: io(),
        });
        assert_eq!(typed.chain().count(), 2);
        assert_eq!(
            error_chain(&typed),
            "cannot read checkpoint runs/x: no policy.safetensors"
        );
        let wrapped = anyhow::Error::new(io()).context("loading the policy");
        assert_eq!(
            error_chain(&wrapped),
            "loading the policy: no policy.safetensors"
        );
    }
}
