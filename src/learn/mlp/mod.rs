//! The actor's and the critic's forward and backward passes written out by hand on f32 slices
//! (the networks of SPEC section 5, [`super::nets`] has them in candle, and the tests hold these
//! against candle's forward passes and autograd). Both are two tanh layers and linear heads:
//!
//!   h1 = tanh(x W1^T + b1) [R, H],   h2 = tanh(h1 W2^T + b2) [R, H],   y = h2 Wh^T + bh,
//!
//! with every weight [out, in] row-major as candle stores it. Parameters live in one flat
//! vector per network, in the order of their names (the order [`super::surgery`] flattens
//! candle's variables in), described by a [`Layout`]. Backward, for U sets of row gradients
//! dy_u [R, out] weighted per sample into K losses (w [K, U, S], the R rows are S samples of
//! R / S rows each):
//!
//!   dW_k = sum_u dy_u^T diag(w`[k, u, s(r)]`) x,   db_k = sum_u sum_r w`[k, u, s(r)]` dy_u`[r]`,
//!   dx_u = (dy_u W) (1 - x^2)   (through the layer and the tanh that made its input x),
//!
//! so every layer is one matrix product over all R rows per (set, loss) pair that has nonzero
//! weights ([out, R] x [R, in], accumulated straight into the gradient; [`layer_grads`]) and
//! one for the U sets going down ([U R, out] x [out, in]). [`actor`] and [`critic`] use it.

pub mod actor;
pub mod critic;

use super::dense::{Mat, matmul, matmul_scaled, rows_of, tanh_inplace};
use std::ops::Range;

/// Where each named parameter sits in a network's flat parameter vector (names in sorted
/// order, shapes as candle's).
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    params: Vec<(&'static str, Vec<usize>)>,
    offsets: Vec<usize>,
    total: usize,
}

impl Layout {
    /// `params` in name order (checked).
    pub fn new(params: Vec<(&'static str, Vec<usize>)>) -> Self {
        assert!(
            params.windows(2).all(|p| p[0].0 < p[1].0),
            "parameters in name order"
        );
        let mut offsets = Vec::with_capacity(params.len());
        let mut total = 0;
        for (_, shape) in &params {
            offsets.push(total);
            total += shape.iter().product::<usize>();
        }
        Self {
            params,
            offsets,
            total,
        }
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.total
    }

    /// Whether the layout holds no parameters.
    pub fn is_empty(&self) -> bool {
        self.total == 0
    }

    /// (name, shape) of every parameter, in order.
    pub fn params(&self) -> &[(&'static str, Vec<usize>)] {
        &self.params
    }

    /// The range of `name` in the flat vector.
    pub fn slot(&self, name: &str) -> Range<usize> {
        let i = self
            .params
            .iter()
            .position(|p| p.0 == name)
            .unwrap_or_else(|| panic!("no parameter {name}"));
        self.offsets[i]..self.offsets[i] + self.params[i].1.iter().product::<usize>()
    }

    /// The values of `name` in `flat`.
    pub fn get<'a>(&self, flat: &'a [f32], name: &str) -> &'a [f32] {
        assert_eq!(flat.len(), self.total, "flat parameter vector length");
        &flat[self.slot(name)]
    }

    /// A dense layer `prefix.weight` `[out, in]`, `prefix.bias` `[out]` of `flat`.
    pub fn dense<'a>(&self, flat: &'a [f32], prefix: &str) -> Dense<'a> {
        let w = self.get(flat, &format!("{prefix}.weight"));
        let b = self.get(flat, &format!("{prefix}.bias"));
        Dense {
            w,
            b,
            out: b.len(),
            inp: w.len() / b.len().max(1),
        }
    }
}

/// A linear layer y = x W^T + b: W `[out, in]` row-major, b `[out]`.
#[derive(Clone, Copy)]
pub struct Dense<'a> {
    /// Weights W [out, in], row-major.
    pub w: &'a [f32],
    /// Bias b `[out]`.
    pub b: &'a [f32],
    /// Output width.
    pub out: usize,
    /// Input width.
    pub inp: usize,
}

