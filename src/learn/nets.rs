//! The networks of SPEC section 5, in candle.
//! Actor (shared by all agents): o_i [B, 8] -> 256 -> 256 (tanh) -> mean [B, 2], log_std [B, 2]
//! (log_std = MIN + (MAX - MIN) sigmoid(raw + ln(-MIN / MAX)): a smooth bound in [MIN, MAX] that is
//! 0 for a raw output of 0 and never loses its gradient, unlike a hard clamp, whose zero gradient
//! past the bound once left a run stuck at MAX).
//! Critic (centralised): joint state [B, N*8] -> 256 -> 256 (tanh) -> three linear heads of N
//! values each -> [B, 3, N] (progress, energy, smoothness).
//! Parameters are named through `VarBuilder::pp("actor")` / `pp("critic")`.

use candle_core::{Result, Tensor};
use candle_nn::{Linear, Module, VarBuilder, linear};

pub const HIDDEN: usize = 256;
pub const LOG_STD_MIN: f64 = -5.0;
pub const LOG_STD_MAX: f64 = 1.0;

pub struct Actor {
    l1: Linear,
    l2: Linear,
    head: Linear,
    action_dim: usize,
}

impl Actor {
    pub fn new(vb: VarBuilder, obs_dim: usize, action_dim: usize) -> Result<Self> {
        Ok(Self {
            l1: linear(obs_dim, HIDDEN, vb.pp("l1"))?,
            l2: linear(HIDDEN, HIDDEN, vb.pp("l2"))?,
            head: linear(HIDDEN, 2 * action_dim, vb.pp("head"))?,
            action_dim,
        })
    }

    /// (mean, log_std), each [B, action_dim], for observations [B, obs_dim].
    pub fn forward(&self, obs: &Tensor) -> Result<(Tensor, Tensor)> {
        let h = self.l2.forward(&self.l1.forward(obs)?.tanh()?)?.tanh()?;
        let out = self.head.forward(&h)?;
        let mean = out.narrow(1, 0, self.action_dim)?;
        let raw = out.narrow(1, self.action_dim, self.action_dim)?;
        let shift = (-LOG_STD_MIN / LOG_STD_MAX).ln();
        let log_std = candle_nn::ops::sigmoid(&raw.affine(1.0, shift)?)?
            .affine(LOG_STD_MAX - LOG_STD_MIN, LOG_STD_MIN)?;
        Ok((mean, log_std))
    }
}

pub struct Critic {
    l1: Linear,
    l2: Linear,
    heads: [Linear; 3],
}

impl Critic {
    pub fn new(vb: VarBuilder, agents: usize, obs_dim: usize) -> Result<Self> {
        Ok(Self {
            l1: linear(agents * obs_dim, HIDDEN, vb.pp("l1"))?,
            l2: linear(HIDDEN, HIDDEN, vb.pp("l2"))?,
            heads: [
                linear(HIDDEN, agents, vb.pp("progress"))?,
                linear(HIDDEN, agents, vb.pp("energy"))?,
                linear(HIDDEN, agents, vb.pp("smoothness"))?,
            ],
        })
    }

    /// Values [B, 3, N] for joint states [B, N*obs_dim].
    pub fn forward(&self, state: &Tensor) -> Result<Tensor> {
        let h = self.l2.forward(&self.l1.forward(state)?.tanh()?)?.tanh()?;
        let heads: Vec<Tensor> = self
            .heads
            .iter()
            .map(|l| l.forward(&h))
            .collect::<Result<_>>()?;
        Tensor::stack(&heads, 1)
    }
}

/// Log-density of raw samples under N(mean, exp(log_std)), summed over the last dimension:
/// [.., D] -> [..].
pub fn gaussian_log_prob(x: &Tensor, mean: &Tensor, log_std: &Tensor) -> Result<Tensor> {
    let z = ((x - mean)? / log_std.exp()?)?;
    let half_ln_2pi = 0.5 * (2.0 * std::f64::consts::PI).ln();
    let per_dim = ((z.sqr()? * -0.5)? - log_std)?.affine(1.0, -half_ln_2pi)?;
    per_dim.sum(candle_core::D::Minus1)
}

