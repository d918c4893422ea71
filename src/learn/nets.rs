//! The networks of SPEC section 5, in candle.
//! Actor (shared by all agents): o_i [B, 8] -> 256 -> 256 (tanh) -> mean [B, 2], log_std [B, 2]
//! (log_std = MIN + (MAX - MIN) sigmoid(raw + ln(-MIN / MAX)): a smooth bound in [MIN, MAX] that is
//! 0 for a raw output of 0 and never loses its gradient, unlike a hard clamp, whose zero gradient
//! past the bound once left a run stuck at MAX).
//! Critic (centralised): joint state [B, N*8 + G] (the joint observations, then G global-state
//! inputs such as the inlet phase; G = 0 by default) -> 256 -> 256 (tanh) -> three linear heads of N
//! values each -> [B, 3, N] (progress, energy, smoothness).
//! Parameters are named through `VarBuilder::pp("actor")` / `pp("critic")`.
//! The learner trains with the same networks written out by hand on f32 slices
//! ([`super::mlp`]); these candle versions are the reference its tests hold them to, and
//! [`Actor::backward`] runs the hand-written backward pass (batched over several losses) on
//! this network, so that a test holds it against candle's autograd.

use candle_core::{Result, Tensor};
use candle_nn::{Linear, Module, VarBuilder, linear};

use super::mlp;

/// Width of both hidden layers of the actor and the critic.
pub const HIDDEN: usize = 256;
/// Lower bound of the actor's log σ.
pub const LOG_STD_MIN: f64 = -5.0;
/// Upper bound of the actor's log σ.
pub const LOG_STD_MAX: f64 = 1.0;

/// The actor in candle: observations [B, obs_dim] -> Gaussian mean and log σ [B, action_dim].
pub struct Actor {
    l1: Linear,
    l2: Linear,
    head: Linear,
    action_dim: usize,
}

/// One actor forward pass with the activations its backward pass needs.
pub struct ActorPass {
    /// Observations [B, obs_dim] and the two hidden layers' tanh outputs [B, HIDDEN].
    x: Tensor,
    h1: Tensor,
    h2: Tensor,
    /// [B, action_dim] each.
    pub mean: Tensor,
    /// Bounded log σ [B, action_dim].
    pub log_std: Tensor,
}

impl ActorPass {
    /// The same activations as plain row-major vectors, for [`mlp::actor::backward`].
    pub fn to_acts(&self) -> Result<mlp::actor::ActorActs> {
        let flat = |t: &Tensor| -> Result<Vec<f32>> {
            t.flatten_all()?
                .to_dtype(candle_core::DType::F32)?
                .to_vec1()
        };
        Ok(mlp::actor::ActorActs {
            rows: self.x.dim(0)?,
            x: flat(&self.x)?,
            h1: flat(&self.h1)?,
            h2: flat(&self.h2)?,
            mean: flat(&self.mean)?,
            log_std: flat(&self.log_std)?,
        })
    }
}

impl Actor {
    /// The actor's layers `l1`, `l2`, `head` under `vb`.
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
        self.split_head(&self.head.forward(&h)?)
    }

    /// [`Self::forward`], keeping the activations for [`Self::backward`].
    pub fn forward_pass(&self, obs: &Tensor) -> Result<ActorPass> {
        let h1 = self.l1.forward(obs)?.tanh()?;
        let h2 = self.l2.forward(&h1)?.tanh()?;
        let (mean, log_std) = self.split_head(&self.head.forward(&h2)?)?;
        Ok(ActorPass {
            x: obs.clone(),
            h1,
            h2,
            mean,
            log_std,
        })
    }

    /// The gradients of K losses at once, by hand-written back-propagation. The losses are
    /// built from U sets of per-row output gradients, `d_mean`, `d_log_std` [U, B, action_dim],
    /// weighted per sample by `weights` [K, U, S] (the B rows are S samples of B / S rows each,
    /// in order): d loss_k / d output of row r = sum_u weights[k, u, s(r)] (d_mean, d_log_std)[u, r].
    ///
    /// This is the learner's own backward pass ([`crate::learn::mlp::actor::backward`], on
    /// f32 slices) run on this network's parameters and `pass`, so that the tests can hold it
    /// against candle's autograd. Returns each parameter's K gradients [K, ..shape], named as
    /// the parameters under the actor's prefix and in name order: head.bias, head.weight,
    /// l1.bias, l1.weight, l2.bias, l2.weight.
    pub fn backward(
        &self,
        pass: &ActorPass,
        d_mean: &Tensor,
        d_log_std: &Tensor,
        weights: &Tensor,
    ) -> Result<Vec<(&'static str, Tensor)>> {
        let (u, b, _) = d_mean.dims3()?;
        let (k, _, s) = weights.dims3()?;
        if weights.dim(1)? != u || s == 0 || b % s != 0 {
            candle_core::bail!(
                "weights {:?} do not fit {u} sets of {b} rows",
                weights.dims()
            );
        }
        let flat = |t: &Tensor| -> Result<Vec<f32>> {
            t.flatten_all()?
                .to_dtype(candle_core::DType::F32)?
                .to_vec1()
        };
        let layout = mlp::actor::layout(self.l1.weight().dim(1)?, self.action_dim);
        let mut p = Vec::with_capacity(layout.len());
        for (name, _) in layout.params() {
            let layer = match name.split('.').next() {
                Some("head") => &self.head,
                Some("l1") => &self.l1,
                _ => &self.l2,
            };
            let t = if name.ends_with("bias") {
                layer.bias().expect("linear layers have biases")
            } else {
                layer.weight()
            };
            p.extend(flat(t)?);
        }
        let acts = pass.to_acts()?;
        let w = flat(weights)?;
        let weights = mlp::Weights {
            w: &w,
            losses: k,
            sets: u,
            samples: s,
        };
        let grads = mlp::actor::backward(
            &layout,
            &p,
            &acts,
            &flat(d_mean)?,
            &flat(d_log_std)?,
            weights,
        );
        let dev = d_mean.device();
        layout
            .params()
            .iter()
            .map(|(name, shape)| {
                let slot = layout.slot(name);
                let per: Vec<f32> = grads
                    .iter()
                    .flat_map(|g| g[slot.clone()].to_vec())
                    .collect();
                let dims: Vec<usize> = std::iter::once(k).chain(shape.iter().copied()).collect();
                Ok((*name, Tensor::from_vec(per, dims, dev)?))
            })
            .collect()
    }

    fn split_head(&self, out: &Tensor) -> Result<(Tensor, Tensor)> {
        let mean = out.narrow(1, 0, self.action_dim)?;
        let raw = out.narrow(1, self.action_dim, self.action_dim)?;
        let shift = (-LOG_STD_MIN / LOG_STD_MAX).ln();
        let log_std = candle_nn::ops::sigmoid(&raw.affine(1.0, shift)?)?
            .affine(LOG_STD_MAX - LOG_STD_MIN, LOG_STD_MIN)?;
        Ok((mean, log_std))
    }
}

