//! The binary as a user drives it: `simulate` writes SPEC section 7's files exactly, refuses an
//! unwritable output directory before simulating, `bench` writes bench.csv, `info` reports the
//! adapter and the driver self-check, bad config keys fail with the key named.

mod common;

use std::path::Path;

use common::cli::{SMALL, SMALL_SWARM, bin, text};

#[test]
fn simulate_writes_frames_fields_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mut args = vec![
        "simulate",
        "--seconds",
        "0.02",
        "--frames-every",
        "2",
        "--fields-every",
        "2",
        "--gif",
        "--out",
    ];
    let out_s = out.to_str().unwrap();
    args.push(out_s);
    args.extend_from_slice(SMALL);
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("control step: "), "{t}");
    assert!(t.contains(out_s), "prints the directory it wrote: {t}");
    for step in [0, 2, 4] {
        let png = out.join(format!("frames/env0_s{step:06}.png"));
        let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
        assert!(img.width() > 600 && img.height() > 150);
        for name in ["ux", "uy", "p"] {
            let path = out.join(format!("fields/{name}_{step:06}.npy"));
            let bytes = std::fs::read(&path).unwrap();
            let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
            assert_eq!(npy.shape(), &[20, 100], "{}", path.display());
            assert_eq!(npy.dtype().descr(), "'<f4'");
        }
    }
    assert!(!out.join("frames/env0_s000001.png").exists());
    // --gif: one looping animation of the three frames, README-sized.
    {
        use image::AnimationDecoder;
        let f = std::fs::File::open(out.join("animation.gif")).unwrap();
        let dec = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(f)).unwrap();
        let frames: Vec<_> = dec.into_frames().collect::<Result<_, _>>().unwrap();
        assert_eq!(frames.len(), 3);
        assert!(frames[0].buffer().width() <= 640);
    }
    let o = bin(&[&["simulate", "--gif", "--frames-every", "0"], SMALL].concat());
    assert!(!o.status.success() && text(&o).contains("--frames-every K"));
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let lines: Vec<&str> = summary.lines().collect();
    assert_eq!(
        lines[0],
        "step,t_s,inlet_u_m_s,max_div_per_s,flux_min_m2_s,flux_max_m2_s,pressure_iters,residual"
    );
    assert_eq!(lines.len(), 1 + 5, "steps 0..=4");
    let row: Vec<f64> = lines[4].split(',').map(|c| c.parse().unwrap()).collect();
    assert_eq!(row[0], 3.0);
    assert!((row[1] - 0.015).abs() < 1e-9);
    // Inlet centreline velocity at t = 15 ms on the systolic ramp: 8 + (400 - 8) * 15 / 30 mm/s.
    assert!((row[2] - 0.204).abs() < 1e-6, "{}", lines[4]);
    assert!(Path::new(&out.join("config.toml")).exists());
}

#[test]
fn simulate_refuses_an_unwritable_output_directory_before_simulating() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let out = file.join("run");
    let o = bin(&["simulate", "--out", out.to_str().unwrap()]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(t.contains("is not writable") && t.contains("--out"), "{t}");
    assert!(
        !t.contains("simulating"),
        "must fail before simulating: {t}"
    );
}

