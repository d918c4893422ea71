//! Running the binary as a user does, and the small configurations the CLI tests share.

use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

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

/// Restores SIGHUP's default action in the child `cmd` starts. A test run under `nohup` (or
/// anything else that ignores SIGHUP) would otherwise hand the child an ignored SIGHUP, which
/// the binary then leaves alone by design, and a test of SIGHUP would wait for nothing.
#[cfg(unix)]
pub fn default_sighup(cmd: &mut Command) -> &mut Command {
    use std::os::unix::process::CommandExt;
    // SAFETY: signal(2) is async-signal-safe, and this runs in the forked child before exec.
    unsafe {
        cmd.pre_exec(|| {
            libc::signal(libc::SIGHUP, libc::SIG_DFL);
            Ok(())
        })
    }
}

/// Sends `signals` (e.g. `libc::SIGTERM`), one right after the other, to `child` (spawned with
/// piped stdout and stderr) once `ready()` holds, and returns what it printed and its status.
/// Guards, not timed assertions: a child that is not ready within 10 minutes or still runs 10
/// minutes after the signals is killed and the test fails.
#[cfg(unix)]
pub fn signal_after(mut child: Child, signals: &[i32], ready: impl Fn() -> bool) -> Output {
    use std::io::Read;
    const GUARD: Duration = Duration::from_secs(600);
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let stdout = drain(child.stdout.take().map(|p| Box::new(p) as _));
    let stderr = drain(child.stderr.take().map(|p| Box::new(p) as _));
    let collect = |mut child: Child, status: Option<std::process::ExitStatus>| {
        let status = status.unwrap_or_else(|| {
            let _ = child.kill();
            child.wait().unwrap()
        });
        Output {
            status,
            stdout: stdout.join().unwrap(),
            stderr: stderr.join().unwrap(),
        }
    };
    let start = Instant::now();
    while !ready() {
        let exited = child.try_wait().unwrap();
        if exited.is_some() || start.elapsed() > GUARD {
            let o = collect(child, exited);
            panic!("not ready for the signal ({:?}): {}", o.status, text(&o));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let pid = child.id() as i32;
    for &s in signals {
        // SAFETY: kill(2) only sends a signal, to the child this test started and still holds.
        assert_eq!(unsafe { libc::kill(pid, s) }, 0, "kill {pid} {s}");
    }
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return collect(child, Some(status));
        }
        if start.elapsed() > GUARD {
            let o = collect(child, None);
            panic!("still running 10 minutes after the signal: {}", text(&o));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

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

/// The `[set]` table of the sweep tests' specs: [`SMALL_SWARM`]'s channel and swarm on the
/// native backend, with 4-step rollouts of 2 minibatches for train runs.
pub const SWEEP_SET: &str = r#"[set]
"solver.backend" = "native"
"train.rollout_steps" = 4
"train.minibatches" = 2
"domain.nx" = 300
"domain.length_m" = 0.03
"domain.success_x_m" = 0.006
"domain.failure_x_m" = 0.024
"swarm.count" = 2
"swarm.grid_rows" = 1
"swarm.grid_centre_x_m" = 0.015
"env.max_steps" = 3
"#;
