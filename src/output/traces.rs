//! The per-step tables of `rollout` and `eval` (SPEC section 7), one writer each:
//! - `starts.csv`: one row per episode start: its inlet phase (s), the inlet velocity (m/s) and
//!   the swarm's x centre (mm);
//! - `swarm.csv`: one row per environment and control step: time, inlet velocity and the swarm
//!   metrics (centre, spread and radius of gyration, mm);
//! - `trajectories.csv`: one row per member and control step: position (mm), velocity (mm/s),
//!   the action and each force on it (nN);
//! - `gap.csv` (`rollout --gap`): one row per environment and control step: the flow past the
//!   swarm (`crate::sim::gap`): the swarm's x extent (mm), the peak fluid u_x in it (m/s)
//!   and the mean and largest blocked fraction of its columns.

use std::io::{BufWriter, Write};
use std::path::Path;

use crate::gpu::params::{GpuMember, GpuMemberDiag};

/// The columns of `starts.csv`.
pub const STARTS_COLUMNS: &str = "env,episode,start_phase_s,start_inlet_u_m_s,start_x_com_mm";
/// The columns of `swarm.csv`.
pub const SWARM_COLUMNS: &str =
    "env,episode,step,t_s,inlet_u_m_s,x_com_mm,y_com_mm,sigma_x_mm,sigma_y_mm,r_g_mm";
/// The columns of `trajectories.csv`.
pub const TRAJECTORIES_COLUMNS: &str = "env,episode,step,member,x_mm,y_mm,vx_mm_s,vy_mm_s,ax,ay,f_prop_x_nN,f_prop_y_nN,f_hydro_x_nN,f_hydro_y_nN,f_drag_x_nN,f_drag_y_nN,f_contact_x_nN,f_contact_y_nN";

/// The columns of `gap.csv`.
pub const GAP_COLUMNS: &str =
    "env,episode,step,t_s,inlet_u_m_s,x_lo_mm,x_hi_mm,peak_u_m_s,mean_blocked,max_blocked";

type File = BufWriter<std::fs::File>;

fn create(dir: &Path, name: &str, columns: &str) -> std::io::Result<File> {
    let mut out = BufWriter::new(std::fs::File::create(dir.join(name))?);
    writeln!(out, "{columns}")?;
    Ok(out)
}

/// Where (environment, episode, step) a row belongs.
#[derive(Debug, Clone, Copy)]
pub struct RowKey {
    /// Environment index.
    pub env: usize,
    /// Episode index within the environment.
    pub episode: u64,
    /// Control step within the episode (0: its start).
    pub step: u32,
}

/// A member's position in mm.
pub fn position_mm(m: &GpuMember) -> [f64; 2] {
    [m.pos[0] as f64 * 1e3, m.pos[1] as f64 * 1e3]
}

/// `starts.csv`.
pub struct StartsCsv(File);

impl StartsCsv {
    /// Creates `dir/starts.csv` with its header.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        create(dir, "starts.csv", STARTS_COLUMNS).map(Self)
    }

    /// One episode's start.
    pub fn write(
        &mut self,
        env: usize,
        episode: u64,
        phase_s: f64,
        inlet_u_m_s: f64,
        x_com_mm: f64,
    ) -> std::io::Result<()> {
        writeln!(
            self.0,
            "{env},{episode},{phase_s:.6},{inlet_u_m_s:.6},{x_com_mm:.5}"
        )
    }

    /// Writes what is buffered.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// `swarm.csv`.
pub struct SwarmCsv(File);

impl SwarmCsv {
    /// Creates `dir/swarm.csv` with its header.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        create(dir, "swarm.csv", SWARM_COLUMNS).map(Self)
    }

    /// One environment at one step: the time `t_s`, the inlet velocity and the swarm metrics
    /// `[x_com, y_com, sigma_x, sigma_y, r_g]` in mm.
    pub fn write(
        &mut self,
        at: RowKey,
        t_s: f64,
        inlet_u_m_s: f64,
        metrics_mm: [f64; 5],
    ) -> std::io::Result<()> {
        let [xc, yc, sx, sy, rg] = metrics_mm;
        writeln!(
            self.0,
            "{},{},{},{t_s:.4},{inlet_u_m_s:.6},{xc:.5},{yc:.5},{sx:.5},{sy:.5},{rg:.5}",
            at.env, at.episode, at.step
        )
    }

    /// Writes what is buffered.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// `trajectories.csv`.
pub struct TrajectoriesCsv(File);

impl TrajectoriesCsv {
    /// Creates `dir/trajectories.csv` with its header.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        create(dir, "trajectories.csv", TRAJECTORIES_COLUMNS).map(Self)
    }

    /// Every member of one environment at one step: members, forces and actions are `[N]`.
    pub fn write(
        &mut self,
        at: RowKey,
        members: &[GpuMember],
        forces: &[GpuMemberDiag],
        actions: &[[f32; 2]],
    ) -> std::io::Result<()> {
        let nn = |v: f32| v as f64 * 1e9;
        for (i, ((m, d), a)) in members.iter().zip(forces).zip(actions).enumerate() {
            let [x, y] = position_mm(m);
            writeln!(
                self.0,
                "{},{},{},{i},{x:.5},{y:.5},{:.4},{:.4},{:.5},{:.5},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
                at.env,
                at.episode,
                at.step,
                m.vel[0] as f64 * 1e3,
                m.vel[1] as f64 * 1e3,
                a[0],
                a[1],
                nn(d.prop[0]),
                nn(d.prop[1]),
                nn(d.hydro[0]),
                nn(d.hydro[1]),
                nn(d.drag[0]),
                nn(d.drag[1]),
                nn(d.contact[0]),
                nn(d.contact[1]),
            )?;
        }
        Ok(())
    }

    /// Writes what is buffered.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// `gap.csv`.
pub struct GapCsv(File);

impl GapCsv {
    /// Creates `dir/gap.csv` with its header.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        create(dir, "gap.csv", GAP_COLUMNS).map(Self)
    }

    /// The flow past one environment's swarm at one step.
    pub fn write(
        &mut self,
        at: RowKey,
        t_s: f64,
        inlet_u_m_s: f64,
        gap: &crate::sim::gap::GapMetrics,
    ) -> std::io::Result<()> {
        writeln!(
            self.0,
            "{},{},{},{t_s:.4},{inlet_u_m_s:.6},{:.4},{:.4},{:.6},{:.4},{:.4}",
            at.env,
            at.episode,
            at.step,
            gap.x_lo_m * 1e3,
            gap.x_hi_m * 1e3,
            gap.peak_u_m_s,
            gap.mean_blocked,
            gap.max_blocked
        )
    }

    /// Writes what is buffered.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}
