//! Adam (Kingma & Ba 2015) over one flat parameter vector:
//! m <- b1 m + (1 - b1) g,  v <- b2 v + (1 - b2) g^2,
//! theta <- theta - lr (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps).
//! Its whole state (m, v: one f32 per parameter; t) is plain data, so a checkpoint saves it and
//! a resumed run continues bit for bit (candle's own `AdamW` keeps its moments private).

use super::lanes::Path;

/// Adam optimiser state for one flat parameter vector (see the module header).
#[derive(Debug, Clone, PartialEq)]
pub struct Adam {
    /// Learning rate.
    pub lr: f64,
    /// Decay rate b1 of the first moment.
    pub beta1: f64,
    /// Decay rate b2 of the second moment.
    pub beta2: f64,
    /// Term added to sqrt(v) in the denominator.
    pub eps: f64,
    /// Steps taken.
    pub t: u64,
    /// First moment estimates, one per parameter.
    pub m: Vec<f32>,
    /// Second moment estimates, one per parameter.
    pub v: Vec<f32>,
}

impl Adam {
    /// Adam for `n` parameters with PyTorch's defaults (b1 0.9, b2 0.999, eps 1e-8).
    pub fn new(n: usize, lr: f64) -> Self {
        Self {
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            t: 0,
            m: vec![0.0; n],
            v: vec![0.0; n],
        }
    }

    /// One step: updates `params` in place from `grad` (same length as the moments).
    pub fn step(&mut self, params: &mut [f32], grad: &[f32]) {
        self.step_scaled(params, grad, None)
    }

    /// [`Self::step`] with the gradient `grad` times `scale` where one is given (a clipped
    /// gradient), without writing the scaled gradient anywhere: each element is scaled as it
    /// is read, the same product a separate pass would have stored.
    pub fn step_scaled(&mut self, params: &mut [f32], grad: &[f32], scale: Option<f32>) {
        self.step_on(Path::best(), params, grad, scale)
    }

    /// [`Self::step_scaled`] on the build `path`.
    pub(crate) fn step_on(
        &mut self,
        path: Path,
        params: &mut [f32],
        grad: &[f32],
        scale: Option<f32>,
    ) {
        assert_eq!(params.len(), self.m.len(), "parameter count changed");
        assert_eq!(grad.len(), self.m.len(), "gradient length");
        self.t += 1;
        let c1 = (1.0 - self.beta1.powi(self.t as i32)) as f32;
        let c2 = (1.0 - self.beta2.powi(self.t as i32)) as f32;
        let k = Consts {
            b1: self.beta1 as f32,
            b2: self.beta2 as f32,
            c1,
            c2,
            lr: self.lr as f32,
            eps: self.eps as f32,
        };
        let (m, v) = (&mut self.m[..], &mut self.v[..]);
        match path {
            Path::Plain => step_plain(params, grad, m, v, scale, k),
            // SAFETY: `path` is one the CPU runs (`Path::best` or `available` chose it).
            #[cfg(target_arch = "x86_64")]
            Path::Avx2 => unsafe { step_avx2(params, grad, m, v, scale, k) },
        }
    }
}

/// The step's constants in f32.
#[derive(Clone, Copy)]
struct Consts {
    b1: f32,
    b2: f32,
    c1: f32,
    c2: f32,
    lr: f32,
    eps: f32,
}

/// The update of every parameter, written once and compiled for the plain target and for AVX2
/// (chosen at run time; AVX-512 is no faster, the dividers are as wide). Only additions,
/// multiplications, divisions and square roots, each correctly rounded and none fused, so the
/// two builds give the same bits (tested).
/// Division is the costly part (three and a square root per parameter); x / 1 is x exactly,
/// so a bias correction that has rounded to 1 in f32 is not divided by (c1 from step 165,
/// c2 from step 17,321), with the same result.
#[inline(always)]
fn step_plain(
    params: &mut [f32],
    grad: &[f32],
    m: &mut [f32],
    v: &mut [f32],
    scale: Option<f32>,
    k: Consts,
) {
    match scale {
        None => with_c1(params, grad, m, v, k, |g| g),
        Some(s) => with_c1(params, grad, m, v, k, move |g| g * s),
    }
}

#[inline(always)]
fn with_c1(
    params: &mut [f32],
    grad: &[f32],
    m: &mut [f32],
    v: &mut [f32],
    k: Consts,
    read: impl Fn(f32) -> f32,
) {
    let c1 = k.c1;
    if c1 == 1.0 {
        with_c2(params, grad, m, v, k, read, |m| m)
    } else {
        with_c2(params, grad, m, v, k, read, move |m| m / c1)
    }
}

#[inline(always)]
fn with_c2(
    params: &mut [f32],
    grad: &[f32],
    m: &mut [f32],
    v: &mut [f32],
    k: Consts,
    read: impl Fn(f32) -> f32,
    unbias1: impl Fn(f32) -> f32,
) {
    let c2 = k.c2;
    if c2 == 1.0 {
        moments(params, grad, m, v, k, read, unbias1, |v| v)
    } else {
        moments(params, grad, m, v, k, read, unbias1, move |v| v / c2)
    }
}

