//! The training curve of each done run for `report --frontier`: the success rate of its
//! training episodes in each tenth of the run, from `DIR/<run dir>/episodes.csv` (the
//! `results` stage copies it). With G the run's last global step, an episode that ended at
//! global step g (1 <= g <= G) falls in bin floor((g - 1) * BINS / G), 0..BINS - 1. A policy
//! that learns and then loses what it learned shows as a row that rises and falls; the
//! protocol evaluates only the final policy.
//!
//! Where the `curve` stage of experiments/frontier_learners.sh has evaluated a run's policy
//! snapshots (`DIR/curve/<run>/update-N/episodes.csv`, sampled at the protocol's seed), their
//! successes are listed too, by update: exploratory, outside the protocol.

use std::path::Path;

use super::data::{Episode, read_episodes};
use super::error::Result;
use super::frontier::read_eval;
use super::sweep_table::SweepRow;

/// Bins per run (tenths of the run).
pub const BINS: usize = 10;

/// Successes and episodes in one bin.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bin {
    /// Successful training episodes.
    pub successes: usize,
    /// Training episodes that ended in the bin.
    pub episodes: usize,
}

/// One run's curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// The variant (sweep point).
    pub variant: usize,
    /// The run's seed.
    pub seed: String,
    /// The bins, first tenth first.
    pub bins: [Bin; BINS],
    /// The evaluated policy snapshots: (update, successes and episodes), by update.
    pub snapshots: Vec<(u64, Bin)>,
}

/// The bins of a run's training episodes (module header).
pub fn bins(episodes: &[Episode]) -> [Bin; BINS] {
    let mut out = [Bin::default(); BINS];
    let last = episodes.iter().map(|e| e.global_step).max().unwrap_or(0);
    if last == 0 {
        return out;
    }
    for e in episodes {
        let g = e.global_step.clamp(1, last);
        let b = ((g - 1) as u128 * BINS as u128 / last as u128) as usize;
        out[b].episodes += 1;
        out[b].successes += (e.outcome == "success") as usize;
    }
    out
}

/// The curves of the done runs among `runs` whose training `episodes.csv` is under `root`.
pub fn load(root: &Path, runs: &[SweepRow]) -> Result<Vec<Curve>> {
    let mut curves = Vec::new();
    for r in runs.iter().filter(|r| r.status == "done") {
        let path = root.join(&r.dir).join("episodes.csv");
        if !path.exists() {
            continue;
        }
        curves.push(Curve {
            variant: r.point,
            seed: r.seed.clone(),
            bins: bins(&read_episodes(&path, true)?),
            snapshots: snapshots(&root.join("curve").join(r.name()))?,
        });
    }
    curves.sort_by(|a, b| (a.variant, &a.seed).cmp(&(b.variant, &b.seed)));
    Ok(curves)
}

/// The evaluations of a run's snapshots under `dir` (`update-N/episodes.csv`), by update.
fn snapshots(dir: &Path) -> Result<Vec<(u64, Bin)>> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(update) = name.strip_prefix("update-").and_then(|u| u.parse().ok()) else {
            continue;
        };
        // The protocol's evaluation reader: the same files, the same counts.
        if let Some(e) = read_eval(&entry.path())? {
            let bin = Bin {
                successes: e.successes,
                episodes: e.episodes,
            };
            out.push((update, bin));
        }
    }
    out.sort_by_key(|s| s.0);
    Ok(out)
}