#[test]
fn bad_config_key_fails_with_the_key_named() {
    let o = bin(&["simulate", "--set", "time.substeps=10"]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(
        t.contains("error: config key `time.substeps` = 10") && t.contains("CFL"),
        "{t}"
    );
    assert!(!t.contains("adapter:"), "rejected before any GPU work: {t}");
}

/// Runs `bench --envs ENVS --seconds 0.05 EXTRA… --out OUT` on the small grid, checks that it
/// succeeded and returns its stdout and stderr.
fn bench(out: &std::path::Path, envs: &str, extra: &[&str]) -> String {
    let mut args = vec!["bench", "--envs", envs, "--seconds", "0.05"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", out.to_str().unwrap()]);
    args.extend_from_slice(SMALL);
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    text(&o)
}

/// The lines of a CSV file written by `bench`.
fn csv_lines(path: &std::path::Path) -> Vec<String> {
    let csv = std::fs::read_to_string(path).unwrap();
    csv.lines().map(str::to_string).collect()
}

#[test]
fn bench_writes_its_table_and_csv() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let output = bench(&out, "1,3", &["--set", "solver.backend=adapter"]);
    let rows: Vec<&str> = output
        .lines()
        .filter(|l| l.trim_start().starts_with(|c: char| c.is_ascii_digit()))
        .collect();
    assert_eq!(rows.len(), 2, "{output}");
    assert!(rows[0].trim_start().starts_with("1 ") && rows[1].trim_start().starts_with("3 "));
    let lines = csv_lines(&out.join("bench.csv"));
    assert_eq!(
        lines[0],
        "envs,env_steps_per_s,cell_updates_per_s,dispatches_per_substep,pressure_iters_per_substep,fluid_s,pressure_s,swarm_s,readback_s,adapter"
    );
    assert_eq!(lines.len(), 3);
    let cols: Vec<&str> = lines[2].split(',').collect();
    assert_eq!(cols[0], "3");
    assert!(cols[1].parse::<f64>().unwrap() > 0.0);
    assert_eq!(cols[3], "7", "MacCormack substep: 7 dispatches");
    assert_eq!(cols[4], "1");
}

/// `bench --native` adds the CPU backend's rate at each batch size and writes native.csv; the
/// CPU backend's own bench table has no dispatches.
#[test]
fn bench_native_writes_the_ratio_to_the_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let output = bench(
        &out,
        "1,3",
        &["--native", "--set", "solver.backend=adapter"],
    );
    assert!(output.contains("CPU backend (sim::cpu"), "{output}");
    let lines = csv_lines(&out.join("native.csv"));
    assert_eq!(
        lines[0],
        "envs,native_env_steps_per_s,adapter_env_steps_per_s,native_over_adapter,threads,adapter"
    );
    assert_eq!(lines.len(), 3);
    let cols: Vec<&str> = lines[2].split(',').collect();
    assert_eq!(cols[0], "3");
    let (native, adapter, ratio): (f64, f64, f64) = (
        cols[1].parse().unwrap(),
        cols[2].parse().unwrap(),
        cols[3].parse().unwrap(),
    );
    assert!(native > 0.0 && adapter > 0.0);
    assert!((ratio - native / adapter).abs() <= 1e-3 * ratio.max(1.0) + 1e-4);
    assert!(cols[4].parse::<usize>().unwrap() >= 1);

    let out = dir.path().join("backend");
    bench(&out, "2", &["--set", "solver.backend=native"]);
    let lines = csv_lines(&out.join("bench.csv"));
    let row: Vec<&str> = lines[1].split(',').collect();
    assert_eq!(row[3], "0", "no dispatches on the native backend");
    assert!(lines[1].contains(",\"CPU backend, "), "{}", lines[1]);
}

