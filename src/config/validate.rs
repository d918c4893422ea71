//! Validation of a merged configuration: every range, the swarm's layout, the waveform, the
//! explicit-diffusion number and the CFL number, each failure naming the key, the value and the
//! limit or the fix.

use super::{
    CFL_ROUNDING_ALLOWANCE, Config, ConfigError, Layout, MAX_CFL, MAX_DIFFUSION_NUMBER,
    MAX_MEMBERS, MAX_NY, Resolved,
};
use crate::waveform::Waveform;

impl Config {
    /// Validates every range and builds the waveform.
    pub fn resolve(self) -> Result<Resolved, ConfigError> {
        let d = &self.domain;
        positive("domain.length_m", d.length_m)?;
        positive("domain.height_m", d.height_m)?;
        at_least("domain.nx", d.nx, 4)?;
        at_least("domain.ny", d.ny, 2)?;
        if d.ny > MAX_NY {
            return Err(range(
                "domain.ny",
                d.ny,
                format!(
                    "is above {MAX_NY}, the most cells across the channel the solver holds per \
                     column: use a coarser grid across the height"
                ),
            ));
        }
        if !(d.success_x_m > 0.0 && d.success_x_m < d.length_m) {
            return Err(range(
                "domain.success_x_m",
                d.success_x_m,
                format!(
                    "must lie inside the channel, 0 < x < length_m = {}",
                    d.length_m
                ),
            ));
        }
        if !(d.failure_x_m > d.success_x_m && d.failure_x_m < d.length_m) {
            return Err(range(
                "domain.failure_x_m",
                d.failure_x_m,
                format!(
                    "must lie between success_x_m = {} and length_m = {}",
                    d.success_x_m, d.length_m
                ),
            ));
        }
        positive("fluid.density_kg_m3", self.fluid.density_kg_m3)?;
        positive("fluid.viscosity_pa_s", self.fluid.viscosity_pa_s)?;
        positive("time.control_dt_s", self.time.control_dt_s)?;
        at_least("time.substeps", self.time.substeps, 1)?;
        positive("inlet.period_s", self.inlet.period_s)?;
        positive("inlet.scale", self.inlet.scale)?;
        self.validate_swarm()?;
        at_least("env.max_steps", self.env.max_steps, 1)?;
        let tr = &self.train;
        at_least("train.rollout_steps", tr.rollout_steps, 1)?;
        at_least("train.epochs", tr.epochs, 1)?;
        at_least("train.minibatches", tr.minibatches, 1)?;
        for (key, v) in [("train.gamma", tr.gamma), ("train.lambda", tr.lambda)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(range(key, v, "must lie in [0, 1]".into()));
            }
        }
        let w = tr.objective_weights;
        if !(w.iter().all(|v| v.is_finite() && *v >= 0.0) && w.iter().sum::<f64>() > 0.0) {
            return Err(ConfigError::Range {
                key: "train.objective_weights".into(),
                value: format!("{w:?}"),
                message: "must be three non-negative weights, not all zero (progress, energy, \
                          smoothness)"
                    .into(),
            });
        }
        if tr.pcgrad && !(w[0] == w[1] && w[1] == w[2]) {
            return Err(ConfigError::Range {
                key: "train.objective_weights".into(),
                value: format!("{w:?}"),
                message: "weighs the summed actor gradients, which PCGrad does not use (it \
                          averages its projected gradients equally): set train.pcgrad = false \
                          (or --no-pcgrad) with unequal weights"
                    .into(),
            });
        }
        if tr.actor_phase && !tr.critic_phase {
            return Err(ConfigError::Range {
                key: "train.actor_phase".into(),
                value: "true".into(),
                message: "gives the actors the inlet phase, so the centralised critic must read                           it too: set train.critic_phase = true as well"
                    .into(),
            });
        }
        positive("train.learning_rate", tr.learning_rate)?;
        positive("train.clip", tr.clip)?;
        positive("train.max_grad_norm", tr.max_grad_norm)?;
        if !(tr.entropy_coef >= 0.0 && tr.entropy_coef.is_finite()) {
            return Err(range(
                "train.entropy_coef",
                tr.entropy_coef,
                "must be non-negative".into(),
            ));
        }
        if !(self.env.position_jitter_m >= 0.0 && self.env.position_jitter_m.is_finite()) {
            return Err(range(
                "env.position_jitter_m",
                self.env.position_jitter_m,
                "must be a non-negative, finite length".into(),
            ));
        }