/// Entropy of N(mean, exp(log_std)) summed over the last dimension.
pub fn gaussian_entropy(log_std: &Tensor) -> Result<Tensor> {
    let c = 0.5 + 0.5 * (2.0 * std::f64::consts::PI).ln();
    log_std.affine(1.0, c)?.sum(candle_core::D::Minus1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::{DType, Device};
    use candle_nn::VarMap;

    #[test]
    fn critic_has_three_heads_of_n_values_and_the_actor_is_shared() {
        let dev = Device::Cpu;
        let (n, b) = (16, 5);
        let vm = VarMap::new();
        let vb = VarBuilder::from_varmap(&vm, DType::F32, &dev);
        let actor = Actor::new(vb.pp("actor"), 8, 2).unwrap();
        let critic = Critic::new(vb.pp("critic"), n, 8).unwrap();
        let state = Tensor::randn(0f32, 1.0, (b, n * 8), &dev).unwrap();
        assert_eq!(critic.forward(&state).unwrap().dims(), &[b, 3, n]);
        // One actor for every agent: its parameters do not depend on N, and an agent's output
        // depends only on its own observation (rows are independent).
        let actor_params: usize = vm
            .data()
            .lock()
            .unwrap()
            .iter()
            .filter(|(k, _)| k.starts_with("actor"))
            .map(|(_, v)| v.elem_count())
            .sum();
        assert_eq!(actor_params, 8 * 256 + 256 + 256 * 256 + 256 + 256 * 4 + 4);
        let obs = Tensor::randn(0f32, 1.0, (n, 8), &dev).unwrap();
        let (m_all, s_all) = actor.forward(&obs).unwrap();
        let (m_one, s_one) = actor.forward(&obs.narrow(0, 3, 1).unwrap()).unwrap();
        let row: Vec<f32> = m_all
            .narrow(0, 3, 1)
            .unwrap()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        let one: Vec<f32> = m_one.flatten_all().unwrap().to_vec1().unwrap();
        // Equal up to f32 rounding (the matrix product blocks differently for 1 and 16 rows).
        for (a, b) in row.iter().zip(&one) {
            assert!(
                (a - b).abs() <= 1e-5 * (1.0 + b.abs()),
                "{row:?} vs {one:?}"
            );
        }
        let s: Vec<f32> = s_all.flatten_all().unwrap().to_vec1().unwrap();
        assert!(
            s.iter()
                .all(|&x| (LOG_STD_MIN as f32..=LOG_STD_MAX as f32).contains(&x))
        );
        assert_eq!(s_one.dims(), &[1, 2]);
    }

    #[test]
    fn tensor_log_prob_and_entropy_match_the_closed_forms() {
        let dev = Device::Cpu;
        let x = Tensor::new(&[[3.0f64, 0.0], [1.0, -2.0]], &dev).unwrap();
        let mean = Tensor::new(&[[1.0f64, 0.0], [0.0, 0.5]], &dev).unwrap();
        let ls = Tensor::new(&[[2f64.ln(), 0.0], [0.3, -0.7]], &dev).unwrap();
        let got: Vec<f64> = gaussian_log_prob(&x, &mean, &ls)
            .unwrap()
            .to_vec1()
            .unwrap();
        let want = [
            crate::learn::gaussian::log_prob(&[3.0, 0.0], &[1.0, 0.0], &[2f64.ln(), 0.0]),
            crate::learn::gaussian::log_prob(&[1.0, -2.0], &[0.0, 0.5], &[0.3, -0.7]),
        ];
        for k in 0..2 {
            assert!((got[k] - want[k]).abs() < 1e-12, "{got:?} vs {want:?}");
        }
        let ent: Vec<f64> = gaussian_entropy(&ls).unwrap().to_vec1().unwrap();
        assert!((ent[1] - crate::learn::gaussian::entropy(&[0.3, -0.7])).abs() < 1e-12);
    }
}
