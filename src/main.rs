//! `fluxswarm-gpu`: command-line entry point. Each subcommand lives in `cli/<name>.rs` and is a
//! `run(args) -> anyhow::Result<()>`.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    fluxswarm_gpu::tuning::keep_freed_blocks();
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or("info,wgpu_core=warn,wgpu_hal=warn,naga=warn"),
    )
    .format_timestamp(None)
    .format_target(false)
    .init();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if let Some(stopped) = e.downcast_ref::<cli::Stopped>() {
                return ExitCode::from(stopped.report() as u8);
            }
            eprintln!("error: {}", cli::error_chain(&e));
            ExitCode::FAILURE
        }
    }
}
