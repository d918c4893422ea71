//! Bad configurations are rejected before any GPU work, with a message naming the key, the
//! value and the limit or the fix (no panic).

use std::path::PathBuf;

use fluxswarm_gpu::config::Config;

fn err(sets: &[&str]) -> String {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    match Config::load(None, &sets) {
        Ok(_) => panic!("config {sets:?} should be rejected"),
        Err(e) => e.to_string(),
    }
}

fn err_file(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, text).unwrap();
    match Config::load(Some(&path), &[]) {
        Ok(_) => panic!("config file {text:?} should be rejected"),
        Err(e) => e.to_string(),
    }
}

fn assert_contains(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "message {message:?} lacks {p:?}");
    }
}

#[test]
fn paper_default_loads_at_cfl_exactly_one() {
    let r = Config::load(None, &[]).unwrap();
    assert_eq!(
        r.config.cfl_number(&r.waveform),
        0.4 * (0.005 / 20.0) / (0.1 / 1000.0)
    );
    assert!((r.config.cfl_number(&r.waveform) - 1.0).abs() < 1e-12);
}

#[test]
fn unknown_key() {
    assert_contains(
        &err(&["domain.nxx=5"]),
        &["domain.nxx=5", "unknown key `nxx`", "[domain]", "nx"],
    );
}

#[test]
fn unknown_section() {
    assert_contains(
        &err(&["fluids.density_kg_m3=1000"]),
        &["unknown section `fluids`", "fluid"],
    );
}

#[test]
fn unknown_key_in_file() {
    assert_contains(
        &err_file("[fluid]\ndensity = 1000.0\n"),
        &["fluid", "unknown field `density`"],
    );
}

#[test]
fn wrong_type() {
    assert_contains(
        &err(&["domain.nx=\"many\""]),
        &["`domain.nx`", "invalid type", "string"],
    );
    assert_contains(
        &err(&["time.substeps=2.5"]),
        &["`time.substeps`", "invalid type"],
    );
}

#[test]
fn non_positive_sizes() {
    assert_contains(
        &err(&["domain.length_m=-0.1"]),
        &["`domain.length_m` = -0.1", "positive"],
    );
    assert_contains(
        &err(&["domain.height_m=0"]),
        &["`domain.height_m` = 0", "positive"],
    );
    assert_contains(&err(&["domain.ny=0"]), &["`domain.ny` = 0", "at least 2"]);
    assert_contains(
        &err(&["time.substeps=0"]),
        &["`time.substeps` = 0", "at least 1"],
    );
}

#[test]
fn non_finite_values() {
    assert_contains(
        &err(&["fluid.density_kg_m3=nan"]),
        &["`fluid.density_kg_m3` = NaN", "finite"],
    );
    assert_contains(
        &err(&["fluid.viscosity_pa_s=inf"]),
        &["`fluid.viscosity_pa_s` = inf"],
    );
}

#[test]
fn diffusion_number_above_quarter() {
    // nu = 0.3 / 1060 -> nu dt / dx^2 = 7.1
    assert_contains(
        &err(&["fluid.viscosity_pa_s=0.3"]),
        &["diffusion number", "7.07", "above", "0.25"],
    );
}

#[test]
fn cfl_above_limit() {
    // 10 substeps: dt_sub = 0.5 ms -> CFL = 0.4 * 5e-4 / 1e-4 = 2
    assert_contains(
        &err(&["time.substeps=10"]),
        &["`time.substeps` = 10", "CFL number", "2.0000", "limit 1"],
    );
    // Faster inlet at the default step.
    assert_contains(
        &err(&["inlet.points=[[0.0, 0.1], [0.5, 0.5]]"]),
        &["CFL number", "1.2500", "raise time.substeps"],
    );
}

#[test]
fn bad_waveform() {
    assert_contains(
        &err(&["inlet.points=[[0.0, 0.1], [0.0, 0.2]]"]),
        &["inlet waveform", "increase strictly"],
    );
    assert_contains(
        &err(&["inlet.points=[[0.0, 0.1]]"]),
        &["at least 2 control points"],
    );
    assert_contains(
        &err(&["inlet.points=[[0.0, 0.1], [1.5, 0.2]]"]),
        &["outside [0, period_s = 1]"],
    );
    let missing = PathBuf::from("/nonexistent/wave.csv");
    assert_contains(
        &err(&[&format!("inlet.csv=\"{}\"", missing.display())]),
        &["inlet waveform CSV /nonexistent/wave.csv", "cannot read"],
    );
}

#[test]
fn unknown_advection_scheme() {
    assert_contains(
        &err(&["solver.advection=upwind"]),
        &[
            "`solver.advection`",
            "unknown variant `upwind`",
            "maccormack",
        ],
    );
}

#[test]
fn analysis_region_outside_channel() {
    assert_contains(
        &err(&["domain.success_x_m=0.2"]),
        &["`domain.success_x_m` = 0.2", "inside the channel"],
    );
    assert_contains(
        &err(&["domain.failure_x_m=0.01"]),
        &["`domain.failure_x_m` = 0.01", "between success_x_m"],
    );
}

