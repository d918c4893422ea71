//! The critic by hand (SPEC section 5; [`crate::learn::nets::Critic`] is the same network in
//! candle): joint states x [B, N obs + G] -> 256 -> 256 (tanh) -> three heads of N values
//! (progress, energy, smoothness) -> v [B, 3, N].
//!
//! Its loss ([`value_loss_grad`]) is 0.5 x the sum of the three heads' MSE against returns
//! R [B, N, 3], i.e. 1.5 mean_(b, i, k) (v[b, k, i] - R[b, i, k])^2, whose gradient with respect
//! to v is (v - R) / (B N); the heads' gradients go down the trunk as one set
//! ([`super::layer_grads`] with one loss).

use super::{Layout, Weights, layer_grads, slots};
use crate::learn::dense::{Mat, matmul};
use crate::learn::nets::HIDDEN;

/// The heads in output order.
pub const HEADS: [&str; 3] = ["progress", "energy", "smoothness"];

/// The critic's parameters in name order: energy.{bias `[N]`, weight `[N, H]`}, l1.{bias `[H]`,
/// weight `[H, N obs + G]`}, l2.{bias `[H]`, weight `[H, H]`}, progress.{..}, smoothness.{..}.
/// G is the global-state inputs after the joint observations (`train.critic_phase`: 2).
pub fn layout(agents: usize, obs_dim: usize, global_dim: usize) -> Layout {
    let (h, n) = (HIDDEN, agents);
    Layout::new(vec![
        ("energy.bias", vec![n]),
        ("energy.weight", vec![n, h]),
        ("l1.bias", vec![h]),
        ("l1.weight", vec![h, n * obs_dim + global_dim]),
        ("l2.bias", vec![h]),
        ("l2.weight", vec![h, h]),
        ("progress.bias", vec![n]),
        ("progress.weight", vec![n, h]),
        ("smoothness.bias", vec![n]),
        ("smoothness.weight", vec![n, h]),
    ])
}

/// One forward pass: inputs [B, N obs + G], hidden tanh outputs [B, H], values [B, 3, N].
#[derive(Debug, Clone)]
pub struct CriticActs {
    /// Number of rows B (joint states).
    pub rows: usize,
    /// Inputs [B, N obs + G].
    pub x: Vec<f32>,
    /// First hidden layer's tanh output [B, H].
    pub h1: Vec<f32>,
    /// Second hidden layer's tanh output [B, H].
    pub h2: Vec<f32>,
    /// Values [B, 3, N] (heads in [`HEADS`] order).
    pub values: Vec<f32>,
}

/// The critic on joint states `x` [rows, N obs + G] with parameters `p` (in `layout` order).
pub fn forward(layout: &Layout, p: &[f32], x: &[f32], rows: usize) -> CriticActs {
    let h1 = layout.dense(p, "l1").forward(x, rows, true);
    let h2 = layout.dense(p, "l2").forward(&h1, rows, true);
    let n = layout.get(p, "progress.bias").len();
    let mut values = vec![0.0f32; rows * 3 * n];
    for (k, name) in HEADS.iter().enumerate() {
        let v = layout.dense(p, name).forward(&h2, rows, false);
        for (b, row) in v.chunks_exact(n).enumerate() {
            values[(b * 3 + k) * n..(b * 3 + k + 1) * n].copy_from_slice(row);
        }
    }
    CriticActs {
        rows,
        x: x.to_vec(),
        h1,
        h2,
        values,
    }
}