/// The centralised critic in candle: joint states [B, N*obs_dim] -> values [B, 3, N].
pub struct Critic {
    l1: Linear,
    l2: Linear,
    heads: [Linear; 3],
}

impl Critic {
    /// The critic's layers `l1`, `l2` and the three heads under `vb`, for `agents` agents and
    /// `global_dim` global-state inputs after their joint observations.
    pub fn new(vb: VarBuilder, agents: usize, obs_dim: usize, global_dim: usize) -> Result<Self> {
        Ok(Self {
            l1: linear(agents * obs_dim + global_dim, HIDDEN, vb.pp("l1"))?,
            l2: linear(HIDDEN, HIDDEN, vb.pp("l2"))?,
            heads: [
                linear(HIDDEN, agents, vb.pp("progress"))?,
                linear(HIDDEN, agents, vb.pp("energy"))?,
                linear(HIDDEN, agents, vb.pp("smoothness"))?,
            ],
        })
    }

    /// Values [B, 3, N] for joint states [B, N*obs_dim + global_dim].
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
        let critic = Critic::new(vb.pp("critic"), n, 8, 0).unwrap();
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

    #[test]
    fn the_batched_backward_pass_matches_autograd_for_each_loss() {
        let dev = Device::Cpu;
        let vm = VarMap::new();
        let vb = VarBuilder::from_varmap(&vm, DType::F32, &dev);
        let actor = Actor::new(vb.pp("actor"), 8, 2).unwrap();
        // Two sets of row gradients, 3 losses, 4 samples of 3 rows.
        let (u, k, samples, rows) = (2, 3, 4, 12);
        // Raw outputs of +-3 put some log σ near their bounds, where the sigmoid saturates.
        let obs = Tensor::randn(0f32, 3.0, (rows, 8), &dev).unwrap();
        let d_mean = Tensor::randn(0f32, 1.0, (u, rows, 2), &dev).unwrap();
        let d_log_std = Tensor::randn(0f32, 1.0, (u, rows, 2), &dev).unwrap();
        let weights = Tensor::randn(0f32, 1.0, (k, u, samples), &dev).unwrap();
        let pass = actor.forward_pass(&obs).unwrap();
        let grads = actor
            .backward(&pass, &d_mean, &d_log_std, &weights)
            .unwrap();
        let mut vars: Vec<(String, candle_core::Var)> = vm
            .data()
            .lock()
            .unwrap()
            .iter()
            .map(|(n, v)| (n.clone(), v.clone()))
            .collect();
        vars.sort_by(|a, b| a.0.cmp(&b.0));
        assert_eq!(vars.len(), grads.len());
        for o in 0..k {
            // loss_o = sum_u sum_r w[o, u, s(r)] (d_mean[u, r] . mean[r] + d_log_std[u, r] .
            // log_std[r]): its gradient with respect to row r's outputs is the weighted sum of
            // the sets' (d_mean, d_log_std) that `backward` is given.
            let (mean, log_std) = actor.forward(&obs).unwrap();
            let w_rows = weights
                .get(o)
                .unwrap()
                .unsqueeze(2)
                .unwrap()
                .broadcast_as((u, samples, rows / samples))
                .unwrap()
                .reshape((u, rows, 1))
                .unwrap();
            let up_mean = d_mean.broadcast_mul(&w_rows).unwrap().sum(0).unwrap();
            let up_log_std = d_log_std.broadcast_mul(&w_rows).unwrap().sum(0).unwrap();
            let loss = ((mean * up_mean).unwrap().sum_all().unwrap()
                + (log_std * up_log_std).unwrap().sum_all().unwrap())
            .unwrap();
            let auto = loss.backward().unwrap();
            for ((name, var), (suffix, g)) in vars.iter().zip(&grads) {
                assert_eq!(name, &format!("actor.{suffix}"));
                let want: Vec<f32> = auto
                    .get(var.as_tensor())
                    .unwrap()
                    .flatten_all()
                    .unwrap()
                    .to_vec1()
                    .unwrap();
                let got: Vec<f32> = g.get(o).unwrap().flatten_all().unwrap().to_vec1().unwrap();
                assert_eq!(got.len(), want.len(), "{name}");
                let scale = want.iter().fold(0f32, |m, x| m.max(x.abs()));
                for (a, b) in got.iter().zip(&want) {
                    assert!(
                        (a - b).abs() <= 1e-5 * scale.max(1.0),
                        "{name}, loss {o}: {a} vs {b}"
                    );
                }
            }
        }
    }
}
