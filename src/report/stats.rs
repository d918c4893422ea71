//! Statistics behind the learning curves and `report.md`.
//!
//! - rolling mean over the last w episodes of one environment (trailing window, shorter at
//!   the start): r_i = mean(v_{max(0, i-w+1)} ..= v_i);
//! - spread across environments: the population standard deviation
//!   sigma = sqrt(sum (v - mean)^2 / n);
//! - across seeds: the mean with a 95 % confidence half-width t_{0.975, n-1} s / sqrt(n), with s
//!   the sample standard deviation (n - 1);
//! - a curve is a step function: at x it holds the value of its last point at or before x.

/// Trailing rolling mean over `window` values (fewer at the start).
pub fn rolling_mean(values: &[f64], window: usize) -> Vec<f64> {
    let window = window.max(1);
    let mut out = Vec::with_capacity(values.len());
    let mut sum = 0.0;
    for (i, v) in values.iter().enumerate() {
        sum += v;
        if i >= window {
            sum -= values[i - window];
        }
        out.push(sum / (i + 1).min(window) as f64);
    }
    out
}

/// Mean and population standard deviation; (NaN, NaN) for no values.
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// Two-sided 95 % quantile of Student's t with `df` degrees of freedom (t_{0.975, df}).
pub fn t975(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => TABLE[df - 1],
        31..=60 => 2.0,
        _ => 1.96,
    }
}

