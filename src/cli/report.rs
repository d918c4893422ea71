//! `fluxswarm-gpu report`: figures and `report.md` from train runs (RUN_DIR…, one per seed),
//! a compared experiment (`--compare`), baselines (`--baseline`) and a before/after pair of
//! rollout or eval directories (see `fluxswarm_gpu::report`), a sweep (`--sweep DIR`,
//! `report::sweep`), the frontier protocol's sweep (`--frontier DIR`, `report::frontier`) or
//! the emergent behaviours in rollouts (`--behaviour DIR...`, `report::behaviour`).
//! Needs no adapter.

use std::path::PathBuf;

use clap::Args;
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::report::{self, Inputs};

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Train run directories of one experiment (several: one per seed).
    #[arg(required_unless_present_any = ["sweep", "frontier", "behaviour"], value_name = "RUN_DIR")]
    pub runs: Vec<PathBuf>,
    /// A sweep directory (`fluxswarm-gpu sweep`): one table of every point's final metrics
    /// over seeds, sweep_points.csv, and a line or heatmap figure for one or two grid keys.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["runs", "compare", "baseline", "before", "after"])]
    pub sweep: Option<PathBuf>,
    /// The sweep directory of `experiments/frontier_learners.sh` (issue 19's protocol): every
    /// variant's pooled success rate and metrics per evaluation with bootstrap intervals over
    /// seeds, the comparators, and the goal (frontier.md, frontier.csv).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["runs", "sweep", "compare", "baseline", "before", "after"])]
    pub frontier: Option<PathBuf>,
    /// Rollout or eval directories written with traces (and `--gap` for the flow past the
    /// swarm): the paper's three emergent behaviours (ratchet, throttling, final approach) as
    /// behaviour.md and behaviour.csv, a row per directory; the figures show the first one's
    /// longest episode.
    #[arg(long, value_name = "DIR", num_args = 1.., conflicts_with_all = ["runs", "sweep", "frontier", "compare", "baseline", "before", "after"])]
    pub behaviour: Vec<PathBuf>,
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
    if !args.behaviour.is_empty() {
        let out = args.out.unwrap_or_else(|| run_dir::default_dir("report"));
        let out = run_dir::prepare(&out, &[])?;
        let figures = report::behaviour_output::write(&args.behaviour, &out)?;
        log::info!("{} figures, behaviour.md and behaviour.csv", figures.len());
        println!("{}", out.display());
        return Ok(());
    }
    if let Some(dir) = &args.frontier {
        let out = args.out.unwrap_or_else(|| run_dir::default_dir("report"));
        let out = run_dir::prepare(&out, &[])?;
        report::frontier_output::write(dir, &out)?;
        log::info!("frontier.md and frontier.csv");
        println!("{}", out.display());
        return Ok(());
    }
    if let Some(dir) = &args.sweep {
        let out = args.out.unwrap_or_else(|| run_dir::default_dir("report"));
        let out = run_dir::prepare(&out, &[])?;
        let figures = report::sweep::write(dir, &out)?;
        log::info!("{} figures, sweep_points.csv and report.md", figures.len());
        println!("{}", out.display());
        return Ok(());
    }
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
