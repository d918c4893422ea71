//! Stopping a long command cleanly on a signal: SIGINT (Ctrl-C), SIGTERM (Slurm's time limit
//! and preemption, `timeout`, `docker stop`, systemd) and SIGHUP (a closed terminal; left
//! alone when it is ignored, as under `nohup`). The first one sets a flag that the command
//! polls between steps, so it finishes the step in hand, writes what it owes (a checkpoint,
//! flushed CSVs) and exits with 128 + the signal's number (130, 143, 129); a second one of any
//! of them exits at once, from the signal handler, with its own status.
//!
//! The flags are set inside the handler by one atomic swap (async-signal-safe); on Unix a
//! small thread also says at once what the command will do, since a training update may take
//! a while to finish.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A signal that stops a command cleanly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    Int,
    Term,
    Hup,
}

impl Signal {
    /// The signals handled on this platform.
    #[cfg(unix)]
    const ALL: [Signal; 3] = [Signal::Int, Signal::Term, Signal::Hup];
    #[cfg(not(unix))]
    const ALL: [Signal; 2] = [Signal::Int, Signal::Term];

    /// The signal's number (1, 2 and 15 on every Unix).
    pub fn number(self) -> i32 {
        match self {
            Signal::Int => signal_hook::consts::SIGINT,
            Signal::Term => signal_hook::consts::SIGTERM,
            Signal::Hup => 1,
        }
    }

    fn from_number(n: usize) -> Option<Signal> {
        Signal::ALL.into_iter().find(|s| s.number() as usize == n)
    }

    /// `SIGINT`, `SIGTERM` or `SIGHUP`.
    pub fn name(self) -> &'static str {
        match self {
            Signal::Int => "SIGINT",
            Signal::Term => "SIGTERM",
            Signal::Hup => "SIGHUP",
        }
    }

    /// The exit status after a clean stop, as a shell reports a process the signal killed:
    /// 128 + the signal's number (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP).
    pub fn exit_code(self) -> i32 {
        128 + self.number()
    }

    #[cfg_attr(not(unix), allow(dead_code))] // for the announcer
    fn label(self) -> &'static str {
        match self {
            Signal::Int => "Ctrl-C (SIGINT)",
            other => other.name(),
        }
    }

    #[cfg_attr(not(unix), allow(dead_code))]
    fn again(self) -> &'static str {
        match self {
            Signal::Int => "Ctrl-C again",
            Signal::Term => "a second SIGTERM",
            Signal::Hup => "a second SIGHUP",
        }
    }
}

/// The handlers of one command; [`Stop::signal`] says whether (and by which signal) it was
/// asked to stop.
pub struct Stop {
    /// The number of the first signal received, 0 before any.
    which: Arc<AtomicUsize>,
}

impl Stop {
    /// Installs the handlers for the rest of the process. `then` says what the command does on
    /// the first signal ("finishing this update, then writing a checkpoint"); it is printed as
    /// soon as the signal arrives (on Unix). A handler that cannot be installed is a warning:
    /// that signal then keeps its default action.
    pub fn install(then: &'static str) -> Stop {
        let stopping = Arc::new(AtomicBool::new(false));
        let which = Arc::new(AtomicUsize::new(0));
        let mut handled = Vec::new();
        for s in Signal::ALL {
            if s == Signal::Hup && ignored(s) {
                continue; // nohup: the run outlives the terminal, as asked
            }
            let (n, code) = (s.number(), s.exit_code());
            let (stopping, which) = (stopping.clone(), which.clone());
            // One atomic swap decides which signal is first, even when two arrive at once on
            // two threads (two handlers that each loaded the flag before either set it would
            // both take themselves for the first, and the second signal would be lost).
            let action = move || {
                if stopping.swap(true, Ordering::SeqCst) {
                    signal_hook::low_level::exit(code);
                }
                which.store(n as usize, Ordering::SeqCst);
            };
            // SAFETY: the action only swaps and stores lock-free atomics and calls `_exit`,
            // all async-signal-safe; it allocates nothing and takes no lock.
            let r = unsafe { signal_hook::low_level::register(n, action) };
            match r {
                Ok(_) => handled.push(s),
                Err(e) => log::warn!("{} will not stop this run cleanly: {e}", s.name()),
            }
        }
        announce(&handled, then);
        Stop { which }
    }

    /// The first signal received, if any.
    pub fn signal(&self) -> Option<Signal> {
        Signal::from_number(self.which.load(Ordering::SeqCst))
    }

    pub fn requested(&self) -> bool {
        self.signal().is_some()
    }
}

/// A command that a signal stopped cleanly, returned as its error so that a caller running
/// it in-process (a sweep task) can record the stop; `main` reports it with [`Stopped::report`]
/// and exits with the signal's status.
#[derive(Debug)]
pub struct Stopped {
    pub signal: Signal,
    /// What was kept ("checkpoint of update 7 written; continue with ...").
    pub what: String,
    pub out: std::path::PathBuf,
}

impl std::fmt::Display for Stopped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "interrupted by {}: {}", self.signal.name(), self.what)
    }
}

impl std::error::Error for Stopped {}

impl Stopped {
    pub fn new(signal: Signal, what: &str, out: &Path) -> Stopped {
        Stopped {
            signal,
            what: what.into(),
            out: out.to_path_buf(),
        }
    }

    /// Says, on stderr, that the signal stopped the command and prints the output directory on
    /// stdout (as a finished command does). Failed writes are ignored: after SIGHUP the
    /// terminal may be gone, and the status must still be the signal's.
    pub fn report(&self) -> i32 {
        let _ = writeln!(std::io::stderr(), "{self}");
        let _ = writeln!(std::io::stdout(), "{}", self.out.display());
        self.signal.exit_code()
    }
}

/// Whether `signal` is ignored (`nohup` ignores SIGHUP), so that installing a handler would
/// undo what the user asked for.
#[cfg(unix)]
fn ignored(signal: Signal) -> bool {
    // SAFETY: with a null new action, sigaction only writes the current one into `old`, a
    // plain C struct for which all-zero bytes are a valid value.
    unsafe {
        let mut old: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal.number(), std::ptr::null(), &mut old) == 0
            && old.sa_sigaction == libc::SIG_IGN
    }
}

#[cfg(not(unix))]
fn ignored(_: Signal) -> bool {
    false
}

/// A thread that prints what happens next as soon as the first signal arrives (the command
/// itself only notices between steps).
#[cfg(unix)]
fn announce(handled: &[Signal], then: &'static str) {
    let numbers: Vec<i32> = handled.iter().map(|s| s.number()).collect();
    let mut signals = match signal_hook::iterator::Signals::new(&numbers) {
        Ok(s) => s,
        Err(e) => {
            log::debug!("no signal announcer: {e}");
            return;
        }
    };
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(s) = signals
                .forever()
                .find_map(|n| Signal::from_number(n as usize))
            {
                let (label, again) = (s.label(), s.again());
                let _ = writeln!(
                    std::io::stderr(),
                    "\n{label}: {then} ({again} stops at once)"
                );
            }
        });
    if let Err(e) = spawned {
        log::debug!("no signal announcer: {e}");
    }
}

#[cfg(not(unix))]
fn announce(_: &[Signal], _: &'static str) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_are_128_plus_the_signal() {
        assert_eq!(Signal::Int.exit_code(), 130);
        assert_eq!(Signal::Term.exit_code(), 143);
        assert_eq!(Signal::Hup.exit_code(), 129);
        for s in Signal::ALL {
            assert_eq!(Signal::from_number(s.number() as usize), Some(s));
        }
        assert_eq!(Signal::from_number(0), None);
    }
}
