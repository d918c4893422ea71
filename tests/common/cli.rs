//! Running the binary as a user does, and the small configurations the CLI tests share.

use std::process::{Command, Output};

pub fn bin(args: &[&str]) -> Output {
    bin_env(args, &[])
}

/// [`bin`] with extra environment variables (e.g. no Vulkan driver at all).
pub fn bin_env(args: &[&str], vars: &[(&str, &str)]) -> Output {
    let _lock = super::gpu().0; // one GPU user at a time
    Command::new(env!("CARGO_BIN_EXE_fluxswarm-gpu"))
        .args(args)
        .env("NODEVICE_SELECT", "1")
        .env("RUST_LOG", "info")
        .envs(vars.iter().copied())
        .output()
        .expect("running fluxswarm-gpu")
}

/// No Vulkan driver (the ICD list points at nothing) and no GL: wgpu finds no adapter at all.
pub const NO_ADAPTER: &[(&str, &str)] = &[
    ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
    ("WGPU_BACKEND", "vulkan"),
];

pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A 30 mm channel (success line 6 mm, failure line 24 mm) with 2 members, 3-step episodes.
pub const SMALL_SWARM: &[&str] = &[
    "--set",
    "domain.nx=300",
    "--set",
    "domain.length_m=0.03",
    "--set",
    "domain.success_x_m=0.006",
    "--set",
    "domain.failure_x_m=0.024",
    "--set",
    "swarm.count=2",
    "--set",
    "swarm.grid_rows=1",
    "--set",
    "swarm.grid_centre_x_m=0.015",
    "--set",
    "env.max_steps=3",
];

/// A 10 mm channel at the paper's resolution.
pub const SMALL: &[&str] = &[
    "--set",
    "domain.nx=100",
    "--set",
    "domain.length_m=0.01",
    "--set",
    "domain.success_x_m=0.002",
    "--set",
    "domain.failure_x_m=0.008",
    "--set",
    "swarm.count=0",
];