impl Dense<'_> {
    /// y = x W^T + b [R, out] for x [R, in], tanh'd if `tanh`.
    pub fn forward(&self, x: &[f32], rows: usize, tanh: bool) -> Vec<f32> {
        let mut y = rows_of(self.b, rows);
        matmul(
            &mut y,
            Mat::new(x, rows, self.inp),
            Mat::new(self.w, self.out, self.inp).t(),
            true,
        );
        if tanh {
            tanh_inplace(&mut y);
        }
        y
    }

    /// The U sets' gradients with respect to this layer's input, dy W [U R, in], times
    /// 1 - h^2 where h [R, in] is the tanh output that was the input.
    pub fn down_through_tanh(&self, dy: &[f32], h: &[f32]) -> Vec<f32> {
        let ur = dy.len() / self.out;
        let mut dx = vec![0.0f32; ur * self.inp];
        matmul(
            &mut dx,
            Mat::new(dy, ur, self.out),
            Mat::new(self.w, self.out, self.inp),
            false,
        );
        for set in dx.chunks_exact_mut(h.len()) {
            for (d, h) in set.iter_mut().zip(h) {
                *d *= 1.0 - h * h;
            }
        }
        dx
    }
}

/// How U sets of row gradients make K losses: `w` [K, U, S], rows grouped into S samples.
#[derive(Clone, Copy)]
pub struct Weights<'a> {
    /// Weights [K, U, S], row-major.
    pub w: &'a [f32],
    /// Number of losses K.
    pub losses: usize,
    /// Number of gradient sets U.
    pub sets: usize,
    /// Number of samples S the rows are grouped into.
    pub samples: usize,
}

impl Weights<'_> {
    /// One loss from one set, every row weight 1.
    pub const ONE: Weights<'static> = Weights {
        w: &[1.0],
        losses: 1,
        sets: 1,
        samples: 1,
    };
}

