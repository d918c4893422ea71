//! `fluxswarm-gpu report` on small synthetic run directories whose numbers are worked out by
//! hand: every figure is written at its size and decodes, and report.md carries the numbers
//! of the CSVs. Needs no adapter.

use std::path::Path;
use std::process::Command;

use fluxswarm_gpu::config::Config;

const EPISODES_HEADER: &str = "global_step,env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm";
const UPDATES_HEADER: &str = "update,global_step,loss_progress,loss_energy,loss_smoothness,value_loss,entropy,mean_log_std,cos_pe,cos_ps,cos_es,conflict_pe,conflict_ps,conflict_es,sim_s,learn_s";

fn config_text(header: &str, sets: &[&str]) -> String {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let resolved = Config::load(None, &sets).expect("paper config");
    format!("{header}\n{}", resolved.config.to_toml())
}

/// (global_step, env, episode, steps, outcome, progress, energy, smoothness)
type Ep = (u64, usize, u64, u64, &'static str, f64, f64, f64);

fn train_dir(dir: &Path, seed: u64, pcgrad: bool, episodes: &[Ep], updates: &[(u64, f64, f64)]) {
    std::fs::create_dir_all(dir).unwrap();
    let header = format!(
        "# fluxswarm-gpu 0.1.0 train: seed {seed}, 2 environments, 64 global steps, adapter test adapter (Vulkan, Cpu)"
    );
    let sets: &[&str] = if pcgrad { &[] } else { &["train.pcgrad=false"] };
    std::fs::write(dir.join("config.toml"), config_text(&header, sets)).unwrap();
    let mut e = format!("{EPISODES_HEADER}\n");
    for &(g, env, ep, steps, outcome, p, en, s) in episodes {
        e += &format!("{g},{env},{ep},{steps},{outcome},{p},{en},{s},0,0,0,0,60\n");
    }
    std::fs::write(dir.join("episodes.csv"), e).unwrap();
    let mut u = format!("{UPDATES_HEADER}\n");
    for (i, &(g, sim, learn)) in updates.iter().enumerate() {
        let c = 0.1 * i as f64;
        u += &format!(
            "{},{g},0,0,0,0,0,0,{c},{},{},0.25,0.5,0.75,{sim},{learn}\n",
            i + 1,
            -c,
            0.5
        );
    }
    std::fs::write(dir.join("updates.csv"), u).unwrap();
}

/// A rollout directory: episodes (steps, outcome, progress, energy, smoothness) in env 0, and
/// a swarm.csv of `steps` rows per episode.
fn rollout_dir(dir: &Path, policy: &str, episodes: &[(u64, &str, f64, f64, f64)]) {
    std::fs::create_dir_all(dir).unwrap();
    let header = format!(
        "# fluxswarm-gpu 0.1.0 rollout: policy {policy}, seed 1, 1 environments, 2 episodes, adapter test adapter (Vulkan, Cpu)"
    );
    std::fs::write(dir.join("config.toml"), config_text(&header, &[])).unwrap();
    let mut e = String::from(
        "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm\n",
    );
    let mut s = String::from(
        "env,episode,step,t_s,inlet_u_m_s,x_com_mm,y_com_mm,sigma_x_mm,sigma_y_mm,r_g_mm\n",
    );
    for (ep, &(steps, outcome, p, en, sm)) in episodes.iter().enumerate() {
        let final_x = 50.0 + steps as f64 + ep as f64;
        e += &format!("0,{ep},{steps},{outcome},{p},{en},{sm},0,0,0,0,{final_x}\n");
        for k in 0..=steps {
            let x = 50.0 + k as f64 + ep as f64;
            s += &format!(
                "0,{ep},{k},{},{},{x},1,{},{},{}\n",
                0.005 * k as f64,
                0.1 * k as f64,
                1.0 + 0.1 * k as f64,
                0.4,
                1.2
            );
        }
    }
    // The start of an episode that had not finished: not part of any figure or number.
    s += &format!("0,{},0,0,0.008,999,1,999,999,999\n", episodes.len());
    std::fs::write(dir.join("episodes.csv"), e).unwrap();
    std::fs::write(dir.join("swarm.csv"), s).unwrap();
}

fn report(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fluxswarm-gpu"))
        .arg("report")
        .args(args)
        .output()
        .expect("running fluxswarm-gpu report")
}

#[test]
fn report_draws_every_figure_and_reports_the_csv_numbers() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    // Seed 1: env 0 progress 1..6 (the last 5 average 4), env 1 progress 10, 20 (15).
    // Seed 2: env 0 progress 7 (7), env 1 progress 2, 4, 6 (4).
    // Final progress over (seed, env): {4, 15, 7, 4}: mean 7.5, population sigma 4.5.
    // Smoothness: seed 1 env 0 all 1.0, env 1 all 0.5; seed 2 env 0 0.8, env 1 0.6:
    // mean 0.725, sigma sqrt((0.275^2 + 0.225^2 + 0.075^2 + 0.125^2) / 4) = 0.19203.
    // Successes: seed 1 env 0 episode 5 (40 steps, 0.2 s), seed 2 env 1 episode 2 (60 steps,
    // 0.3 s): 2 of 12 episodes = 16.7 %, mean time to success 0.25 s. One diverged episode.
    // Wall time per run: (1 + 1.5 + 2 + 2.5) + 4 x 0.25 = 8 s.
    let seed1: Vec<Ep> = (0..6)
        .map(|i| {
            let outcome = if i == 5 { "success" } else { "failure" };
            (
                16 * (i + 1),
                0,
                i,
                if i == 5 { 40 } else { 20 },
                outcome,
                (i + 1) as f64,
                0.5,
                1.0,
            )
        })
        .chain([
            (32, 1, 0, 20, "diverged", 10.0, 0.5, 0.5),
            (64, 1, 1, 20, "failure", 20.0, 0.5, 0.5),
        ])
        .collect();
    let seed2: Vec<Ep> = vec![
        (48, 0, 0, 20, "timeout", 7.0, 0.5, 0.8),
        (16, 1, 0, 20, "failure", 2.0, 0.5, 0.6),
        (32, 1, 1, 20, "failure", 4.0, 0.5, 0.6),
        (64, 1, 2, 60, "success", 6.0, 0.5, 0.6),
    ];
    let updates = [
        (16, 1.0, 0.25),
        (32, 1.5, 0.25),
        (48, 2.0, 0.25),
        (64, 2.5, 0.25),
    ];
    train_dir(&root.join("pc1"), 1, true, &seed1, &updates);
    train_dir(&root.join("pc2"), 2, true, &seed2, &updates);
    // The compared experiment: one run, progress -1, -3 in env 0 (final -2).
    train_dir(
        &root.join("nopc1"),
        1,
        false,
        &[
            (16, 0, 0, 20, "failure", -1.0, 0.1, 0.2),
            (48, 0, 1, 20, "failure", -3.0, 0.1, 0.2),
        ],
        &updates,
    );
    rollout_dir(
        &root.join("upstream"),
        "upstream",
        &[
            (25, "failure", -120.0, -1.0, 1.0),
            (25, "failure", -130.0, -1.0, 1.0),
        ],
    );
    rollout_dir(
        &root.join("before"),
        "runs/x/untrained",
        &[
            (4, "failure", -10.0, 0.0, 0.5),
            (6, "failure", -20.0, 0.2, 0.7),
        ],
    );
    rollout_dir(
        &root.join("after"),
        "runs/x/seed1",
        &[
            (8, "success", 5.0, 0.9, 0.95),
            (8, "failure", -5.0, 0.7, 0.85),
        ],
    );
    let out = root.join("report");
    let p = |n: &str| root.join(n).display().to_string();
    let o = report(&[
        &p("pc1"),
        &p("pc2"),
        "--compare",
        &p("nopc1"),
        "--baseline",
        &p("upstream"),
        "--before",
        &p("before"),
        "--after",
        &p("after"),
        "--out",
        &p("report"),
    ]);
    assert!(
        o.status.success(),
        "report failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    for (name, panels) in [
        ("learning_curves.png", 3),
        ("gradient_conflicts.png", 2),
        ("dispersion.png", 2),
        ("com_rg.png", 2),
    ] {
        let path = out.join(name);
        let img = image::open(&path)
            .unwrap_or_else(|e| panic!("{name} does not decode: {e}"))
            .to_rgb8();
        assert_eq!(img.dimensions(), (1000, 380 * panels), "{name}");
        // Not blank: curves, text and bands use many colours.
        let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        colours.sort();
        colours.dedup();
        assert!(
            colours.len() > 50,
            "{name} has only {} colours",
            colours.len()
        );
    }
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let row = |label: &str| -> &str {
        md.lines()
            .find(|l| l.starts_with(&format!("| {label} |")))
            .unwrap_or_else(|| panic!("no row {label} in\n{md}"))
    };
    let main = row("MOMAPPO + PCGrad (2 seeds)");
    for want in [
        "| 2 | 64 | 8 | 12 |",
        "16.7 %",
        "| 0.250 |",
        "| 1 |", // diverged
        "7.50 ± 4.50",
        "0.500 ± 0.000",
        "0.725 ± 0.192",
        "2 success, 8 failure, 1 timeout, 1 diverged",
    ] {
        assert!(main.contains(want), "`{want}` missing from {main}");
    }
    let ablation = row("MOMAPPO, no PCGrad");
    assert!(ablation.contains("-2.00 ± 0.00"), "{ablation}");
    assert!(ablation.contains("| 0.0 % | — |"), "{ablation}");
    let up = row("baseline");
    assert!(
        up.contains("direct-upstream") && up.contains("-125.00 ± 5.00"),
        "{up}"
    );
    assert!(
        up.contains("-1.000 ± 0.000") && up.contains("| 25.0 |"),
        "{up}"
    );
    let after = row("after learning");
    // Final x_COM: 50 + 8 + episode -> 58, 59: mean 58.5.
    assert!(
        after.contains("| 0.040 |") && after.contains("58.50"),
        "{after}"
    );
    assert!(md.contains("[dispersion.png](dispersion.png)"));
    // Only finished episodes' steps enter the before/after figures.
    let after = fluxswarm_gpu::report::data::RolloutRun::read(&root.join("after")).unwrap();
    assert_eq!(after.swarm.len(), 2 * 9);
    assert!(after.swarm.iter().all(|s| s.x_com_mm < 100.0));
    assert!(md.contains("test adapter (Vulkan, Cpu)"));
}

