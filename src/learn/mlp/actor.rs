//! The actor by hand (SPEC section 5; [`crate::learn::nets::Actor`] is the same network in
//! candle): o [R, obs] -> 256 -> 256 (tanh) -> [R, 2A] = (mean, raw), and
//! log σ = MIN + (MAX - MIN) sigmoid(raw + ln(-MIN / MAX)), A = 2 action dimensions.
//!
//! Backward ([`backward`]): the U sets of gradients with respect to (mean, log σ) become
//! gradients with respect to (mean, raw) through d log σ / d raw = (MAX - MIN) s (1 - s),
//! s = (log σ - MIN) / (MAX - MIN), and go down the network once each, while every layer forms
//! all K weighted losses' weight gradients in one matrix product ([`super::layer_grads`]).
//! The Gaussian policy's joint log-probability of raw samples, summed over agents and
//! dimensions, is [`joint_log_prob`].

use super::{Layout, Weights, layer_grads, slots};
use crate::learn::nets::{HIDDEN, LOG_STD_MAX, LOG_STD_MIN};

/// The actor's parameters in name order: head.bias `[2A]`, head.weight `[2A, H]`, l1.bias `[H]`,
/// l1.weight `[H, obs]`, l2.bias `[H]`, l2.weight `[H, H]`.
pub fn layout(obs_dim: usize, action_dim: usize) -> Layout {
    let (h, a2) = (HIDDEN, 2 * action_dim);
    Layout::new(vec![
        ("head.bias", vec![a2]),
        ("head.weight", vec![a2, h]),
        ("l1.bias", vec![h]),
        ("l1.weight", vec![h, obs_dim]),
        ("l2.bias", vec![h]),
        ("l2.weight", vec![h, h]),
    ])
}

/// One forward pass and the activations the backward pass needs; all row-major.
#[derive(Debug, Clone)]
pub struct ActorActs {
    /// Number of rows R (one per agent sample).
    pub rows: usize,
    /// Inputs [R, obs], the hidden layers' tanh outputs [R, H].
    pub x: Vec<f32>,
    /// First hidden layer's tanh output [R, H].
    pub h1: Vec<f32>,
    /// Second hidden layer's tanh output [R, H].
    pub h2: Vec<f32>,
    /// [R, A] each.
    pub mean: Vec<f32>,
    /// Clamped log σ [R, A].
    pub log_std: Vec<f32>,
}

/// The actor on observations `x` [rows, obs] with parameters `p` (in `layout` order).
pub fn forward(layout: &Layout, p: &[f32], x: &[f32], rows: usize) -> ActorActs {
    let h1 = layout.dense(p, "l1").forward(x, rows, true);
    let h2 = layout.dense(p, "l2").forward(&h1, rows, true);
    let head = layout.dense(p, "head");
    let out = head.forward(&h2, rows, false);
    let a = head.out / 2;
    let shift = (-LOG_STD_MIN / LOG_STD_MAX).ln() as f32;
    let span = (LOG_STD_MAX - LOG_STD_MIN) as f32;
    let mut mean = Vec::with_capacity(rows * a);
    let mut log_std = Vec::with_capacity(rows * a);
    for row in out.chunks_exact(2 * a) {
        mean.extend_from_slice(&row[..a]);
        log_std.extend(row[a..].iter().map(|raw| {
            let s = 1.0 / (1.0 + (-(raw + shift)).exp());
            s * span + LOG_STD_MIN as f32
        }));
    }
    ActorActs {
        rows,
        x: x.to_vec(),
        h1,
        h2,
        mean,
        log_std,
    }
}

/// The K losses' gradients, one flat vector each in `layout` order, for U sets of row
/// gradients `d_mean`, `d_log_std` [U, R, A] weighted into losses by `weights` (see
/// [`super`]): d loss_k / d output of row r = sum_u w[k, u, s(r)] (d_mean, d_log_std)[u, r].
pub fn backward(
    layout: &Layout,
    p: &[f32],
    acts: &ActorActs,
    d_mean: &[f32],
    d_log_std: &[f32],
    weights: Weights,
) -> Vec<Vec<f32>> {
    let rows = acts.rows;
    let a = acts.mean.len() / rows.max(1);
    let u = weights.sets;
    assert!(
        d_mean.len() == u * rows * a && d_log_std.len() == d_mean.len(),
        "d_mean and d_log_std are [{u}, {rows}, {a}]"
    );
    let span = (LOG_STD_MAX - LOG_STD_MIN) as f32;
    let mut d_out = vec![0.0f32; u * rows * 2 * a];
    for (i, row) in d_out.chunks_exact_mut(2 * a).enumerate() {
        let r = i % rows;
        row[..a].copy_from_slice(&d_mean[i * a..(i + 1) * a]);
        for j in 0..a {
            let s = (acts.log_std[r * a + j] - LOG_STD_MIN as f32) / span;
            row[a + j] = d_log_std[i * a + j] * ((1.0 - s) * s * span);
        }
    }
    // Zeroed vectors (`vec![v; k]` would copy the first k - 1 times).
    let mut grads: Vec<Vec<f32>> = (0..weights.losses)
        .map(|_| vec![0.0f32; layout.len()])
        .collect();
    let (head, l2) = (layout.dense(p, "head"), layout.dense(p, "l2"));
    layer_grads(
        &d_out,
        &acts.h2,
        rows,
        weights,
        &mut grads,
        slots(layout, "head"),
    );
    let d2 = head.down_through_tanh(&d_out, &acts.h2);
    layer_grads(
        &d2,
        &acts.h1,
        rows,
        weights,
        &mut grads,
        slots(layout, "l2"),
    );
    let d1 = l2.down_through_tanh(&d2, &acts.h1);
    layer_grads(&d1, &acts.x, rows, weights, &mut grads, slots(layout, "l1"));
    grads
}