/// On the CPU backend `bench` times the stages (bench.csv's split is no longer zero), writes
/// the per-stage table (stages.csv) and the roofline against the peaks it measured
/// (roofline.csv).
#[test]
fn bench_on_the_cpu_backend_splits_the_step_by_stage_and_writes_the_roofline() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    let mut args = vec![
        "bench",
        "--envs",
        "1,2",
        "--seconds",
        "0.05",
        "--peak-seconds",
        "0.02",
        "--triad-mib",
        "8",
        "--set",
        "solver.backend=native",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(SMALL_SWARM);
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    for part in [
        "machine peaks on",
        "CPU stages at E = 2",
        "roofline at E = 2",
        "% of the",
    ] {
        assert!(t.contains(part), "missing {part}: {t}");
    }
    let lines = csv_lines(&out.join("bench.csv"));
    let row: Vec<f64> = lines[2]
        .split(',')
        .take(9)
        .map(|c| c.parse().unwrap())
        .collect();
    let (fluid, pressure, swarm) = (row[5], row[6], row[7]);
    assert!(fluid > 0.0 && pressure > 0.0 && swarm > 0.0, "{}", lines[2]);

    let stages = csv_lines(&out.join("stages.csv"));
    assert_eq!(
        stages[0],
        "envs,stage,cpu_s_per_control_step,share,wall_s_per_control_step,flops_per_cell_substep,bytes_per_cell_substep,gflop_per_cpu_s,gb_per_cpu_s"
    );
    assert_eq!(
        stages.len(),
        1 + 2 * 9,
        "8 stages and their sum per batch size"
    );
    let at_2: Vec<Vec<&str>> = stages[10..]
        .iter()
        .map(|l| l.split(',').collect())
        .collect();
    let names: Vec<&str> = at_2.iter().map(|c| c[1]).collect();
    assert_eq!(
        names,
        [
            "paint",
            "advect",
            "pressure_rhs",
            "pressure_solve",
            "pressure_back",
            "project",
            "move",
            "diagnostics",
            "all"
        ]
    );
    let share: f64 = at_2[..8].iter().map(|c| c[3].parse::<f64>().unwrap()).sum();
    assert!((share - 1.0).abs() < 1e-3, "{share}");
    for c in &at_2 {
        assert!(c[2].parse::<f64>().unwrap() > 0.0, "{c:?}");
        assert!(c[5].parse::<f64>().unwrap() > 0.0, "{c:?}");
    }

    let roof = csv_lines(&out.join("roofline.csv"));
    assert_eq!(roof.len(), 3);
    let cols: Vec<&str> = roof[2].split(',').collect();
    assert_eq!(cols[0], "2");
    let num = |k: usize| cols[k].parse::<f64>().unwrap();
    assert!(
        num(2) > 100.0 && num(3) > 100.0,
        "flops, bytes per cell: {}",
        roof[2]
    );
    for k in [4, 5, 6, 8, 9, 10, 11, 12, 13, 14] {
        assert!(
            num(k).is_finite() && num(k) > 0.0,
            "column {k}: {}",
            roof[2]
        );
    }
}