/// The loop: `read` scales the gradient (or not), `unbias1` and `unbias2` divide by the bias
/// corrections (or not).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn moments(
    params: &mut [f32],
    grad: &[f32],
    m: &mut [f32],
    v: &mut [f32],
    k: Consts,
    read: impl Fn(f32) -> f32,
    unbias1: impl Fn(f32) -> f32,
    unbias2: impl Fn(f32) -> f32,
) {
    let Consts {
        b1, b2, lr, eps, ..
    } = k;
    for (((p, g), m), v) in params
        .iter_mut()
        .zip(grad)
        .zip(m.iter_mut())
        .zip(v.iter_mut())
    {
        let g = read(*g);
        *m = b1 * *m + (1.0 - b1) * g;
        *v = b2 * *v + (1.0 - b2) * g * g;
        *p -= lr * unbias1(*m) / (unbias2(*v).sqrt() + eps);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn step_avx2(
    params: &mut [f32],
    grad: &[f32],
    m: &mut [f32],
    v: &mut [f32],
    scale: Option<f32>,
    k: Consts,
) {
    step_plain(params, grad, m, v, scale, k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_step_moves_each_parameter_by_lr_against_its_gradient_sign() {
        // t = 1: m_hat = g, v_hat = g^2, so the step is lr g / (|g| + eps) = lr sign(g).
        let mut a = Adam::new(3, 0.1);
        let mut p = [1.0f32, 1.0, 1.0];
        a.step(&mut p, &[2.0, -0.5, 0.0]);
        assert!((p[0] - 0.9).abs() < 1e-6, "{p:?}");
        assert!((p[1] - 1.1).abs() < 1e-6, "{p:?}");
        assert_eq!(p[2], 1.0);
    }

    #[test]
    fn second_step_matches_hand_computed_moments() {
        // g1 = 1, g2 = 3: m = 0.9 * 0.1 + 0.1 * 3 = 0.39, v = 0.999 * 0.001 + 0.001 * 9 = 0.009999;
        // m_hat = 0.39 / 0.19, v_hat = 0.009999 / 0.001999, step = lr m_hat / sqrt(v_hat).
        let mut a = Adam::new(1, 0.01);
        let mut p = [0.0f32];
        a.step(&mut p, &[1.0]);
        a.step(&mut p, &[3.0]);
        let second = 0.01 * (0.39 / 0.19) / (0.009999f64 / 0.001999).sqrt();
        let expected = -0.01 - second;
        assert!(
            (p[0] as f64 - expected).abs() < 1e-6,
            "{} vs {expected}",
            p[0]
        );
        assert_eq!(a.t, 2);
    }

    /// The step as the module header writes it, on a gradient scaled beforehand (as a clip
    /// did before it was fused into the step).
    fn reference_step(a: &mut Adam, p: &mut [f32], g: &[f32], scale: Option<f32>) {
        a.t += 1;
        let (b1, b2) = (a.beta1 as f32, a.beta2 as f32);
        let c1 = (1.0 - a.beta1.powi(a.t as i32)) as f32;
        let c2 = (1.0 - a.beta2.powi(a.t as i32)) as f32;
        let (lr, eps) = (a.lr as f32, a.eps as f32);
        for (((p, g), m), v) in p.iter_mut().zip(g).zip(&mut a.m).zip(&mut a.v) {
            let g = match scale {
                Some(s) => g * s,
                None => *g,
            };
            *m = b1 * *m + (1.0 - b1) * g;
            *v = b2 * *v + (1.0 - b2) * g * g;
            *p -= lr * (*m / c1) / ((*v / c2).sqrt() + eps);
        }
    }

    #[test]
    fn every_build_and_the_fused_clip_give_the_plain_steps_bits() {
        // Gradients over many scales (and zeros), an awkward length, and steps on both sides of
        // the bias corrections rounding to 1 (c1 from t = 165, c2 from t = 17,321): every
        // build, with the scale applied on reading, equals the written-out step bit for bit.
        let mut rng = crate::rng::Rng::new(8);
        let len = 1037;
        let mut noise = || -> Vec<f32> {
            (0..len)
                .map(|i| {
                    if i % 97 == 0 {
                        0.0
                    } else {
                        (rng.normal() * 10f64.powi((i % 9) as i32 - 4)) as f32
                    }
                })
                .collect()
        };
        let p0 = noise();
        let grads: Vec<Vec<f32>> = (0..3).map(|_| noise()).collect();
        let bits = |x: &[f32]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for path in Path::available() {
            for t0 in [0u64, 160, 17_316] {
                for scale in [None, Some(0.37f32)] {
                    let mut reference = Adam::new(len, 1e-3);
                    reference.t = t0;
                    reference.m = noise().iter().map(|x| x * 0.1).collect();
                    reference.v = noise().iter().map(|x| x * x).collect();
                    let mut fused = reference.clone();
                    let (mut pr, mut pf) = (p0.clone(), p0.clone());
                    for _ in 0..3 {
                        for g in &grads {
                            reference_step(&mut reference, &mut pr, g, scale);
                            fused.step_on(path, &mut pf, g, scale);
                        }
                    }
                    let what = format!("{path:?}, t from {t0}, scale {scale:?}");
                    assert_eq!(bits(&pr), bits(&pf), "parameters, {what}");
                    assert_eq!(bits(&reference.m), bits(&fused.m), "m, {what}");
                    assert_eq!(bits(&reference.v), bits(&fused.v), "v, {what}");
                    assert_eq!(reference.t, fused.t);
                }
            }
        }
        // The shortcuts are taken in those ranges.
        assert!((1.0 - 0.9f64.powi(165)) as f32 == 1.0 && (1.0 - 0.9f64.powi(164)) as f32 != 1.0);
        assert!((1.0 - 0.999f64.powi(17_321)) as f32 == 1.0);
        assert!((1.0 - 0.999f64.powi(17_320)) as f32 != 1.0);
    }
}
