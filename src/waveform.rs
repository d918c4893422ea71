//! Inlet waveform U(t): the centreline velocity (m/s) of the parabolic inlet profile,
//! periodic with period T, piecewise linear between control points (t_k, U_k), 0 <= t_k <= T.
//! Between the last point and T + t_0 it interpolates back to the first point.

use std::path::Path;

use thiserror::Error;

/// Why a waveform could not be built.
#[derive(Debug, Error)]
pub enum WaveformError {
    /// The period or the control points are invalid; the message says which.
    #[error("inlet waveform: {0}")]
    Invalid(String),
    /// The CSV file could not be read or parsed.
    #[error("inlet waveform CSV {path}: {message}")]
    Csv {
        /// Path of the CSV file.
        path: String,
        /// What is wrong with it.
        message: String,
    },
}

/// A periodic piecewise-linear waveform.
#[derive(Debug, Clone, PartialEq)]
pub struct Waveform {
    points: Vec<(f64, f64)>,
    period_s: f64,
}

impl Waveform {
    /// Checks the points (at least two, finite, strictly increasing t within [0, period]).
    pub fn new(points: Vec<(f64, f64)>, period_s: f64) -> Result<Self, WaveformError> {
        if !(period_s.is_finite() && period_s > 0.0) {
            return Err(WaveformError::Invalid(format!(
                "inlet.period_s = {period_s} must be a positive number of seconds"
            )));
        }
        if points.len() < 2 {
            return Err(WaveformError::Invalid(format!(
                "needs at least 2 control points, got {}",
                points.len()
            )));
        }
        for (k, &(t, u)) in points.iter().enumerate() {
            if !t.is_finite() || !u.is_finite() {
                return Err(WaveformError::Invalid(format!(
                    "control point {k} ({t}, {u}) is not finite"
                )));
            }
            if t < 0.0 || t > period_s {
                return Err(WaveformError::Invalid(format!(
                    "control point {k} has t = {t} s outside [0, period_s = {period_s}]"
                )));
            }
            if k > 0 && t <= points[k - 1].0 {
                return Err(WaveformError::Invalid(format!(
                    "control point times must increase strictly: point {k} has t = {t} s after {} s",
                    points[k - 1].0
                )));
            }
        }
        Ok(Self { points, period_s })
    }

    /// Reads control points from a CSV file with header `t_s,u_m_per_s`.
    pub fn from_csv(path: &Path, period_s: f64) -> Result<Self, WaveformError> {
        let err = |message: String| WaveformError::Csv {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(format!("cannot read: {e}")))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next().ok_or_else(|| err("file is empty".into()))?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        if names != ["t_s", "u_m_per_s"] {
            return Err(err(format!(
                "header must be `t_s,u_m_per_s`, found `{}`",
                header.trim()
            )));
        }
        let mut points = Vec::new();
        for (n, line) in lines.enumerate() {
            let cols: Vec<&str> = line.split(',').map(str::trim).collect();
            let parse = |s: &str| s.parse::<f64>().ok();
            match (cols.as_slice(), cols.first().and_then(|s| parse(s))) {
                ([_, u], Some(t)) if parse(u).is_some() => {
                    points.push((t, parse(u).unwrap_or(0.0)))
                }
                _ => {
                    return Err(err(format!(
                        "data row {} `{line}` is not two numbers `t_s,u_m_per_s`",
                        n + 1
                    )));
                }
            }
        }
        Self::new(points, period_s)
    }

    /// The same waveform with every velocity multiplied by `factor` (`inlet.scale`).
    pub fn scaled(mut self, factor: f64) -> Self {
        for p in &mut self.points {
            p.1 *= factor;
        }
        self
    }

    /// Period T (s).
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Control points (t (s), U (m/s)), in increasing t.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// Centreline velocity U(t) in m/s.
    pub fn at(&self, t: f64) -> f64 {
        let (t0, _) = self.points[0];
        // Phase measured from the first control point, in [t0, t0 + T).
        let phase = t0 + (t - t0).rem_euclid(self.period_s);
        let pts = &self.points;
        for w in pts.windows(2) {
            let ((ta, ua), (tb, ub)) = (w[0], w[1]);
            if phase >= ta && phase <= tb {
                return ua + (ub - ua) * (phase - ta) / (tb - ta);
            }
        }
        // Wrap segment: from the last point to the first point one period later.
        let (ta, ua) = pts[pts.len() - 1];
        let (tb, ub) = (t0 + self.period_s, pts[0].1);
        if tb - ta <= 0.0 {
            return ub;
        }
        let ph = if phase < ta {
            phase + self.period_s
        } else {
            phase
        };
        ua + (ub - ua) * (ph - ta) / (tb - ta)
    }

