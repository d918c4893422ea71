//! `fluxswarm-gpu report`: figures and `report.md` from train runs (RUN_DIR…, one per seed),
//! a compared experiment (`--compare`), baselines (`--baseline`) and a before/after pair of
//! rollout or eval directories (see `fluxswarm_gpu::report`). Needs no adapter.

use std::path::PathBuf;

use clap::Args;
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::report::{self, Inputs};

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Train run directories of one experiment (several: one per seed).
    #[arg(required = true, value_name = "RUN_DIR")]
    pub runs: Vec<PathBuf>,
    /// Train run directories of an experiment to overlay (e.g. the --no-pcgrad ablation; one
    /// per seed).
    #[arg(long, value_name = "RUN_DIR", num_args = 1..)]
    pub compare: Vec<PathBuf>,
    /// Rollout directories of baseline policies, each drawn as a horizontal band.
    #[arg(long, value_name = "DIR", num_args = 1..)]
    pub baseline: Vec<PathBuf>,
    /// Rollout/eval directory before learning (with --after).
    #[arg(long, value_name = "DIR")]
    pub before: Option<PathBuf>,
    /// Rollout/eval directory after learning (with --before).
    #[arg(long, value_name = "DIR")]
    pub after: Option<PathBuf>,
    /// Output directory (default runs/report-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: ReportArgs) -> anyhow::Result<()> {
    let inputs = Inputs {
        runs: args.runs,
        compare: args.compare,
        baselines: args.baseline,
        before: args.before,
        after: args.after,
    };
    let loaded = report::load(&inputs)?;
    let out = args.out.unwrap_or_else(|| run_dir::default_dir("report"));
    let out = run_dir::prepare(&out, &[])?;
    let figures = report::write(&loaded, &out)?;
    log::info!("{} figures and report.md", figures.len());
    println!("{}", out.display());
    Ok(())
}
