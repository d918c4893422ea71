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
            eprintln!("error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message
/// already holds (typed errors that name their source, like `CheckpointError::Read`).
fn error_chain(e: &anyhow::Error) -> String {
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
