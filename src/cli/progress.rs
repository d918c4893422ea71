//! Progress of a long command (`train`, `rollout`, `eval`, `simulate`) on stderr: an indicatif
//! bar on a terminal, and where there is none (Slurm logs, `nohup`, CI, a pipe) a plain line,
//! at most every `FLUXSWARM_PROGRESS_SECS` seconds (default 10; 0: at every update) and once
//! at the end:
//!
//! ```text
//! train: 1072/100000 steps (1.1 %), 150 steps/s, eta 11m01s, elapsed 7s; update 134  success 0% …
//! ```
//!
//! The rate and ETA are computed here, not by indicatif: units done since the (re)start over
//! the wall time since then. That average stays steady when the units arrive in chunks
//! (`train` advances by E x T steps an update), where indicatif's short window swung between
//! `0.083/s eta 2w` and `24.7/s eta 71m`.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// The variable that sets the seconds between plain progress lines.
pub const SECS_VAR: &str = "FLUXSWARM_PROGRESS_SECS";
const DEFAULT_SECS: f64 = 10.0;

pub struct Progress {
    what: &'static str,
    unit: &'static str,
    total: u64,
    /// Position at the (re)start, where the rate's count begins.
    start_pos: u64,
    start: Instant,
    pos: u64,
    msg: String,
    out: Out,
}

enum Out {
    Bar(ProgressBar),
    Lines {
        every: Duration,
        last: Option<Instant>,
        printed: Option<u64>,
    },
}

impl Progress {
    /// Progress of `what` (the command's name) towards `total` units, `done` of them already
    /// (a resumed run): a bar when stderr is a terminal, plain lines otherwise.
    pub fn new(what: &'static str, unit: &'static str, total: u64, done: u64) -> Self {
        let out = if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(total);
            let template = format!("{{bar:30}} {{pos}}/{{len}} {unit}  {{msg}}");
            bar.set_style(
                ProgressStyle::with_template(&template)
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_position(done.min(total));
            Out::Bar(bar)
        } else {
            Out::Lines {
                every: interval(),
                last: None,
                printed: None,
            }
        };
        Self {
            what,
            unit,
            total,
            start_pos: done,
            start: Instant::now(),
            pos: done,
            msg: String::new(),
            out,
        }
    }

    /// Moves to `pos` units done, with `msg` after the rate and ETA. A plain line is printed
    /// if none was in the last interval.
    pub fn set(&mut self, pos: u64, msg: String) {
        self.pos = pos;
        self.msg = msg;
        let elapsed = self.start.elapsed();
        let (rate, eta) = rate_and_eta(
            self.pos.saturating_sub(self.start_pos),
            self.total.saturating_sub(self.pos),
            elapsed.as_secs_f64(),
        );
        match &mut self.out {
            Out::Bar(bar) => {
                bar.set_message(format!(
                    "{} {}/s  eta {}  {}",
                    fmt_rate(rate),
                    self.unit,
                    fmt_eta(eta),
                    self.msg
                ));
                bar.set_position(pos.min(self.total));
            }
            Out::Lines {
                every,
                last,
                printed,
            } => {
                let now = Instant::now();
                if last.is_none_or(|t| now.duration_since(t) >= *every) {
                    *last = Some(now);
                    *printed = Some(pos);
                    // Ignored if it fails: progress is no reason to stop a run.
                    let _ = writeln!(
                        std::io::stderr(),
                        "{}",
                        line(
                            self.what,
                            self.unit,
                            pos,
                            self.total,
                            rate,
                            eta,
                            elapsed.as_secs_f64(),
                            &self.msg
                        )
                    );
                }
            }
        }
    }

    /// Ends the bar, or prints the last plain line if the newest position was not printed yet.
    pub fn finish(&mut self) {
        match &mut self.out {
            Out::Bar(bar) => bar.finish(),
            Out::Lines { every, printed, .. } => {
                if *printed != Some(self.pos) {
                    *every = Duration::ZERO;
                    let msg = std::mem::take(&mut self.msg);
                    self.set(self.pos, msg);
                }
            }
        }
    }

    /// Leaves the bar as it is (a command that fails); nothing more in plain lines.
    pub fn abandon(&mut self) {
        if let Out::Bar(bar) = &self.out {
            bar.abandon();
        }
    }
}

