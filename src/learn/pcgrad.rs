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

fn dot(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| *x as f64 * *y as f64).sum()
}

/// PCGrad with `order[i]`: the objectives g_i is projected against, in that order.
pub fn pcgrad(grads: &[Vec<f32>], order: &[Vec<usize>]) -> Surgery {
    let k = grads.len();
    assert!(
        k > 0 && order.len() == k,
        "one projection order per gradient"
    );
    let len = grads[0].len();
    let mut combined = vec![0.0f64; len];
    for (i, g) in grads.iter().enumerate() {
        let mut p: Vec<f64> = g.iter().map(|&x| x as f64).collect();
        for &j in &order[i] {
            assert_ne!(i, j, "a gradient is not projected against itself");
            let gj = &grads[j];
            let d: f64 = p.iter().zip(gj).map(|(a, b)| a * *b as f64).sum();
            let nn = dot(gj, gj);
            if d < 0.0 && nn > 0.0 {
                for (x, y) in p.iter_mut().zip(gj) {
                    *x -= d / nn * *y as f64;
                }
            }
        }
        for (c, x) in combined.iter_mut().zip(&p) {
            *c += x / k as f64;
        }
    }
    let (mut cosines, mut conflicts) = (Vec::new(), Vec::new());
    for i in 0..k {
        for j in i + 1..k {
            let d = dot(&grads[i], &grads[j]);
            let n = (dot(&grads[i], &grads[i]) * dot(&grads[j], &grads[j])).sqrt();
            cosines.push(if n > 0.0 { (d / n) as f32 } else { 0.0 });
            conflicts.push(d < 0.0);
        }
    }
    Surgery {
        combined: combined.into_iter().map(|x| x as f32).collect(),
        cosines,
        conflicts,
    }
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
}
