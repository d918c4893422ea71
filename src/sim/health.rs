//! Per-environment health after a control step: the one small read-back of each step.
//! Layout of the GPU health buffer: `[E][2]` `vec4<f32>` (see `shaders/diagnostics.wgsl`).

/// Velocity magnitude above which an environment counts as diverged (m/s; SPEC section 3).
pub const DIVERGENCE_SPEED_M_S: f32 = 10.0;

/// Documented bound on the velocity divergence left after the projection, relative to the
/// grid's velocity-gradient scale: max |div u| <= DIV_TOLERANCE x U_peak / dx. The pressure
/// solve is exact up to f32 round-off (about 1e-6 of U_peak / dx is measured); the bound keeps
/// a margin for long runs and obstacles.
pub const DIV_TOLERANCE: f64 = 1e-4;

/// Health of one environment after a control step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnvHealth {
    /// Smallest and largest volume flux per unit depth over all cross-sections x = i dx (m^2/s).
    pub flux_min: f32,
    /// Largest volume flux per unit depth over all cross-sections (m^2/s).
    pub flux_max: f32,
    /// Largest |div u| over all cells after the projection (1/s).
    pub max_div: f32,
    /// Largest |u| or |v| on any face (m/s).
    pub max_speed: f32,
    /// Non-finite values among u, v, p and div u.
    pub nonfinite: u32,
    /// Largest |div u*| of the predicted field before the projection (1/s).
    pub div_before: f32,
    /// Flux through the inlet (m^2/s).
    pub inlet_flux: f32,
}

impl EnvHealth {
    /// Unpacks the two vec4 of the GPU health buffer for one environment.
    pub fn from_raw(raw: &[[f32; 4]; 2]) -> Self {
        let [a, b] = raw;
        Self {
            flux_min: a[0],
            flux_max: a[1],
            max_div: a[2],
            max_speed: a[3],
            nonfinite: b[0] as u32,
            div_before: b[1],
            inlet_flux: b[2],
        }
    }

    /// Relative residual of the pressure solve: max |div u| after / before the projection.
    pub fn residual(&self) -> f32 {
        if self.div_before > 0.0 {
            self.max_div / self.div_before
        } else {
            0.0
        }
    }

    /// No non-finite values, and finite max speed and flux.
    pub fn is_finite(&self) -> bool {
        self.nonfinite == 0 && self.max_speed.is_finite() && self.flux_min.is_finite()
    }

    /// Non-finite values or |u| above [`DIVERGENCE_SPEED_M_S`].
    pub fn diverged(&self) -> bool {
        !self.is_finite() || self.max_speed > DIVERGENCE_SPEED_M_S
    }
}