/// Joint log-probabilities `[B]` of raw actions `[B n, A]` under N(mean, exp(log σ)): the sum over
/// each sample's n rows and the A dimensions of -z^2 / 2 - log σ - ln(2 pi) / 2,
/// z = (a - mean) / σ (as [`crate::learn::nets::gaussian_log_prob`] computes it per row).
pub fn joint_log_prob(actions: &[f32], mean: &[f32], log_std: &[f32], n: usize) -> Vec<f32> {
    let a = 2;
    let half_ln_2pi = (0.5 * (2.0 * std::f64::consts::PI).ln()) as f32;
    let per_row: Vec<f32> = (0..actions.len() / a)
        .map(|r| {
            (0..a)
                .map(|j| {
                    let i = r * a + j;
                    let z = (actions[i] - mean[i]) / log_std[i].exp();
                    z * z * -0.5 - log_std[i] - half_ln_2pi
                })
                .sum()
        })
        .collect();
    per_row.chunks(n).map(|c| c.iter().sum()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::nets::Actor;
    use crate::learn::surgery::{named_vars, values};
    use candle_core::{DType, Device, Tensor};
    use candle_nn::{VarBuilder, VarMap};

    fn close(got: &[f32], want: &[f32], tol: f32, what: &str) {
        assert_eq!(got.len(), want.len(), "{what}");
        let scale = want.iter().fold(1f32, |m, x| m.max(x.abs()));
        for (a, b) in got.iter().zip(want) {
            assert!((a - b).abs() <= tol * scale, "{what}: {a} vs {b}");
        }
    }

    #[test]
    fn the_hand_written_forward_pass_matches_candles() {
        let dev = Device::Cpu;
        let vm = VarMap::new();
        let vb = VarBuilder::from_varmap(&vm, DType::F32, &dev);
        let actor = Actor::new(vb.pp("actor"), 8, 2).unwrap();
        let vars = named_vars(&vm, "actor");
        let layout = layout(8, 2);
        let names: Vec<String> = layout
            .params()
            .iter()
            .map(|(n, _)| format!("actor.{n}"))
            .collect();
        assert_eq!(names, vars.iter().map(|v| v.0.clone()).collect::<Vec<_>>());
        let p = values(&vars).unwrap();
        // Inputs of scale 3 drive some log σ near their bounds.
        let rows = 37;
        let obs = Tensor::randn(0f32, 3.0, (rows, 8), &dev).unwrap();
        let x: Vec<f32> = obs.flatten_all().unwrap().to_vec1().unwrap();
        let acts = forward(&layout, &p, &x, rows);
        let pass = actor.forward_pass(&obs).unwrap();
        let flat = |t: &Tensor| -> Vec<f32> { t.flatten_all().unwrap().to_vec1().unwrap() };
        close(&acts.mean, &flat(&pass.mean), 1e-5, "mean");
        close(&acts.log_std, &flat(&pass.log_std), 1e-5, "log_std");
        let actions = Tensor::randn(0f32, 1.0, (rows - 1, 2), &dev).unwrap();
        let want: Vec<f32> = crate::learn::nets::gaussian_log_prob(
            &actions,
            &pass.mean.narrow(0, 0, rows - 1).unwrap(),
            &pass.log_std.narrow(0, 0, rows - 1).unwrap(),
        )
        .unwrap()
        .reshape(((rows - 1) / 4, 4))
        .unwrap()
        .sum(1)
        .unwrap()
        .to_vec1()
        .unwrap();
        let got = joint_log_prob(&flat(&actions), &acts.mean, &acts.log_std, 4);
        close(&got, &want, 1e-5, "joint log-probability");
    }
}