/// Every loss's weight and bias gradient of a layer with input x [R, in] and output gradients
/// `dy` `[U][R][out]` (module header), added into each loss's flat gradient `grads[k]` at
/// `slots` = (weight range, bias range).
///
/// Per set u, over the m losses that use it (a pair whose weights are all zero adds nothing and
/// is skipped), dW_k += dy_u^T diag(w[k, u, s(r)]) x: where one loss uses the set with the same
/// weight for every sample, one matrix product straight into its gradient, scaled; otherwise
/// the narrower of dy_u and x is weighted per loss (the m copies side by side in one scratch
/// buffer) and each copy makes one product ([out, R] x [R, in]) accumulated straight into
/// its loss's gradient. (This was one product m times as wide into a temporary, whose blocks
/// were then added in: gemm forms each element as one chain of fused multiply-adds over the
/// rows in order whatever the product's width, so into a gradient that is still zero there, as
/// every objective's is in the learner, the two give the same bits; checked on training runs.)
/// db_k += sum_s w[k, u, s] (the row sum of dy_u over sample s).
pub fn layer_grads(
    dy: &[f32],
    x: &[f32],
    rows: usize,
    weights: Weights,
    grads: &mut [Vec<f32>],
    slots: (Range<usize>, Range<usize>),
) {
    let Weights {
        w,
        losses: k,
        sets: u,
        samples: s,
    } = weights;
    let out = dy.len() / (u * rows);
    let inp = x.len() / rows;
    assert!(
        w.len() == k * u * s && s > 0 && rows.is_multiple_of(s) && grads.len() == k,
        "weights [{k}, {u}, {s}] for {rows} rows and {} losses",
        grads.len()
    );
    assert_eq!(dy.len(), u * rows * out, "dy is [{u}, {rows}, out]");
    let n = rows / s;
    let (w_slot, b_slot) = slots;
    // The m weighted copies of a [R, width] matrix side by side: [R, m width], every element
    // of `dst` written.
    let side_by_side = |src: &[f32], width: usize, ws: &[&[f32]], dst: &mut [f32]| {
        let m = ws.len();
        for (r, (row, d)) in src
            .chunks_exact(width)
            .zip(dst.chunks_exact_mut(m * width))
            .enumerate()
        {
            for (j, w) in ws.iter().enumerate() {
                let c = w[r / n];
                let block = &mut d[j * width..(j + 1) * width];
                block.iter_mut().zip(row).for_each(|(d, v)| *d = c * v);
            }
        }
    };
    for uu in 0..u {
        let dy_u = &dy[uu * rows * out..(uu + 1) * rows * out];
        let users: Vec<usize> = (0..k)
            .filter(|kk| {
                w[(kk * u + uu) * s..(kk * u + uu + 1) * s]
                    .iter()
                    .any(|&c| c != 0.0)
            })
            .collect();
        if users.is_empty() {
            continue;
        }
        let ws: Vec<&[f32]> = users
            .iter()
            .map(|kk| &w[(kk * u + uu) * s..(kk * u + uu + 1) * s])
            .collect();
        // Biases, from each sample's row sum of dy_u [S, out].
        let mut sums = vec![0.0f32; s * out];
        for (r, row) in dy_u.chunks_exact(out).enumerate() {
            let dst = &mut sums[(r / n) * out..(r / n + 1) * out];
            dst.iter_mut().zip(row).for_each(|(d, v)| *d += v);
        }
        for (&kk, w) in users.iter().zip(&ws) {
            let db = &mut grads[kk][b_slot.clone()];
            for (ss, c) in w.iter().enumerate() {
                let src = &sums[ss * out..(ss + 1) * out];
                db.iter_mut().zip(src).for_each(|(d, v)| *d += c * v);
            }
        }
        let m = users.len();
        if m == 1 && ws[0].iter().all(|&c| c == ws[0][0]) {
            let dw = &mut grads[users[0]][w_slot.clone()];
            let (a, b) = (Mat::new(dy_u, rows, out).t(), Mat::new(x, rows, inp));
            matmul_scaled(dw, a, b, true, ws[0][0]);
        } else if inp <= out {
            // x weighted per loss, side by side [R, m in]; block j times dy_u^T is loss j's dW,
            // accumulated straight into its gradient.
            with_scratch(rows * m * inp, |xs| {
                side_by_side(x, inp, &ws, xs);
                let a = Mat::new(dy_u, rows, out).t();
                for (j, &kk) in users.iter().enumerate() {
                    let b = Mat::strided(&xs[j * inp..], rows, inp, m * inp, 1);
                    matmul(&mut grads[kk][w_slot.clone()], a, b, true);
                }
            });
        } else {
            // dy_u weighted per loss, side by side [R, m out]; block j transposed times x is
            // loss j's dW.
            with_scratch(rows * m * out, |ds| {
                side_by_side(dy_u, out, &ws, ds);
                let b = Mat::new(x, rows, inp);
                for (j, &kk) in users.iter().enumerate() {
                    let a = Mat::strided(&ds[j * out..], rows, out, m * out, 1).t();
                    matmul(&mut grads[kk][w_slot.clone()], a, b, true);
                }
            });
        }
    }
}

thread_local! {
    /// [`with_scratch`]'s buffer on this thread.
    static SCRATCH: std::cell::RefCell<Vec<f32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Runs `f` on a scratch buffer of `len` elements, kept per thread between calls (grown when
/// needed, never cleared: it holds what the last call left), for a buffer that `f` writes in
/// full before it reads it, so that each minibatch does not allocate and zero it again.
fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f32]) -> R) -> R {
    SCRATCH.with(|cell| {
        let mut buf = cell.borrow_mut();
        if buf.len() < len {
            buf.resize(len, 0.0);
        }
        f(&mut buf[..len])
    })
}

/// The (weight, bias) ranges of layer `prefix` in `layout`.
pub fn slots(layout: &Layout, prefix: &str) -> (Range<usize>, Range<usize>) {
    (
        layout.slot(&format!("{prefix}.weight")),
        layout.slot(&format!("{prefix}.bias")),
    )
}