/// Seconds between plain lines: `FLUXSWARM_PROGRESS_SECS`, or the default.
fn interval() -> Duration {
    let secs = match std::env::var(SECS_VAR) {
        Ok(v) => match v.trim().parse::<f64>() {
            Ok(s) if s.is_finite() && s >= 0.0 => s,
            _ => {
                log::warn!(
                    "{SECS_VAR}={v:?} is not a number of seconds (0 or more): using {DEFAULT_SECS}"
                );
                DEFAULT_SECS
            }
        },
        Err(_) => DEFAULT_SECS,
    };
    Duration::from_secs_f64(secs)
}

/// Units per second since the (re)start, and the seconds left at that rate (None before any
/// unit is done).
fn rate_and_eta(done: u64, left: u64, elapsed_s: f64) -> (Option<f64>, Option<f64>) {
    if done == 0 || elapsed_s <= 0.0 {
        return (None, None);
    }
    let rate = done as f64 / elapsed_s;
    (Some(rate), Some(left as f64 / rate))
}

#[allow(clippy::too_many_arguments)]
fn line(
    what: &str,
    unit: &str,
    pos: u64,
    total: u64,
    rate: Option<f64>,
    eta: Option<f64>,
    elapsed_s: f64,
    msg: &str,
) -> String {
    let percent = 100.0 * pos as f64 / total.max(1) as f64;
    let mut s = format!(
        "{what}: {pos}/{total} {unit} ({percent:.1} %), {} {unit}/s, eta {}, elapsed {}",
        fmt_rate(rate),
        fmt_eta(eta),
        fmt_duration(elapsed_s)
    );
    if !msg.is_empty() {
        s.push_str("; ");
        s.push_str(msg);
    }
    s
}

/// Three significant figures or so: `1234`, `24.7`, `3.21`, `0.083`.
fn fmt_rate(rate: Option<f64>) -> String {
    match rate {
        None => "-".into(),
        Some(r) if r >= 100.0 => format!("{r:.0}"),
        Some(r) if r >= 10.0 => format!("{r:.1}"),
        Some(r) if r >= 1.0 => format!("{r:.2}"),
        Some(r) => format!("{r:.3}"),
    }
}

fn fmt_eta(eta: Option<f64>) -> String {
    eta.map_or_else(|| "-".into(), fmt_duration)
}

/// `45s`, `12m05s`, `3h07m`, `2d04h`.
fn fmt_duration(secs: f64) -> String {
    let s = secs.max(0.0).round() as u64;
    let (d, h, m) = (s / 86_400, s / 3600 % 24, s / 60 % 60);
    if s < 60 {
        format!("{s}s")
    } else if s < 3600 {
        format!("{m}m{:02}s", s % 60)
    } else if d == 0 {
        format!("{h}h{m:02}m")
    } else {
        format!("{d}d{h:02}h")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_counts_from_the_restart_and_the_eta_follows_it() {
        assert_eq!(rate_and_eta(0, 100, 5.0), (None, None));
        // 96 steps in 8 s since a restart: 12 steps/s, 1000 left in 83 s, whatever the
        // position the run was resumed at.
        let (rate, eta) = rate_and_eta(96, 1000, 8.0);
        assert_eq!(rate, Some(12.0));
        assert!((eta.unwrap() - 1000.0 / 12.0).abs() < 1e-9);
    }

    #[test]
    fn durations_and_rates_read_as_people_write_them() {
        assert_eq!(fmt_duration(44.6), "45s");
        assert_eq!(fmt_duration(725.0), "12m05s");
        assert_eq!(fmt_duration(3.0 * 3600.0 + 7.0 * 60.0 + 10.0), "3h07m");
        assert_eq!(fmt_duration(2.0 * 86_400.0 + 4.0 * 3600.0), "2d04h");
        assert_eq!(fmt_rate(Some(1234.4)), "1234");
        assert_eq!(fmt_rate(Some(24.71)), "24.7");
        assert_eq!(fmt_rate(Some(0.0834)), "0.083");
        assert_eq!(fmt_rate(None), "-");
    }

    #[test]
    fn a_plain_line_names_the_command_position_rate_and_eta() {
        let l = line(
            "train",
            "steps",
            384,
            108_000,
            Some(12.3),
            Some(8750.0),
            31.0,
            "success 0%",
        );
        assert_eq!(
            l,
            "train: 384/108000 steps (0.4 %), 12.3 steps/s, eta 2h25m, elapsed 31s; success 0%"
        );
    }
}