/// Mean and 95 % confidence half-width of the mean (0 for a single value).
pub fn mean_ci95(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n < 2 {
        return (values.first().copied().unwrap_or(f64::NAN), 0.0);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let s = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    (mean, t975(n - 1) * s / (n as f64).sqrt())
}

/// The 95 % Wilson score interval of a binomial proportion k/n (z = 1.96):
/// (p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n); (0, 1) for n = 0.
pub fn wilson95(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z = 1.959_963_984_540_054;
    let (p, n) = (k as f64 / n as f64, n as f64);
    let d = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / d;
    let half = z / d * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// A curve with a band around it: `lo <= mean <= hi` at each `x`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Band {
    /// x of each point.
    pub x: Vec<f64>,
    /// Curve value at each point.
    pub mean: Vec<f64>,
    /// Lower edge of the band at each point.
    pub lo: Vec<f64>,
    /// Upper edge of the band at each point.
    pub hi: Vec<f64>,
}

impl Band {
    /// Appends a point: `mean` with the band `mean - below ..= mean + above`.
    fn push(&mut self, x: f64, mean: f64, below: f64, above: f64) {
        self.x.push(x);
        self.mean.push(mean);
        self.lo.push(mean - below);
        self.hi.push(mean + above);
    }

    /// The value at `x` of the step function through the means (None before the first point).
    pub fn at(&self, x: f64) -> Option<f64> {
        step_value(&self.x, &self.mean, x)
    }
}

/// The value at `x` of the step function through (xs, ys), xs ascending: the last y whose x is
/// at or before `x`.
pub fn step_value(xs: &[f64], ys: &[f64], x: f64) -> Option<f64> {
    let k = xs.partition_point(|&v| v <= x);
    (k > 0).then(|| ys[k - 1])
}

/// Mean +- 1 population standard deviation across series, each a step function
/// `(x ascending, value)`, on the union of their x. At each x only the series that have begun
/// count.
pub fn across_series_std(series: &[(Vec<f64>, Vec<f64>)]) -> Band {
    let mut band = Band::default();
    for g in union_grid(series.iter().map(|s| s.0.as_slice())) {
        let vals: Vec<f64> = series
            .iter()
            .filter_map(|(xs, ys)| step_value(xs, ys, g))
            .collect();
        let (m, s) = mean_std(&vals);
        band.push(g, m, s, s);
    }
    band
}

/// Mean with a 95 % confidence band across curves (e.g. one per seed), on the union of their x
/// where every curve has begun and none has ended. One curve is returned as it is.
pub fn across_seeds_ci(curves: &[Band]) -> Band {
    if curves.len() == 1 {
        return curves[0].clone();
    }
    let start = curves
        .iter()
        .filter_map(|c| c.x.first().copied())
        .fold(f64::NEG_INFINITY, f64::max);
    let end = curves
        .iter()
        .map(|c| c.x.last().copied().unwrap_or(f64::NEG_INFINITY))
        .fold(f64::INFINITY, f64::min);
    let grid = union_grid(curves.iter().map(|c| c.x.as_slice()));
    let mut band = Band::default();
    for g in grid.into_iter().filter(|&g| g >= start && g <= end) {
        let vals: Vec<f64> = curves.iter().filter_map(|c| c.at(g)).collect();
        let (m, h) = mean_ci95(&vals);
        band.push(g, m, h, h);
    }
    band
}

/// Sorted distinct x of all the given series.
fn union_grid<'a>(xs: impl Iterator<Item = &'a [f64]>) -> Vec<f64> {
    let mut grid: Vec<f64> = xs.flat_map(|x| x.iter().copied()).collect();
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    grid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_intervals_match_hand_computed_values() {
        // (0.1611...) is the textbook upper bound for 0 of 20; the rest by the formula by hand.
        for (k, n, lo, hi) in [
            (0, 20, 0.0, 0.161_125_158),
            (10, 20, 0.299_298_008, 0.700_701_992),
            (20, 20, 0.838_874_842, 1.0),
            (3, 40, 0.025_836_026, 0.198_642_335),
        ] {
            let (l, h) = wilson95(k, n);
            assert!(
                (l - lo).abs() < 1e-8 && (h - hi).abs() < 1e-8,
                "{k}/{n}: {l} {h}"
            );
        }
        assert_eq!(wilson95(0, 0), (0.0, 1.0));
    }

    #[test]
    fn rolling_mean_by_hand() {
        let r = rolling_mean(&[1.0, 2.0, 6.0, 3.0, 8.0, 10.0, -4.0], 5);
        // 1; (1+2)/2; (1+2+6)/3; (1+2+6+3)/4; (1+2+6+3+8)/5; (2+6+3+8+10)/5; (6+3+8+10-4)/5
        let want = [1.0, 1.5, 3.0, 3.0, 4.0, 5.8, 4.6];
        for (a, b) in r.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{r:?}");
        }
        assert_eq!(rolling_mean(&[], 5), Vec::<f64>::new());
    }

    #[test]
    fn std_across_environments_by_hand() {
        // env A: 1 at x=10, 3 at x=30; env B: 5 at x=20.
        let band =
            across_series_std(&[(vec![10.0, 30.0], vec![1.0, 3.0]), (vec![20.0], vec![5.0])]);
        assert_eq!(band.x, vec![10.0, 20.0, 30.0]);
        // x=10: only A (1) -> 1 +- 0; x=20: {1, 5} -> 3 +- 2; x=30: {3, 5} -> 4 +- 1.
        assert_eq!(band.mean, vec![1.0, 3.0, 4.0]);
        assert_eq!(band.lo, vec![1.0, 1.0, 3.0]);
        assert_eq!(band.hi, vec![1.0, 5.0, 5.0]);
        let (m, s) = mean_std(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!((m, s), (5.0, 2.0));
    }

    #[test]
    fn confidence_band_across_seeds_by_hand() {
        let c = |x: Vec<f64>, m: Vec<f64>| Band {
            lo: m.clone(),
            hi: m.clone(),
            x,
            mean: m,
        };
        let band = across_seeds_ci(&[
            c(vec![0.0, 10.0, 20.0], vec![1.0, 2.0, 3.0]),
            c(vec![5.0, 15.0], vec![3.0, 6.0]),
        ]);
        // Common range [5, 15]: x = 5, 10, 15.
        assert_eq!(band.x, vec![5.0, 10.0, 15.0]);
        assert_eq!(band.mean, vec![2.0, 2.5, 4.0]);
        // x=5: {1, 3}: s = sqrt(2), half-width 12.706 * sqrt(2) / sqrt(2) = 12.706.
        assert!((band.hi[0] - (2.0 + 12.706)).abs() < 1e-9);
        let (m, h) = mean_ci95(&[1.0, 2.0, 3.0]);
        assert_eq!(m, 2.0);
        assert!((h - 4.303 / 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn step_function_values() {
        let xs = [1.0, 2.0, 4.0];
        let ys = [10.0, 20.0, 40.0];
        assert_eq!(step_value(&xs, &ys, 0.5), None);
        assert_eq!(step_value(&xs, &ys, 2.0), Some(20.0));
        assert_eq!(step_value(&xs, &ys, 3.9), Some(20.0));
        assert_eq!(step_value(&xs, &ys, 9.0), Some(40.0));
    }
}