#[test]
fn info_reports_adapter_limits_and_self_check() {
    let o = bin(&["info"]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    for part in [
        "adapters found",
        "chosen",
        "max_storage_buffer_binding_size",
        "driver self-check",
        "largest batch",
    ] {
        assert!(t.contains(part), "missing {part}: {t}");
    }
}

#[test]
fn rollout_writes_episodes_swarm_and_trajectories() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ro");
    let args = [
        "rollout",
        "--policy",
        "upstream",
        "--envs",
        "2",
        "--episodes",
        "3",
        "--frames-every",
        "2",
        "--gif",
        "--gif-episode",
        "0",
        "--gif-steps",
        "2:10",
        "--gap",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = bin(&[&args[..], SMALL_SWARM].concat());
    assert!(o.status.success(), "{}", text(&o));
    let read = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
    // gap.csv: steps 0..=2 of the three counted episodes; an episode's last step is skipped
    // (its environment has reset, so the fields are the next episode's).
    let gap = read("gap.csv");
    let rows: Vec<&str> = gap.lines().collect();
    assert_eq!(
        rows[0],
        "env,episode,step,t_s,inlet_u_m_s,x_lo_mm,x_hi_mm,peak_u_m_s,mean_blocked,max_blocked"
    );
    assert_eq!(rows.len(), 1 + 3 * 3, "{gap}");
    assert!(!rows.iter().any(|r| r.starts_with("0,0,3,")), "{gap}");
    // Two members at x = 14.5 and 15.5 mm, r = 0.25 mm: the extent is 14.25 .. 15.75 mm.
    assert!(rows[1].starts_with("0,0,0,0.0000,"), "{gap}");
    let cells: Vec<f64> = rows[1].split(',').map(|c| c.parse().unwrap()).collect();
    assert_eq!((cells[5], cells[6]), (14.25, 15.75), "{gap}");
    // Both discs sit at mid-height (y = 1 mm; dy = 0.1 mm, r = 0.25 mm). In a column 0.05 mm
    // from a centre, the cell centres at y = 0.85 .. 1.15 mm lie inside (0.75 and 1.25 mm lie
    // 0.255 mm away): 4 of 20 rows. Columns near the extent's edges hold fewer.
    assert_eq!(cells[9], 0.2, "{gap}");
    assert!(cells[8] > 0.0 && cells[8] < cells[9], "{gap}");
    assert!(cells[7].is_finite() && cells[7] > 0.0, "{gap}");
    let episodes = read("episodes.csv");
    let lines: Vec<&str> = episodes.lines().collect();
    assert_eq!(
        lines[0],
        "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm"
    );
    // Both environments truncate together every 3 steps. The quota is 2 episodes for
    // environment 0 and 1 for environment 1: 4 episodes end by step 6, and exactly the 3 asked
    // for are counted (environment 1's second episode is not).
    assert_eq!(lines.len(), 1 + 3, "{episodes}");
    assert!(lines[3].starts_with("0,1,3,timeout,"), "{episodes}");
    assert!(
        lines[1].starts_with("0,0,3,timeout,") && lines[2].starts_with("1,0,3,timeout,"),
        "{episodes}"
    );
    let swarm = read("swarm.csv");
    assert!(swarm.starts_with(
        "env,episode,step,t_s,inlet_u_m_s,x_com_mm,y_com_mm,sigma_x_mm,sigma_y_mm,r_g_mm\n"
    ));
    // Steps 0..=3 of the three counted episodes only.
    assert_eq!(swarm.lines().count(), 1 + 3 * 4, "{swarm}");
    let traj = read("trajectories.csv");
    assert!(traj.starts_with("env,episode,step,member,x_mm,y_mm,vx_mm_s,vy_mm_s,ax,ay,f_prop_x_nN,f_prop_y_nN,f_hydro_x_nN,f_hydro_y_nN,f_drag_x_nN,f_drag_y_nN,f_contact_x_nN,f_contact_y_nN\n"));
    assert_eq!(traj.lines().count(), 1 + 3 * 4 * 2);
    // One start row per counted episode; phase 0 (random_phase is off).
    let starts = read("starts.csv");
    let rows: Vec<&str> = starts.lines().collect();
    assert_eq!(
        rows[0],
        "env,episode,start_phase_s,start_inlet_u_m_s,start_x_com_mm"
    );
    let keys: Vec<String> = rows[1..]
        .iter()
        .map(|r| r.split(',').take(3).collect::<Vec<_>>().join(","))
        .collect();
    assert_eq!(
        keys,
        ["0,0,0.000000", "1,0,0.000000", "0,1,0.000000"],
        "{starts}"
    );
    let row: Vec<&str> = traj
        .lines()
        .find(|l| l.starts_with("0,0,1,0,"))
        .unwrap()
        .split(',')
        .collect();
    assert_eq!(
        (row[8], row[9], row[10]),
        ("-1.00000", "0.00000", "-850.000"),
        "upstream thrust"
    );
    for name in [
        "env0_ep0000_s000000.png",
        "env0_ep0000_s000002.png",
        "env0_ep0001_s000000.png",
    ] {
        assert!(out.join("frames").join(name).exists(), "{name}");
    }
    // The GIF holds the one frame of episode 0 in steps [2, 10): step 2.
    let f = std::fs::File::open(out.join("animation.gif")).unwrap();
    let dec = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(f)).unwrap();
    use image::AnimationDecoder;
    assert_eq!(dec.into_frames().count(), 1);
    // A window without frames, or a bad one, fails and says why.
    for (window, says) in [
        (["--gif-steps", "4:2"], "START:END"),
        (["--gif-episode", "9"], "no frame of"),
    ] {
        let out = dir.path().join("empty");
        let args = [
            "rollout",
            "--policy",
            "zero",
            "--frames-every",
            "1",
            "--gif",
            window[0],
            window[1],
            "--out",
            out.to_str().unwrap(),
        ];
        let o = bin(&[&args[..], SMALL_SWARM].concat());
        assert!(
            !o.status.success() && text(&o).contains(says),
            "{}",
            text(&o)
        );
    }
    let o = bin(&["rollout", "--policy", "zero", "--gif-episode", "0"]);
    assert!(
        !o.status.success() && text(&o).contains("--gif"),
        "{}",
        text(&o)
    );
}