    /// U at the end of each of the `substeps` equal substeps of the control step of length
    /// `control_dt` that starts at `t0` (s), as the kernels' inlet buffer holds it (f32).
    pub fn substep_values(
        &self,
        t0: f64,
        control_dt: f64,
        substeps: usize,
    ) -> impl Iterator<Item = f32> + '_ {
        let dt_sub = control_dt / substeps as f64;
        (0..substeps).map(move |s| self.at(t0 + (s as f64 + 1.0) * dt_sub) as f32)
    }

    /// Largest |U| over a period (at a control point, since U is piecewise linear).
    pub fn peak_abs(&self) -> f64 {
        self.points.iter().map(|p| p.1.abs()).fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> Waveform {
        Waveform::new(
            vec![
                (0.0, 0.008),
                (0.03, 0.4),
                (0.12, 0.4),
                (0.15, -0.015),
                (0.25, -0.015),
                (0.26, 0.008),
                (1.0, 0.008),
            ],
            1.0,
        )
        .unwrap()
    }

    #[test]
    fn interpolates_control_points_and_midpoints() {
        let w = paper();
        assert!((w.at(0.0) - 0.008).abs() < 1e-12);
        assert!((w.at(0.015) - 0.204).abs() < 1e-12); // halfway up the systolic ramp
        assert!((w.at(0.1) - 0.4).abs() < 1e-12);
        assert!((w.at(0.135) - 0.1925).abs() < 1e-12);
        assert!((w.at(0.2) - -0.015).abs() < 1e-12);
        assert!((w.at(0.5) - 0.008).abs() < 1e-12);
        assert!((w.peak_abs() - 0.4).abs() < 1e-15);
    }

    #[test]
    fn is_periodic() {
        let w = paper();
        for t in [0.0, 0.01, 0.137, 0.255, 0.9] {
            assert!((w.at(t) - w.at(t + 3.0)).abs() < 1e-12);
            assert!((w.at(t) - w.at(t - 1.0)).abs() < 1e-12);
        }
    }

    #[test]
    fn wraps_between_last_and_first_point() {
        // Points that do not reach the period: linear from (0.5, 1) back to (1.0 + 0.0, 0).
        let w = Waveform::new(vec![(0.0, 0.0), (0.5, 1.0)], 1.0).unwrap();
        assert!((w.at(0.75) - 0.5).abs() < 1e-12);
        assert!((w.at(0.25) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn rejects_bad_points() {
        assert!(Waveform::new(vec![(0.0, 1.0)], 1.0).is_err());
        assert!(Waveform::new(vec![(0.0, 1.0), (0.0, 2.0)], 1.0).is_err());
        assert!(Waveform::new(vec![(0.0, 1.0), (2.0, 2.0)], 1.0).is_err());
        assert!(Waveform::new(vec![(0.0, 1.0), (0.5, f64::NAN)], 1.0).is_err());
        assert!(Waveform::new(vec![(0.0, 1.0), (0.5, 1.0)], 0.0).is_err());
    }

    #[test]
    fn reads_csv() {
        let dir = std::env::temp_dir().join(format!("fluxswarm-wave-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("w.csv");
        std::fs::write(&f, "t_s,u_m_per_s\n0,0.1\n0.5,0.3\n").unwrap();
        let w = Waveform::from_csv(&f, 1.0).unwrap();
        assert!((w.at(0.25) - 0.2).abs() < 1e-12);
        std::fs::write(&f, "time,u\n0,0.1\n").unwrap();
        let e = Waveform::from_csv(&f, 1.0).unwrap_err().to_string();
        assert!(e.contains("header must be `t_s,u_m_per_s`"), "{e}");
        std::fs::write(&f, "t_s,u_m_per_s\n0,abc\n").unwrap();
        let e = Waveform::from_csv(&f, 1.0).unwrap_err().to_string();
        assert!(e.contains("data row 1"), "{e}");
    }
}
