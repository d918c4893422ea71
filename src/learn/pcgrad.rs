//! PCGrad (Yu et al. 2020): for each objective gradient g_i, in a (random) order over the
//! others j, if g_i' . g_j < 0 project away the conflicting part, g_i' <- g_i' - (g_i' . g_j) /
//! |g_j|^2 g_j (against the original g_j); then average the projected gradients. Also reports
//! the pairwise cosine similarities of the original gradients and which pairs conflicted.

/// Result of one surgery.
#[derive(Debug, Clone, PartialEq)]
pub struct Surgery {
    /// Mean of the projected gradients.
    pub combined: Vec<f32>,
    /// cos(g_i, g_j) for i < j, in the order (0,1), (0,2), ..., (1,2), ...
    pub cosines: Vec<f32>,
    /// g_i . g_j < 0 for the same pairs.
    pub conflicts: Vec<bool>,
}

pub(crate) use super::lanes::dot;

/// The Gram matrix g_i . g_j of K gradients of one length, each entry exactly [`dot`]`(g_i,
/// g_j)`; for three gradients (the learner's objectives) all six in one pass over the data.
pub(crate) fn gram(grads: &[&[f32]]) -> Vec<Vec<f64>> {
    let k = grads.len();
    let mut g = vec![vec![0.0f64; k]; k];
    if let [a, b, c] = grads {
        let d = super::lanes::gram3(a, b, c);
        for (d, (i, j)) in d
            .into_iter()
            .zip([(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)])
        {
            (g[i][j], g[j][i]) = (d, d);
        }
        return g;
    }
    for i in 0..k {
        for j in i..k {
            let d = dot(grads[i], grads[j]);
            (g[i][j], g[j][i]) = (d, d);
        }
    }
    g
}

/// What PCGrad decides from the Gram matrix: each original gradient's weight in the mean of
/// the projected ones, and the diagnostics of [`Surgery`].
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Weight of each original gradient in the mean of the projected ones.
    pub weight: Vec<f64>,
    /// cos(g_i, g_j) for i < j, in the order (0,1), (0,2), ..., (1,2), ...
    pub cosines: Vec<f32>,
    /// g_i . g_j < 0 for the same pairs.
    pub conflicts: Vec<bool>,
}

/// PCGrad with `order[i]`: the objectives g_i is projected against, in that order.
///
/// Every projected gradient stays a combination of the originals, p_i = sum_m a_im g_m, so
/// p_i . g_j = sum_m a_im (g_m . g_j): the surgery runs on the Gram matrix of the K
/// gradients (K(K+1)/2 dot products), and one pass forms the mean sum_m (mean_i a_im) g_m.
pub fn pcgrad(grads: &[Vec<f32>], order: &[Vec<usize>]) -> Surgery {
    let views: Vec<&[f32]> = grads.iter().map(|g| g.as_slice()).collect();
    let plan = plan(&views, order);
    let mut combined = vec![0.0f32; grads.first().map_or(0, |g| g.len())];
    combine(&mut combined, &views, &plan.weight, None);
    Surgery {
        combined,
        cosines: plan.cosines,
        conflicts: plan.conflicts,
    }
}

/// The [`Plan`] of PCGrad with `order` (see [`pcgrad`]) for gradients of one length.
pub fn plan(grads: &[&[f32]], order: &[Vec<usize>]) -> Plan {
    let k = grads.len();
    assert!(
        k > 0 && order.len() == k,
        "one projection order per gradient"
    );
    assert!(
        grads.iter().all(|g| g.len() == grads[0].len()),
        "gradients of one length"
    );
    let gram = gram(grads);
    let mut weight = vec![0.0f64; k];
    for (i, others) in order.iter().enumerate() {
        let mut a = vec![0.0f64; k];
        a[i] = 1.0;
        for &j in others {
            assert_ne!(i, j, "a gradient is not projected against itself");
            let d: f64 = (0..k).map(|m| a[m] * gram[m][j]).sum();
            let nn = gram[j][j];
            if d < 0.0 && nn > 0.0 {
                a[j] -= d / nn;
            }
        }
        for (w, x) in weight.iter_mut().zip(&a) {
            *w += x / k as f64;
        }
    }
    let (mut cosines, mut conflicts) = (Vec::new(), Vec::new());
    for i in 0..k {
        for j in i + 1..k {
            let n = (gram[i][i] * gram[j][j]).sqrt();
            cosines.push(if n > 0.0 {
                (gram[i][j] / n) as f32
            } else {
                0.0
            });
            conflicts.push(gram[i][j] < 0.0);
        }
    }
    Plan {
        weight,
        cosines,
        conflicts,
    }
}