#[test]
fn report_refuses_what_it_cannot_use() {
    let tmp = tempfile::tempdir().unwrap();
    let o = report(&[&tmp.path().display().to_string()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("config.toml"), "{err}");
    rollout_dir(
        &tmp.path().join("r"),
        "upstream",
        &[(2, "failure", 0.0, 0.0, 1.0)],
    );
    let o = report(&[&tmp.path().join("r").display().to_string()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no updates.csv"), "{err}");
}

/// A map rollout directory: `k` successes of `n` at one point, every episode starting at x_COM
/// 50 mm and phase 0.5 s (a diastole start).
fn map_dir(dir: &Path, policy: &str, scale: f64, thrust: f64, k: usize, n: usize) {
    std::fs::create_dir_all(dir).unwrap();
    let header = format!(
        "# fluxswarm-gpu 0.1.0 rollout: policy {policy}, seed 1, 4 environments, {n} episodes, adapter CPU backend"
    );
    let sets = [
        format!("inlet.scale={scale}"),
        format!("swarm.max_thrust_n={thrust}"),
    ];
    let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
    std::fs::write(dir.join("config.toml"), config_text(&header, &sets)).unwrap();
    let mut e = String::from(
        "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm\n",
    );
    let mut s = String::from("env,episode,start_phase_s,start_inlet_u_m_s,start_x_com_mm\n");
    for ep in 0..n {
        let (outcome, x) = if ep < k {
            ("success", 20.0)
        } else {
            ("failure", 70.0)
        };
        e += &format!("0,{ep},200,{outcome},0,0,0,0,0,0,0,{x}\n");
        s += &format!("0,{ep},0.5,0.008,50\n");
    }
    std::fs::write(dir.join("episodes.csv"), e).unwrap();
    std::fs::write(dir.join("starts.csv"), s).unwrap();
}

#[test]
fn map_writes_its_csvs_and_figures_from_rollout_directories() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("map");
    for (scale, wall, scripted) in [(0.9, 3, 4), (1.0, 0, 2)] {
        for thrust in [8.5e-7, 2.5e-6] {
            let point = root.join(format!("s{scale}_f{thrust}"));
            map_dir(&point.join("zero"), "zero", scale, thrust, 0, 4);
            map_dir(&point.join("wall"), "wall", scale, thrust, wall, 4);
            map_dir(
                &point.join("scripted"),
                "scripted",
                scale,
                thrust,
                scripted,
                4,
            );
        }
    }
    let out = tmp.path().join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_fluxswarm-gpu"))
        .args([
            "map",
            root.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let points = std::fs::read_to_string(out.join("controllability_points.csv")).unwrap();
    // Four points; at s = 0.9 wall (3/4) is the best constant and scripted (4/4) leads by 0.25.
    assert_eq!(points.lines().count(), 1 + 4, "{points}");
    let row = points
        .lines()
        .find(|l| l.starts_with("0.9,850.0,"))
        .unwrap();
    assert!(
        row.contains(",wall,0.7500,") && row.ends_with(",1.0000,0.5101,1.0000,0.2500"),
        "{row}"
    );
    let map = std::fs::read_to_string(out.join("controllability_map.csv")).unwrap();
    assert_eq!(map.lines().count(), 1 + 12);
    // Every start was a diastole start; 3 successes moved 30 mm, 1 failure -20 mm, in 4 cycles.
    let wall = map
        .lines()
        .find(|l| l.starts_with("0.9,0.3600,850.0,wall,"))
        .unwrap();
    assert!(
        wall.contains(",4,3,0.7500,") && wall.contains(",0,0,0.0000,1.0000,4,3,"),
        "{wall}"
    );
    assert!(
        wall.contains(",17.500,"),
        "(90 - 20) mm over 4 cycles: {wall}"
    );
    for name in [
        "controllability_map.png",
        "controllability_map_gap.png",
        "controllability_map_best_constant.png",
    ] {
        let img = image::open(out.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(img.width() >= 400 && img.height() >= 300, "{name}");
    }
    // No wall-drag probes: no dimensionless figure.
    assert!(!out.join("controllability_map_dimensionless.png").exists());
    let o = Command::new(env!("CARGO_BIN_EXE_fluxswarm-gpu"))
        .args(["map", tmp.path().join("empty").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success());
}

/// A rollout directory with traces and gap.csv whose behaviour numbers are counted by hand:
/// one successful episode of 400 steps from phase 0 (two complete 1 s cycles of 200 steps).
/// The inlet is 0.4 m/s at steps 1..=20 of each cycle and 0.008 m/s otherwise (threshold
/// 0.2), so the intervals starting at steps 0..=20 of a cycle are forward flow (21) and the
/// other 179 are not. x_COM moves +0.1 mm over each forward interval and -0.02 mm over each
/// other: D_fwd = 2.1 mm and D_rest = -3.58 mm in both cycles, both ratchet cycles.
fn behaviour_dir(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let header = "# fluxswarm-gpu 0.1.0 rollout: policy scripted, seed 1, 1 environments, 1 episodes, adapter CPU backend";
    std::fs::write(dir.join("config.toml"), config_text(header, &[])).unwrap();
    std::fs::write(
        dir.join("episodes.csv"),
        "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm\n0,0,400,success,1,0.5,0.9,0,0,0,0,19.9\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("starts.csv"),
        "env,episode,start_phase_s,start_inlet_u_m_s,start_x_com_mm\n0,0,0.000000,0.008,50\n",
    )
    .unwrap();
    let forward = |k: u64| (1..=20).contains(&(k % 200));
    let (mut swarm, mut gap, mut traj) = (
        String::from(
            "env,episode,step,t_s,inlet_u_m_s,x_com_mm,y_com_mm,sigma_x_mm,sigma_y_mm,r_g_mm\n",
        ),
        String::from(
            "env,episode,step,t_s,inlet_u_m_s,x_lo_mm,x_hi_mm,peak_u_m_s,mean_blocked,max_blocked\n",
        ),
        String::from("env,episode,step,member,x_mm,y_mm,ax,ay\n"),
    );
    let mut x = 50.0;
    for k in 0..=400u64 {
        if k > 0 {
            x += if forward(k - 1) || forward(k) {
                0.1
            } else {
                -0.02
            };
        }
        let inlet = if forward(k) { 0.4 } else { 0.008 };
        // sigma_x and R_g: 1 mm, then 2 mm over the last 40 steps (361..=400).
        let sx = if k >= 361 { 2.0 } else { 1.0 };
        let sy = if forward(k) { 0.5 } else { 0.3 };
        let t = 0.005 * k as f64;
        swarm += &format!("0,0,{k},{t},{inlet},{x},1,{sx},{sy},{sx}\n");
        if k < 400 {
            let peak = if forward(k) { 0.6 } else { 0.01 };
            let max_b = if k == 5 { 0.3 } else { 0.2 };
            gap += &format!(
                "0,0,{k},{t},{inlet},{},{},{peak},0.1,{max_b}\n",
                x - 1.0,
                x + 1.0
            );
        }
        // Member 0 at y = 0.5 mm, member 1 at 1.5 mm (mid-height 1 mm). In forward flow both
        // push 60 deg from upstream towards y = 0; otherwise each 40 deg towards its nearer wall.
        let (ang, down) = if forward(k) {
            (60f64, [-1.0, -1.0])
        } else {
            (40f64, [-1.0, 1.0])
        };
        let (c, s) = (ang.to_radians().cos(), ang.to_radians().sin());
        traj += &format!(
            "0,0,{k},0,{},0.5,{},{}\n0,0,{k},1,{},1.5,{},{}\n",
            x - 0.5,
            -c,
            down[0] * s,
            x + 0.5,
            -c,
            down[1] * s
        );
    }
    std::fs::write(dir.join("swarm.csv"), swarm).unwrap();
    std::fs::write(dir.join("gap.csv"), gap).unwrap();
    std::fs::write(dir.join("trajectories.csv"), traj).unwrap();
}

#[test]
fn behaviour_measures_the_ratchet_throttling_and_approach() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    behaviour_dir(&run);
    let out = tmp.path().join("rep");
    let o = report(&[
        "--behaviour",
        run.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(out.join("behaviour.md")).unwrap();
    // Episodes 1, successes 1, complete cycles 2, ratchet cycles 2, D_fwd, D_rest.
    assert!(md.contains("| 1 | 1 | 2 | 2 | 2.100 | -3.580 |"), "{md}");
    // 40 forward steps: sigma_y 0.5, sigma_x 1; peak 600 mm/s = 1.5 x inlet; blocked.
    assert!(
        md.contains("| 40 | 40 | 0.500 | 1.000 | 600 | 1.50 | 0.100 | 0.300 |"),
        "{md}"
    );
    // Thrust: 40 forward steps x 2 members at 60 deg, half towards their nearer wall, all
    // towards y = 0; 361 other steps x 2 at 40 deg, all towards the nearer wall.
    assert!(
        md.contains("| 80 | 60.0 ± 0.0 | 0.50 | 1.00 | 722 | 40.0 ± 0.0 | 1.00 | 0.50 |"),
        "{md}"
    );
    // By phase: the tenth 0.0-0.1 holds steps 0-19, 200-219 and 400 (steps 20 and 220 sit at
    // phase 0.1), so 38 forward steps at 60 deg, all towards y = 0, and 3 rest steps at 40 deg,
    // one member of two towards y = 0: 4800 / 82 = 58.5 deg, 79 / 82 = 0.96, and a mean inlet
    // of (38 x 400 + 3 x 8) / 41 = 371.3 mm/s. The tenths from 0.2 on are all rest.
    assert!(
        md.contains("| inlet (mm/s) | 371.3 | ") && md.contains(" | 58.5 (0.96) | "),
        "{md}"
    );
    assert_eq!(md.matches("40.0 (0.50)").count(), 8, "{md}");
    // The last 40 steps (0.2 s) spread twice as wide as the 361 rows before.
    assert!(md.contains("| 1 | 40 | 2.00 | 2.00 | 1/1 |"), "{md}");
    let phase_csv = std::fs::read_to_string(out.join("thrust_phase.csv")).unwrap();
    assert_eq!(phase_csv.lines().count(), 11, "{phase_csv}");
    assert!(
        phase_csv
            .lines()
            .nth(1)
            .unwrap()
            .contains(",0.00,0.10,82,371.32,58.54,"),
        "{phase_csv}"
    );
    for f in [
        "ratchet.png",
        "throttling.png",
        "approach.png",
        "thrust_phase.png",
    ] {
        let img = image::open(out.join(f)).unwrap();
        assert_eq!(img.width(), 1000, "{f}");
        assert!(md.contains(&format!("![{f}]({f})")), "{f}");
    }
    let csv = std::fs::read_to_string(out.join("behaviour.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with(",thrust_rest_lower_wall")
            && csv
                .trim_end()
                .ends_with(",80,60.00,0.00,0.5000,1.0000,722,40.00,0.00,1.0000,0.5000"),
        "{csv}"
    );
    // A directory without traces is refused with the file named.
    std::fs::remove_file(run.join("swarm.csv")).unwrap();
    let o = report(&["--behaviour", run.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("swarm.csv"), "{err}");
}