#[test]
fn rollout_quota_and_no_traces_with_a_privileged_controller() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ro");
    let args = [
        "rollout",
        "--policy",
        "scripted:0:90:0.0:0.5",
        "--envs",
        "2",
        "--episodes",
        "2",
        "--no-traces",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "inlet.random_phase=true",
        "--set",
        "inlet.scale=0.5",
    ];
    let o = bin(&[&args[..], SMALL_SWARM].concat());
    assert!(o.status.success(), "{}", text(&o));
    assert!(!out.join("swarm.csv").exists() && !out.join("trajectories.csv").exists());
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    let header = config.lines().next().unwrap();
    assert!(
        header.contains("policy scripted:0:90:0.0:0.5 (privileged, reads the inlet phase"),
        "{header}"
    );
    assert!(config.contains("scale = 0.5"), "{config}");
    // One episode from each environment (quota 1 + 1), with its random start phase recorded.
    let episodes = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let mut envs: Vec<&str> = episodes.lines().skip(1).map(|l| &l[..2]).collect();
    envs.sort();
    assert_eq!(envs, ["0,", "1,"], "{episodes}");
    let starts = std::fs::read_to_string(out.join("starts.csv")).unwrap();
    let phases: Vec<f64> = starts
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(phases.len(), 2);
    assert!(phases.iter().all(|p| (0.0..1.0).contains(p)) && phases[0] != phases[1]);
    let o = bin(&[&["rollout", "--policy", "wall-angle:x"], SMALL_SWARM].concat());
    assert!(
        !o.status.success() && text(&o).contains("wall-angle:30"),
        "{}",
        text(&o)
    );
}

#[test]
fn train_writes_config_episodes_and_updates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("train");
    let args = [
        "train",
        "--envs",
        "2",
        "--steps",
        "32",
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "train.rollout_steps=4",
        "--set",
        "train.minibatches=2",
    ];
    let o = bin(&[&args[..], SMALL_SWARM].concat());
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("control step: "));
    let config = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        config.starts_with("# fluxswarm-gpu ")
            && config.contains("seed 5, 2 environments, 32 global steps")
    );
    // The written configuration loads back.
    fluxswarm_gpu::config::Config::load(Some(&out.join("config.toml")), &[]).unwrap();
    let updates = std::fs::read_to_string(out.join("updates.csv")).unwrap();
    let lines: Vec<&str> = updates.lines().collect();
    assert_eq!(
        lines[0],
        "update,global_step,loss_progress,loss_energy,loss_smoothness,value_loss,entropy,mean_log_std,cos_pe,cos_ps,cos_es,conflict_pe,conflict_ps,conflict_es,sim_s,learn_s"
    );
    assert_eq!(lines.len(), 1 + 4, "4 updates of 4 steps x 2 environments");
    assert!(lines[4].starts_with("4,32,"));
    let episodes = std::fs::read_to_string(out.join("episodes.csv")).unwrap();
    let rows: Vec<&str> = episodes.lines().collect();
    assert!(rows[0].starts_with("global_step,env,episode,steps,outcome,"));
    // Episodes of 3 steps: 5 finish in each environment within 16 steps.
    assert_eq!(rows.len(), 1 + 2 * 5, "{episodes}");
}