/// out = (sum_m weight_m g_m, summed in f64 in the order m = 0, 1, .., rounded to f32) + `extra`
/// (where given, in f32), and returns out . out as `dot` sums it, in one pass.
pub fn combine(out: &mut [f32], grads: &[&[f32]], weight: &[f64], extra: Option<&[f32]>) -> f64 {
    let len = out.len();
    assert!(
        grads.len() == weight.len() && grads.iter().all(|g| g.len() == len),
        "one weight per gradient, all of the output's length"
    );
    if let Some(e) = extra {
        assert_eq!(e.len(), len, "the extra term has the output's length");
    }
    if let ([a, b, c], &[wa, wb, wc]) = (grads, weight) {
        return super::lanes::combine3(out, [a, b, c], [wa, wb, wc], extra);
    }
    for (x, o) in out.iter_mut().enumerate() {
        let s = grads
            .iter()
            .zip(weight)
            .map(|(g, w)| w * g[x] as f64)
            .sum::<f64>() as f32;
        *o = match extra {
            Some(e) => s + e[x],
            None => s,
        };
    }
    dot(out, out)
}

/// Plain average (the `--no-pcgrad` ablation), with the same diagnostics.
pub fn average(grads: &[Vec<f32>]) -> Surgery {
    let no_projection: Vec<Vec<usize>> = vec![Vec::new(); grads.len()];
    pcgrad(grads, &no_projection)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f32], b: &[f32]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-6, "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn two_conflicting_gradients_project_onto_each_others_normal_plane() {
        // g1 = (1, 0), g2 = (-1, 1): g1.g2 = -1.
        // g1' = g1 - (-1)/2 g2 = (0.5, 0.5), g2' = g2 - (-1)/1 g1 = (0, 1); mean (0.25, 0.75).
        let g = vec![vec![1.0, 0.0], vec![-1.0, 1.0]];
        let s = pcgrad(&g, &[vec![1], vec![0]]);
        close(&s.combined, &[0.25, 0.75]);
        assert_eq!(s.conflicts, vec![true]);
        assert!((s.cosines[0] + 0.5f32.sqrt()).abs() < 1e-6);
        // Each projected gradient is orthogonal to the other original one.
        let p1 = [0.5f32, 0.5];
        let p2 = [0.0f32, 1.0];
        assert!(dot(&p1, &g[1]).abs() < 1e-9 && dot(&p2, &g[0]).abs() < 1e-9);
    }

    #[test]
    fn non_conflicting_gradients_pass_unchanged() {
        let g = vec![vec![1.0, 2.0], vec![0.5, 0.1]];
        let s = pcgrad(&g, &[vec![1], vec![0]]);
        close(&s.combined, &[0.75, 1.05]);
        assert_eq!(s.conflicts, vec![false]);
        assert_eq!(s, average(&g));
    }

    #[test]
    fn three_gradients_with_a_fixed_order_match_hand_values() {
        // g1 = (1,0,0), g2 = (-1,1,0), g3 = (0,-1,1).
        // g1 vs [g2, g3]: g1.g2 = -1 -> (0.5, 0.5, 0); then .g3 = -0.5 -> + 0.25 g3 = (0.5, 0.25, 0.25)
        // g2 vs [g3, g1]: g2.g3 = -1 -> (-1, 0.5, 0.5); then .g1 = -1 -> + g1 = (0, 0.5, 0.5)
        // g3 vs [g1, g2]: g3.g1 = 0 (kept); g3.g2 = -1 -> + 0.5 g2 = (-0.5, -0.5, 1)
        // mean = (0, 0.25/3, 1.75/3)
        let g = vec![
            vec![1.0, 0.0, 0.0],
            vec![-1.0, 1.0, 0.0],
            vec![0.0, -1.0, 1.0],
        ];
        let s = pcgrad(&g, &[vec![1, 2], vec![2, 0], vec![0, 1]]);
        close(&s.combined, &[0.0, 0.25 / 3.0, 1.75 / 3.0]);
        assert_eq!(s.conflicts, vec![true, false, true]);
        // The order matters: g1 against [g3, g2] first meets g3 with g1.g3 = 0 (kept), then g2.
        let s2 = pcgrad(&g, &[vec![2, 1], vec![2, 0], vec![0, 1]]);
        assert_ne!(s.combined, s2.combined);
    }

    /// PCGrad as Yu et al. write it: each projection applied to the vector itself.
    fn direct(grads: &[Vec<f32>], order: &[Vec<usize>]) -> Vec<f64> {
        let k = grads.len();
        let mut combined = vec![0.0f64; grads[0].len()];
        for (i, g) in grads.iter().enumerate() {
            let mut p: Vec<f64> = g.iter().map(|&x| x as f64).collect();
            for &j in &order[i] {
                let gj: Vec<f64> = grads[j].iter().map(|&x| x as f64).collect();
                let d: f64 = p.iter().zip(&gj).map(|(a, b)| a * b).sum();
                let nn: f64 = gj.iter().map(|b| b * b).sum();
                if d < 0.0 {
                    p.iter_mut().zip(&gj).for_each(|(x, y)| *x -= d / nn * y);
                }
            }
            combined
                .iter_mut()
                .zip(&p)
                .for_each(|(c, x)| *c += x / k as f64);
        }
        combined
    }

    #[test]
    fn the_gram_matrix_form_equals_projecting_the_vectors() {
        // Three long gradients (an awkward length) with conflicts: g1 and g2 share a
        // component, g0 opposes it.
        let mut rng = crate::rng::Rng::new(5);
        let len = 1003;
        let base: Vec<f32> = (0..len).map(|_| rng.normal() as f32).collect();
        let grads: Vec<Vec<f32>> = [-1.0f32, 0.6, 0.3]
            .iter()
            .map(|&c| {
                base.iter()
                    .map(|b| c * b + rng.normal() as f32 * 0.5)
                    .collect()
            })
            .collect();
        for order in [
            vec![vec![1, 2], vec![2, 0], vec![0, 1]],
            vec![vec![2, 1], vec![0, 2], vec![1, 0]],
        ] {
            let s = pcgrad(&grads, &order);
            assert_eq!(s.conflicts, vec![true, true, false]);
            let want = direct(&grads, &order);
            let scale = want.iter().fold(0f64, |m, x| m.max(x.abs()));
            for (a, b) in s.combined.iter().zip(&want) {
                assert!((*a as f64 - b).abs() < 1e-6 * scale, "{a} vs {b}");
            }
            let d = dot(&grads[0], &grads[1]);
            let want_cos = d / (dot(&grads[0], &grads[0]) * dot(&grads[1], &grads[1])).sqrt();
            assert!((s.cosines[0] as f64 - want_cos).abs() < 1e-6);
        }
    }

    fn plain_dot(a: &[f32], b: &[f32]) -> f64 {
        crate::learn::lanes::dot_on(crate::learn::lanes::Path::Plain, a, b)
    }

    #[test]
    fn the_fused_passes_give_the_separate_passes_bits() {
        // What the update did before the passes were fused: six dot products, the mean in
        // f64 per element, the entropy term added in f32, then the squared norm.
        let mut rng = crate::rng::Rng::new(6);
        for len in [0usize, 5, 8, 1003, 4096 + 3] {
            let mut noise = |s: f64| -> Vec<f32> {
                (0..len)
                    .map(|i| (s * rng.normal() * 10f64.powi((i % 7) as i32 - 3)) as f32)
                    .collect()
            };
            let grads = [noise(1.0), noise(0.5), noise(2.0)];
            let extra = noise(0.1);
            let views: Vec<&[f32]> = grads.iter().map(|g| g.as_slice()).collect();
            let g = gram(&views);
            for i in 0..3 {
                for j in 0..3 {
                    assert_eq!(g[i][j].to_bits(), plain_dot(&grads[i], &grads[j]).to_bits());
                }
            }
            let weight = [0.31f64, -0.07, 0.4];
            let want: Vec<f32> = (0..len)
                .map(|x| {
                    let s = (0..3).map(|m| weight[m] * grads[m][x] as f64).sum::<f64>() as f32;
                    s + extra[x]
                })
                .collect();
            let want_sq = plain_dot(&want, &want);
            let mut out = vec![0.0f32; len];
            let got_sq = combine(&mut out, &views, &weight, Some(&extra));
            let bits = |x: &[f32]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&out), bits(&want), "len {len}");
            assert_eq!(got_sq.to_bits(), want_sq.to_bits(), "len {len}");
            // Without the extra term, and the general path (two gradients).
            let mut plain = vec![0.0f32; len];
            combine(&mut plain, &views, &weight, None);
            let want: Vec<f32> = (0..len)
                .map(|x| (0..3).map(|m| weight[m] * grads[m][x] as f64).sum::<f64>() as f32)
                .collect();
            assert_eq!(bits(&plain), bits(&want));
            let two = combine(&mut plain, &views[..2], &weight[..2], None);
            assert_eq!(two.to_bits(), plain_dot(&plain, &plain).to_bits());
        }
    }
}
