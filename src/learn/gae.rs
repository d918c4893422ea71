//! Generalised advantage estimation per (environment, agent, objective), masked at episode ends.
//!
//!   delta_t = r_t + gamma * boot_t * V_next_t - V_t,   boot_t = 0 if terminated or diverged
//!   A_t     = delta_t + gamma * lambda * cont_t * A_{t+1},   cont_t = 0 if the episode ended at t
//!   R_t     = A_t + V_t
//! V_next_t is the value of the state after step t in the same episode: V(s_{t+1}) while the
//! episode goes on, V(final observation) when it was truncated at t (the caller fills it in;
//! auto-reset means s_{t+1} belongs to a new episode). A diverged step is never bootstrapped.
//! Shapes: rewards, values, next_values `[T][E][N][K]`; flags `[T][E]`.

/// One rollout, flattened row-major with t outermost.
pub struct Rollout<'a> {
    /// Rollout length T (steps).
    pub steps: usize,
    /// Number of environments E.
    pub envs: usize,
    /// Number of agents N per environment.
    pub agents: usize,
    /// Number of objectives K.
    pub objectives: usize,
    /// Rewards r_t, `[T][E][N][K]`.
    pub rewards: &'a [f32],
    /// Values V(s_t), `[T][E][N][K]`.
    pub values: &'a [f32],
    /// Values of the state after step t in the same episode (V_next_t), `[T][E][N][K]`.
    pub next_values: &'a [f32],
    /// Episode terminated at step t (no bootstrap), `[T][E]`.
    pub terminated: &'a [bool],
    /// Episode truncated at step t (bootstrapped from `next_values`), `[T][E]`.
    pub truncated: &'a [bool],
    /// Environment diverged at step t (no bootstrap), `[T][E]`.
    pub diverged: &'a [bool],
}

/// Advantages and returns, both `[T][E][N][K]`.
pub fn gae(r: &Rollout, gamma: f32, lambda: f32) -> (Vec<f32>, Vec<f32>) {
    let per_step = r.envs * r.agents * r.objectives;
    let per_env = r.agents * r.objectives;
    let len = r.steps * per_step;
    assert!(
        r.rewards.len() == len && r.values.len() == len && r.next_values.len() == len,
        "rewards, values and next_values must be [T][E][N][K]"
    );
    assert!(r.terminated.len() == r.steps * r.envs && r.truncated.len() == r.steps * r.envs);
    assert!(r.diverged.len() == r.steps * r.envs);
    let mut adv = vec![0.0f32; len];
    let mut next_adv = vec![0.0f32; per_step];
    for t in (0..r.steps).rev() {
        for e in 0..r.envs {
            let f = t * r.envs + e;
            let no_bootstrap = r.terminated[f] || r.diverged[f];
            let ended = no_bootstrap || r.truncated[f];
            let boot = if no_bootstrap { 0.0 } else { 1.0 };
            let cont = if ended { 0.0 } else { 1.0 };
            for q in 0..per_env {
                let i = t * per_step + e * per_env + q;
                let delta = r.rewards[i] + gamma * boot * r.next_values[i] - r.values[i];
                let a = delta + gamma * lambda * cont * next_adv[e * per_env + q];
                adv[i] = a;
                next_adv[e * per_env + q] = a;
            }
        }
    }
    let returns = adv.iter().zip(r.values).map(|(a, v)| a + v).collect();
    (adv, returns)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_with_termination_and_truncation() {
        // One env, one agent, one objective; gamma = lambda = 0.5 (gamma * lambda = 0.25).
        // t:          0     1            2     3
        // r:          1     2            3     4
        // V:          0.5   1.0          0.2   0.4
        // V_next:     1.0   9 (ignored)  0.4   2.0 (value of the final observation)
        // ends:       -     terminated   -     truncated
        // delta3 = 4 + 0.5 * 2.0 - 0.4 = 4.6                  A3 = 4.6
        // delta2 = 3 + 0.5 * 0.4 - 0.2 = 3.0                  A2 = 3.0 + 0.25 * 4.6 = 4.15
        // delta1 = 2 + 0 - 1.0 = 1.0 (no bootstrap)           A1 = 1.0 (episode ended)
        // delta0 = 1 + 0.5 * 1.0 - 0.5 = 1.0                  A0 = 1.0 + 0.25 * 1.0 = 1.25
        let r = Rollout {
            steps: 4,
            envs: 1,
            agents: 1,
            objectives: 1,
            rewards: &[1.0, 2.0, 3.0, 4.0],
            values: &[0.5, 1.0, 0.2, 0.4],
            next_values: &[1.0, 9.0, 0.4, 2.0],
            terminated: &[false, true, false, false],
            truncated: &[false, false, false, true],
            diverged: &[false; 4],
        };
        let (a, ret) = gae(&r, 0.5, 0.5);
        let want = [1.25, 1.0, 4.15, 4.6];
        for k in 0..4 {
            assert!(
                (a[k] - want[k]).abs() < 1e-6,
                "A{k} = {} vs {}",
                a[k],
                want[k]
            );
        }
        let want_ret = [1.75, 2.0, 4.35, 5.0];
        for k in 0..4 {
            assert!((ret[k] - want_ret[k]).abs() < 1e-6);
        }
    }

    #[test]
    fn per_env_agent_objective_and_no_bootstrap_after_divergence() {
        // Two envs x two agents x two objectives, T = 2, gamma = 0.9, lambda = 1.
        // Env 1 diverges at t = 0: its t = 0 advantage is r - V (no bootstrap, no carry).
        let (t, e, n, k) = (2, 2, 2, 2);
        let len = t * e * n * k;
        let rewards: Vec<f32> = (0..len).map(|i| i as f32 * 0.1).collect();
        let values = vec![0.5f32; len];
        let next_values = vec![1.0f32; len];
        let r = Rollout {
            steps: t,
            envs: e,
            agents: n,
            objectives: k,
            rewards: &rewards,
            values: &values,
            next_values: &next_values,
            terminated: &[false; 4],
            truncated: &[false; 4],
            diverged: &[false, true, false, false],
        };
        let (a, _) = gae(&r, 0.9, 1.0);
        for q in 0..4 {
            // t = 1 (last step, ongoing): delta = r + 0.9 * 1.0 - 0.5.
            let i1_env0 = 8 + q;
            assert!((a[i1_env0] - (rewards[i1_env0] + 0.4)).abs() < 1e-6);
            // t = 0, env 0: delta0 + 0.9 * A1.
            let want = rewards[q] + 0.4 + 0.9 * a[8 + q];
            assert!((a[q] - want).abs() < 1e-6);
            // t = 0, env 1 diverged: r - V only.
            let i = 4 + q;
            assert!((a[i] - (rewards[i] - 0.5)).abs() < 1e-6, "A = {}", a[i]);
        }
    }
}