/// The markdown section: a row per run, each bin as "rate (episodes)".
pub fn markdown(curves: &[Curve]) -> String {
    let mut md = String::from("## Training curves\n\n");
    md += "Success rate of each done run's training episodes in each tenth of the run (by \
           global step), with the number of episodes that ended there. The protocol evaluates \
           only the final policy.\n\n| variant | seed |";
    for b in 0..BINS {
        md += &format!(" {}-{} % |", 100 * b / BINS, 100 * (b + 1) / BINS);
    }
    md += "\n|---|---|";
    md += &"---|".repeat(BINS);
    md += "\n";
    for c in curves {
        md += &format!("| {} | {} |", c.variant, c.seed);
        for b in &c.bins {
            md += &match b.episodes {
                0 => " - |".to_string(),
                n => format!(" {:.0} % ({n}) |", 100.0 * b.successes as f64 / n as f64),
            };
        }
        md += "\n";
    }
    if curves.is_empty() {
        md += "\nNo run is done yet.\n";
    }
    let evaluated: Vec<&Curve> = curves.iter().filter(|c| !c.snapshots.is_empty()).collect();
    if !evaluated.is_empty() {
        md += "\n### Policy snapshots evaluated (exploratory, outside the protocol)\n\n\
               Successes of each kept policy (`train --policy-every`), sampled at the protocol's \
               seed (the `curve` stage), by update.\n\n| variant | seed | successes by update |\n\
               |---|---|---|\n";
        for c in evaluated {
            let points: Vec<String> = c
                .snapshots
                .iter()
                .map(|(u, b)| format!("{u}: {}/{}", b.successes, b.episodes))
                .collect();
            md += &format!("| {} | {} | {} |\n", c.variant, c.seed, points.join(", "));
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn episode(global_step: u64, outcome: &str) -> Episode {
        Episode {
            global_step,
            env: 0,
            episode: 0,
            steps: 1,
            outcome: outcome.into(),
            metrics: [0.0; 3],
            final_x_com_mm: 0.0,
        }
    }

    #[test]
    fn episodes_fall_in_the_tenth_of_the_run_they_ended_in() {
        // G = 100: g 1..=10 is bin 0, 11..=20 bin 1, 91..=100 bin 9.
        let e = [
            episode(5, "success"),
            episode(10, "failure"),
            episode(11, "success"),
            episode(55, "timeout"),
            episode(100, "success"),
        ];
        let b = bins(&e);
        assert_eq!(
            b[0],
            Bin {
                successes: 1,
                episodes: 2
            }
        );
        assert_eq!(
            b[1],
            Bin {
                successes: 1,
                episodes: 1
            }
        );
        assert_eq!(
            b[5],
            Bin {
                successes: 0,
                episodes: 1
            }
        );
        assert_eq!(
            b[9],
            Bin {
                successes: 1,
                episodes: 1
            }
        );
        assert_eq!(b.iter().map(|b| b.episodes).sum::<usize>(), 5);
        assert_eq!(bins(&[]), [Bin::default(); BINS]);
    }

    #[test]
    fn the_table_gives_rate_and_count_and_marks_empty_bins() {
        let mut bins = [Bin::default(); BINS];
        bins[0] = Bin {
            successes: 1,
            episodes: 4,
        };
        let curve = |snapshots| Curve {
            variant: 3,
            seed: "2".into(),
            bins,
            snapshots,
        };
        let md = markdown(&[curve(Vec::new())]);
        assert!(md.contains("| 3 | 2 | 25 % (4) | - |"), "{md}");
        assert!(md.contains("| 0-10 % | 10-20 % |"), "{md}");
        assert!(!md.contains("snapshots evaluated"), "{md}");
        let two = Bin {
            successes: 2,
            episodes: 16,
        };
        let md = markdown(&[curve(vec![(250, two)])]);
        assert!(md.contains("| 3 | 2 | 250: 2/16 |"), "{md}");
        assert!(markdown(&[]).contains("No run is done yet."));
    }

    #[test]
    fn load_reads_the_done_runs_training_episodes() {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("runs/p001_x_seed4");
        std::fs::create_dir_all(&run).unwrap();
        std::fs::write(
            run.join("episodes.csv"),
            "global_step,env,episode,steps,outcome,progress,energy,smoothness,final_x_com_mm\n\
             8,0,0,3,failure,-1,0,1,60\n\
             16,1,0,5,success,2,0,1,19\n",
        )
        .unwrap();
        // Two evaluated snapshots (update-1000 sorts before update-250 as text) and a stray
        // directory.
        let eval = "env,episode,steps,outcome,progress,energy,smoothness,final_x_com_mm\n";
        for (name, rows) in [
            (
                "update-250",
                "0,0,9,success,1,0,1,19\n1,0,4,failure,-1,0,1,61\n",
            ),
            ("update-1000", "0,0,4,failure,-1,0,1,61\n"),
            ("notes", "0,0,4,failure,-1,0,1,61\n"),
        ] {
            let d = dir.path().join("curve/p001_x_seed4").join(name);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join("episodes.csv"), format!("{eval}{rows}")).unwrap();
        }
        let row = |status: &str, dir: &str| SweepRow {
            point: 1,
            seed: "4".into(),
            status: status.into(),
            dir: dir.into(),
            overrides: String::new(),
            values: Vec::new(),
        };
        let runs = [
            row("done", "runs/p001_x_seed4"),
            row("pending", "runs/p001_x_seed5"),
            row("done", "runs/p001_x_missing"),
        ];
        let curves = load(dir.path(), &runs).unwrap();
        assert_eq!(curves.len(), 1);
        // G = 16: g = 8 is bin floor(7 * 10 / 16) = 4, g = 16 bin floor(15 * 10 / 16) = 9.
        let bin = |successes, episodes| Bin {
            successes,
            episodes,
        };
        assert_eq!(curves[0].bins[4], bin(0, 1));
        assert_eq!(curves[0].bins[9], bin(1, 1));
        assert_eq!((curves[0].variant, curves[0].seed.as_str()), (1, "4"));
        assert_eq!(curves[0].snapshots, [(250, bin(1, 2)), (1000, bin(0, 1))]);
    }
}