#[test]
fn malformed_set_and_files() {
    assert_contains(
        &err(&["domain.nx"]),
        &["--set domain.nx", "section.key=value"],
    );
    assert_contains(&err(&["nx=3"]), &["--set nx=3", "section.key=value"]);
    assert_contains(&err_file("[domain\nnx = 3\n"), &["is not valid TOML"]);
    match Config::load(Some(std::path::Path::new("/nonexistent/cfg.toml")), &[]) {
        Err(e) => assert_contains(
            &e.to_string(),
            &["cannot read config file /nonexistent/cfg.toml"],
        ),
        Ok(_) => panic!("missing file accepted"),
    }
}

#[test]
fn file_merges_over_default_and_set_over_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.toml");
    std::fs::write(&path, "[time]\nsubsteps = 40\n").unwrap();
    let r = Config::load(Some(&path), &["domain.ny=10".into()]).unwrap();
    assert_eq!(r.config.time.substeps, 40);
    assert_eq!(r.config.domain.ny, 10);
    assert_eq!(r.config.domain.nx, 1000); // from the default
}

#[test]
fn waveform_from_csv_relative_to_config_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("w.csv"),
        "t_s,u_m_per_s\n0.0,0.1\n0.5,0.3\n",
    )
    .unwrap();
    let path = dir.path().join("c.toml");
    std::fs::write(&path, "[inlet]\ncsv = \"w.csv\"\n").unwrap();
    let r = Config::load(Some(&path), &[]).unwrap();
    assert!((r.waveform.at(0.25) - 0.2).abs() < 1e-12);
}

#[test]
fn too_many_cells_across() {
    assert_contains(
        &err(&["domain.ny=257", "domain.height_m=0.0257"]),
        &["`domain.ny` = 257", "above 256"],
    );
}

#[test]
fn bad_swarms() {
    assert_contains(
        &err(&["swarm.count=65"]),
        &["`swarm.count` = 65", "above 64"],
    );
    assert_contains(
        &err(&["swarm.count=15"]),
        &["`swarm.count` = 15", "multiple of swarm.grid_rows = 2"],
    );
    assert_contains(
        &err(&["swarm.radius_m=0.0011"]),
        &["`swarm.radius_m`", "does not fit the channel height"],
    );
    assert_contains(
        &err(&["swarm.grid_spacing_m=0.0004"]),
        &["members 0 and 1", "overlap at reset"],
    );
    assert_contains(
        &err(&["swarm.grid_centre_x_m=0.003"]),
        &["member 0 at", "less than a radius from a wall or an end"],
    );
    assert_contains(
        &err(&["swarm.pinned=[3, 16]"]),
        &["`swarm.pinned` = 16", "not a member index (0..16)"],
    );
    assert_contains(
        &err(&["swarm.layout=explicit", "swarm.positions_m=[[0.05, 0.001]]"]),
        &[
            "`swarm.positions_m` = 1 entries",
            "one [x, y] per member (swarm.count = 16)",
        ],
    );
    assert_contains(
        &err(&["env.max_steps=0"]),
        &["`env.max_steps` = 0", "at least 1"],
    );
    assert_contains(
        &err(&["env.position_jitter_m=-1e-4"]),
        &["`env.position_jitter_m`", "non-negative"],
    );
    // A valid explicit swarm and a swarm-free channel load.
    Config::load(
        None,
        &[
            "swarm.count=2".into(),
            "swarm.layout=explicit".into(),
            "swarm.positions_m=[[0.05, 0.0005], [0.051, 0.0015]]".into(),
        ],
    )
    .unwrap();
    Config::load(
        None,
        &["swarm.count=0".into(), "swarm.grid_centre_x_m=-1.0".into()],
    )
    .unwrap();
}

#[test]
fn objective_weights_need_the_averaged_gradient_and_sensible_values() {
    let m = err(&["train.objective_weights=[9.0, 1.0, 1.0]"]);
    assert_contains(
        &m,
        &[
            "train.objective_weights",
            "train.pcgrad = false",
            "--no-pcgrad",
        ],
    );
    let m = err(&[
        "train.pcgrad=false",
        "train.objective_weights=[0.0, 0.0, 0.0]",
    ]);
    assert_contains(&m, &["train.objective_weights", "not all zero"]);
    let m = err(&[
        "train.pcgrad=false",
        "train.objective_weights=[1.0, -1.0, 0.0]",
    ]);
    assert_contains(&m, &["non-negative"]);
    let ok = Config::load(
        None,
        &[
            "train.pcgrad=false".into(),
            "train.objective_weights=[1.0, 0.0, 0.0]".into(),
        ],
    )
    .unwrap();
    assert_eq!(ok.config.train.objective_weights, [1.0, 0.0, 0.0]);
    let m = err(&["env.energy_reward=\"downstream\""]);
    assert_contains(&m, &["energy_reward", "upstream"]);
    let m = err(&["train.action_distribution=beta"]);
    assert_contains(&m, &["action_distribution", "gaussian", "tanh"]);
    let ok = Config::load(None, &["train.action_distribution=tanh".into()]).unwrap();
    assert_eq!(
        ok.config.train.action_distribution,
        fluxswarm_gpu::config::ActionDistribution::Tanh
    );
}

#[test]
fn an_actor_that_reads_the_phase_needs_a_critic_that_reads_it() {
    let m = err(&["train.actor_phase=true"]);
    assert_contains(&m, &["train.actor_phase", "train.critic_phase = true"]);
    Config::load(
        None,
        &[
            "train.actor_phase=true".into(),
            "train.critic_phase=true".into(),
        ],
    )
    .unwrap();
}
