//! The per-agent rewards of SPEC section 3 (pure functions) and the swarm metrics.
//!
//! Delta = (x_{t-1} - x_t) / (x_f - x_s) (upstream displacement positive);
//! progress = +10 if x_t < x_s, -10 if x_t > x_f, else 100 tanh(3 Delta) / tanh(3) - 0.01 for
//! Delta < 0 and 100 Delta - 0.01 for Delta >= 0;
//! energy = F . dr / (F_max |dr|) (0 if dr = 0), or with `env.energy_reward = "upstream"`
//! F_x min(dr_x, 0) / (F_max |dr|), the work towards upstream motion only; smoothness =
//! cos(a_{t-1}, a_t) (1 on the first step and when either action is zero).

/// Progress reward of one agent.
pub fn progress(x_prev: f64, x_now: f64, x_success: f64, x_failure: f64) -> f64 {
    if x_now < x_success {
        return 10.0;
    }
    if x_now > x_failure {
        return -10.0;
    }
    let delta = (x_prev - x_now) / (x_failure - x_success);
    if delta < 0.0 {
        100.0 * (3.0 * delta).tanh() / 3f64.tanh() - 0.01
    } else {
        100.0 * delta - 0.01
    }
}

/// Energy reward: the applied force's alignment with the displacement it produced.
pub fn energy(force: [f64; 2], dr: [f64; 2], f_max: f64) -> f64 {
    let len = dr[0].hypot(dr[1]);
    if len == 0.0 {
        return 0.0;
    }
    (force[0] * dr[0] + force[1] * dr[1]) / (f_max * len)
}

/// Upstream-only energy reward: the part of the force's work that went into upstream (-x)
/// motion, F_x min(dr_x, 0) / (F_max |dr|), in [-1, 1]: thrusting upstream while moving
/// upstream earns it, being carried downstream earns nothing whatever the force, and pushing
/// downstream while moving upstream costs.
pub fn energy_upstream(force: [f64; 2], dr: [f64; 2], f_max: f64) -> f64 {
    let len = dr[0].hypot(dr[1]);
    if len == 0.0 {
        return 0.0;
    }
    force[0] * dr[0].min(0.0) / (f_max * len)
}

/// Smoothness reward: cosine between consecutive applied actions.
pub fn smoothness(previous: Option<[f64; 2]>, action: [f64; 2]) -> f64 {
    let Some(prev) = previous else {
        return 1.0;
    };
    let (a, b) = (prev[0].hypot(prev[1]), action[0].hypot(action[1]));
    if a == 0.0 || b == 0.0 {
        return 1.0;
    }
    (prev[0] * action[0] + prev[1] * action[1]) / (a * b)
}

/// x_COM, y_COM, sigma_x, sigma_y, R_g of member centres (same unit as the input).
pub fn swarm_metrics(positions: &[[f64; 2]]) -> [f64; 5] {
    let n = positions.len().max(1) as f64;
    let (mx, my) = positions
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p[0] / n, a.1 + p[1] / n));
    let (vx, vy) = positions.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p[0] - mx).powi(2) / n, a.1 + (p[1] - my).powi(2) / n)
    });
    [mx, my, vx.sqrt(), vy.sqrt(), (vx + vy).sqrt()]
}

#[cfg(test)]
mod tests {
    use super::*;

    const XS: f64 = 0.02;
    const XF: f64 = 0.08;

    #[test]
    fn progress_by_hand() {
        // 0.6 mm upstream: Delta = 0.01 -> 100 * 0.01 - 0.01 = 0.99.
        assert!((progress(0.0500, 0.0494, XS, XF) - 0.99).abs() < 1e-9);
        // 0.6 mm downstream: 100 tanh(-0.03) / tanh(3) - 0.01 = -3.02401 (python: math.tanh)
        let want = 100.0 * (-0.03f64).tanh() / 3f64.tanh() - 0.01;
        assert!((progress(0.0494, 0.0500, XS, XF) - want).abs() < 1e-12);
        assert!((want + 3.02401).abs() < 1e-5);
        // No displacement costs the time penalty only.
        assert!((progress(0.05, 0.05, XS, XF) + 0.01).abs() < 1e-15);
        // Past the lines.
        assert_eq!(progress(0.0201, 0.0199, XS, XF), 10.0);
        assert_eq!(progress(0.0799, 0.0801, XS, XF), -10.0);
    }

    #[test]
    fn energy_by_hand() {
        let f = 850e-9;
        assert!((energy([-f, 0.0], [-1e-4, 0.0], f) - 1.0).abs() < 1e-12);
        assert!((energy([-f, 0.0], [1e-4, 0.0], f) + 1.0).abs() < 1e-12);
        assert!((energy([0.0, f / 2.0], [3e-5, 4e-5], f) - 0.4).abs() < 1e-12);
        assert_eq!(energy([f, 0.0], [0.0, 0.0], f), 0.0);
        assert_eq!(energy([0.0, 0.0], [1e-4, 0.0], f), 0.0);
    }

    #[test]
    fn upstream_energy_by_hand() {
        let f = 8.5e-7;
        // Full upstream thrust, moving straight upstream: 1.
        assert!((energy_upstream([-f, 0.0], [-1e-4, 0.0], f) - 1.0).abs() < 1e-12);
        // Carried downstream, pushing downstream (the paper's energy pays 1): nothing.
        assert_eq!(energy_upstream([f, 0.0], [1e-4, 0.0], f), 0.0);
        assert!((energy([f, 0.0], [1e-4, 0.0], f) - 1.0).abs() < 1e-12);
        // Half thrust upstream, moving up-and-across (-3, 4): 0.5 * 3 / 5.
        assert!((energy_upstream([-f / 2.0, 0.0], [-3e-5, 4e-5], f) - 0.3).abs() < 1e-12);
        // Pushing downstream while moving upstream costs: -1 * 3 / 5.
        assert!((energy_upstream([f, 0.0], [-3e-5, 4e-5], f) + 0.6).abs() < 1e-12);
        // A wall-ward push does no upstream work.
        assert_eq!(energy_upstream([0.0, f], [-1e-4, 1e-4], f), 0.0);
        assert_eq!(energy_upstream([f, 0.0], [0.0, 0.0], f), 0.0);
    }

    #[test]
    fn smoothness_by_hand() {
        assert_eq!(smoothness(None, [1.0, 0.0]), 1.0);
        assert_eq!(smoothness(Some([0.0, 0.0]), [1.0, 0.0]), 1.0);
        assert_eq!(smoothness(Some([1.0, 0.0]), [0.0, 0.0]), 1.0);
        assert!((smoothness(Some([1.0, 0.0]), [0.0, 2.0])).abs() < 1e-15);
        assert!((smoothness(Some([1.0, 0.0]), [-3.0, 0.0]) + 1.0).abs() < 1e-15);
        assert!((smoothness(Some([1.0, 1.0]), [1.0, 0.0]) - 0.5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn swarm_metrics_by_hand() {
        let m = swarm_metrics(&[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0]]);
        assert_eq!(m, [1.0, 1.0, 1.0, 1.0, 2f64.sqrt()]);
    }
}