/// The value loss (module header) of a forward pass against returns [B, N, 3] and its
/// gradient, a flat vector in `layout` order.
pub fn value_loss_grad(
    layout: &Layout,
    p: &[f32],
    acts: &CriticActs,
    returns: &[f32],
) -> (f64, Vec<f32>) {
    let rows = acts.rows;
    let n = acts.values.len() / (3 * rows.max(1));
    assert_eq!(returns.len(), rows * n * 3, "returns are [{rows}, {n}, 3]");
    let scale = 1.0 / (rows * n) as f32;
    let mut loss = 0.0f64;
    // dv [B, 3 N], in the values' layout.
    let mut dv = vec![0.0f32; acts.values.len()];
    for b in 0..rows {
        for k in 0..3 {
            for i in 0..n {
                let at = (b * 3 + k) * n + i;
                let diff = acts.values[at] - returns[(b * n + i) * 3 + k];
                loss += (diff as f64).powi(2);
                dv[at] = diff * scale;
            }
        }
    }
    let loss = 1.5 * loss / (rows * n * 3) as f64;
    let mut grad = vec![vec![0.0f32; layout.len()]];
    let h = acts.h2.len() / rows.max(1);
    // d h2 = sum_k dv_k W_k [B, H], then through the tanh.
    let mut d2 = vec![0.0f32; rows * h];
    for (k, name) in HEADS.iter().enumerate() {
        let head = layout.dense(p, name);
        let dv_k = Mat::strided(&dv[k * n..], rows, n, 3 * n, 1);
        let (ws, bs) = slots(layout, name);
        matmul(
            &mut grad[0][ws],
            dv_k.t(),
            Mat::new(&acts.h2, rows, h),
            true,
        );
        for b in 0..rows {
            for i in 0..n {
                grad[0][bs.start + i] += dv[(b * 3 + k) * n + i];
            }
        }
        matmul(&mut d2, dv_k, Mat::new(head.w, n, h), true);
    }
    for (d, h) in d2.iter_mut().zip(&acts.h2) {
        *d *= 1.0 - h * h;
    }
    let one = Weights::ONE;
    layer_grads(&d2, &acts.h1, rows, one, &mut grad, slots(layout, "l2"));
    let d1 = layout.dense(p, "l2").down_through_tanh(&d2, &acts.h1);
    layer_grads(&d1, &acts.x, rows, one, &mut grad, slots(layout, "l1"));
    (loss, grad.pop().expect("one loss"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::nets::Critic;
    use crate::learn::surgery::{flatten, named_vars, values};
    use candle_core::{DType, Device, Tensor};
    use candle_nn::{VarBuilder, VarMap};

    #[test]
    fn the_hand_written_critic_and_its_loss_gradient_match_candles_autograd() {
        // Without global state, and with the two phase inputs of `train.critic_phase`.
        for global in [0, 2] {
            critic_matches_autograd(global);
        }
    }

    fn critic_matches_autograd(global: usize) {
        let dev = Device::Cpu;
        let (n, b) = (5, 7);
        let vm = VarMap::new();
        let vb = VarBuilder::from_varmap(&vm, DType::F32, &dev);
        let critic = Critic::new(vb.pp("critic"), n, 8, global).unwrap();
        let vars = named_vars(&vm, "critic");
        let layout = layout(n, 8, global);
        let names: Vec<String> = layout
            .params()
            .iter()
            .map(|(k, _)| format!("critic.{k}"))
            .collect();
        assert_eq!(names, vars.iter().map(|v| v.0.clone()).collect::<Vec<_>>());
        let p = values(&vars).unwrap();
        let state = Tensor::randn(0f32, 1.0, (b, n * 8 + global), &dev).unwrap();
        let ret = Tensor::randn(0f32, 1.0, (b, n, 3), &dev).unwrap();
        let flat = |t: &Tensor| -> Vec<f32> { t.flatten_all().unwrap().to_vec1().unwrap() };
        let acts = forward(&layout, &p, &flat(&state), b);
        let v = critic.forward(&state).unwrap();
        let want_v = flat(&v);
        for (a, w) in acts.values.iter().zip(&want_v) {
            assert!((a - w).abs() <= 1e-5 * (1.0 + w.abs()), "{a} vs {w}");
        }
        // The update's loss, as it was computed with autograd.
        let loss = (v.transpose(1, 2).unwrap() - &ret)
            .unwrap()
            .sqr()
            .unwrap()
            .mean_all()
            .unwrap()
            .affine(1.5, 0.0)
            .unwrap();
        let want = flatten(&loss.backward().unwrap(), &vars).unwrap();
        let (got_loss, got) = value_loss_grad(&layout, &p, &acts, &flat(&ret));
        let want_loss = loss.to_scalar::<f32>().unwrap() as f64;
        assert!(
            (got_loss - want_loss).abs() < 1e-5 * want_loss,
            "{got_loss} vs {want_loss}"
        );
        let scale = want.iter().fold(0f32, |m, x| m.max(x.abs()));
        assert!(scale > 0.0);
        for (i, (a, w)) in got.iter().zip(&want).enumerate() {
            assert!((a - w).abs() <= 1e-5 * scale, "parameter {i}: {a} vs {w}");
        }
    }
}