        let waveform = match &self.inlet.csv {
            Some(path) => Waveform::from_csv(path, self.inlet.period_s)?,
            None => Waveform::new(
                self.inlet.points.iter().map(|p| (p[0], p[1])).collect(),
                self.inlet.period_s,
            )?,
        }
        .scaled(self.inlet.scale);

        let diffusion = self.diffusion_number();
        if diffusion > MAX_DIFFUSION_NUMBER {
            return Err(range(
                "time.substeps",
                self.time.substeps,
                format!(
                    "gives a diffusion number nu dt_sub (1/dx^2 + 1/dy^2) / 2 = {diffusion:.4}, above \
                     the explicit-diffusion limit {MAX_DIFFUSION_NUMBER}: raise time.substeps, lower \
                     time.control_dt_s or use a coarser grid"
                ),
            ));
        }
        let cfl = self.cfl_number(&waveform);
        if cfl > MAX_CFL * (1.0 + CFL_ROUNDING_ALLOWANCE) {
            return Err(range(
                "time.substeps",
                self.time.substeps,
                format!(
                    "gives a CFL number U_peak dt_sub / dx = {:.4} m/s x {:.4e} s / {:.4e} m = {cfl:.4}, \
                     above the limit {MAX_CFL}: raise time.substeps, lower time.control_dt_s or the \
                     inlet velocity, or use a coarser grid",
                    waveform.peak_abs(),
                    self.dt_sub(),
                    self.dx()
                ),
            ));
        }
        Ok(Resolved {
            config: self,
            waveform,
        })
    }

    fn validate_swarm(&self) -> Result<(), ConfigError> {
        let s = &self.swarm;
        let (length, height) = (self.domain.length_m, self.domain.height_m);
        if s.count > MAX_MEMBERS {
            return Err(range(
                "swarm.count",
                s.count,
                format!("is above {MAX_MEMBERS}, the most members one environment holds"),
            ));
        }
        if s.count == 0 {
            return Ok(());
        }
        positive("swarm.radius_m", s.radius_m)?;
        positive("swarm.density_kg_m3", s.density_kg_m3)?;
        positive("swarm.max_thrust_n", s.max_thrust_n)?;
        if 2.0 * s.radius_m >= height {
            return Err(range(
                "swarm.radius_m",
                s.radius_m,
                format!("gives a diameter that does not fit the channel height {height} m"),
            ));
        }
        if s.layout == Layout::Grid {
            at_least("swarm.grid_rows", s.grid_rows, 1)?;
            if !s.count.is_multiple_of(s.grid_rows) {
                return Err(range(
                    "swarm.count",
                    s.count,
                    format!("must be a multiple of swarm.grid_rows = {}", s.grid_rows),
                ));
            }
            positive("swarm.grid_spacing_m", s.grid_spacing_m)?;
        } else if s.positions_m.len() != s.count as usize {
            return Err(range(
                "swarm.positions_m",
                format!("{} entries", s.positions_m.len()),
                format!("needs one [x, y] per member (swarm.count = {})", s.count),
            ));
        }
        let r = s.radius_m;
        let pos = s.initial_positions(height);
        for (k, p) in pos.iter().enumerate() {
            if !(p[0] >= r && p[0] <= length - r && p[1] >= r && p[1] <= height - r) {
                return Err(range(
                    "swarm",
                    format!("member {k} at ({:.6}, {:.6}) m", p[0], p[1]),
                    format!(
                        "lies less than a radius from a wall or an end of the channel \
                         ({length} x {height} m): move the grid or the explicit positions"
                    ),
                ));
            }
            for (j, q) in pos.iter().enumerate().take(k) {
                if (p[0] - q[0]).hypot(p[1] - q[1]) < 2.0 * r {
                    return Err(range(
                        "swarm",
                        format!("members {j} and {k}"),
                        "overlap at reset: increase swarm.grid_spacing_m or move them".into(),
                    ));
                }
            }
        }
        if let Some(&bad) = s.pinned.iter().find(|&&i| i >= s.count) {
            return Err(range(
                "swarm.pinned",
                bad,
                format!("is not a member index (0..{})", s.count),
            ));
        }
        Ok(())
    }
}

fn range(key: &str, value: impl std::fmt::Display, message: String) -> ConfigError {
    ConfigError::Range {
        key: key.into(),
        value: value.to_string(),
        message,
    }
}

fn positive(key: &str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(range(
            key,
            value,
            "must be a positive, finite number".into(),
        ))
    }
}

fn at_least(key: &str, value: u32, min: u32) -> Result<(), ConfigError> {
    if value >= min {
        Ok(())
    } else {
        Err(range(key, value, format!("must be at least {min}")))
    }
}
