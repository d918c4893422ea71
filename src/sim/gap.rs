//! The flow past the swarm, the measure behind the paper's "throttling" claim (a formation
//! that lowers the peak local velocity, about 700 to 400 mm/s in the paper).
//!
//! Over the columns of cells whose centres lie in the swarm's x extent
//! [min_i x_i - r, max_i x_i + r]:
//! - `peak_u` = max u_x over the fluid cells (centre outside every member's disc |c - x_i| < r);
//! - a column's blocked fraction = (cells inside some disc) / ny, reported as its mean and its
//!   maximum over those columns.
//!
//! Input: u_x at cell centres `[ny][nx]` (row 0 at the bottom wall, cell (i, j) centred at
//! ((i + 1/2) dx, (j + 1/2) dy)) and the member centres `[N]` (m). Cost: columns x ny x N
//! distance tests, about 50k for the refined frontier grid, once per traced step.

use super::Grid;

/// The flow past the swarm at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GapMetrics {
    /// The swarm's x extent, lower edge (m): min x_i - r.
    pub x_lo_m: f64,
    /// The swarm's x extent, upper edge (m): max x_i + r.
    pub x_hi_m: f64,
    /// The largest u_x over the fluid cells of the extent's columns (m/s).
    pub peak_u_m_s: f64,
    /// The mean over those columns of the fraction of their cells inside a member.
    pub mean_blocked: f64,
    /// The largest such fraction.
    pub max_blocked: f64,
}

/// The flow past members centred at `centres` (m) of radius `radius_m`, in the cell-centred
/// u_x field `ux` `[ny][nx]` of grid `g`. With no members (or an extent between cell centres)
/// the peak is NaN and the fractions are zero.
pub fn gap_metrics(g: &Grid, ux: &[f32], centres: &[[f64; 2]], radius_m: f64) -> GapMetrics {
    let (dx, dy) = (g.dx(), g.dy());
    let x_lo = centres.iter().map(|c| c[0]).fold(f64::INFINITY, f64::min) - radius_m;
    let x_hi = centres
        .iter()
        .map(|c| c[0])
        .fold(f64::NEG_INFINITY, f64::max)
        + radius_m;
    let mut out = GapMetrics {
        x_lo_m: x_lo,
        x_hi_m: x_hi,
        peak_u_m_s: f64::NAN,
        mean_blocked: 0.0,
        max_blocked: 0.0,
    };
    if centres.is_empty() {
        return out;
    }
    // Columns whose centre (i + 1/2) dx lies in [x_lo, x_hi].
    let first = ((x_lo / dx - 0.5).ceil().max(0.0)) as usize;
    let last = ((x_hi / dx - 0.5).floor()).min(g.nx as f64 - 1.0);
    if last < first as f64 {
        return out;
    }
    let (last, r2) = (last as usize, radius_m * radius_m);
    let mut blocked_sum = 0.0;
    for i in first..=last {
        let x = (i as f64 + 0.5) * dx;
        let mut blocked = 0usize;
        for j in 0..g.ny {
            let y = (j as f64 + 0.5) * dy;
            let inside = centres
                .iter()
                .any(|c| (x - c[0]).powi(2) + (y - c[1]).powi(2) < r2);
            if inside {
                blocked += 1;
            } else {
                let u = ux[j * g.nx + i] as f64;
                if out.peak_u_m_s.is_nan() || u > out.peak_u_m_s {
                    out.peak_u_m_s = u;
                }
            }
        }
        let fraction = blocked as f64 / g.ny as f64;
        blocked_sum += fraction;
        out.max_blocked = out.max_blocked.max(fraction);
    }
    out.mean_blocked = blocked_sum / (last + 1 - first) as f64;
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 x 4 grid of 1 mm cells.
    fn grid() -> Grid {
        Grid {
            nx: 10,
            ny: 4,
            length_m: 0.010,
            height_m: 0.004,
        }
    }

    /// u_x = column index + row / 10 (m/s), so every cell's value names it.
    fn field(g: &Grid) -> Vec<f32> {
        (0..g.ny)
            .flat_map(|j| (0..g.nx).map(move |i| i as f32 + j as f32 / 10.0))
            .collect()
    }

    #[test]
    fn one_member_blocks_its_cells_and_the_peak_skips_them() {
        let g = grid();
        // Centre (4.5, 1.5) mm, r = 1.1 mm: cells (4,1) at distance 0, (3,1), (5,1), (4,0),
        // (4,2) at 1.0 mm are inside; diagonals at 1.414 mm are not. The extent 3.4..5.6 mm
        // holds the column centres 3.5, 4.5 and 5.5 mm (columns 3, 4, 5).
        let m = gap_metrics(&g, &field(&g), &[[0.0045, 0.0015]], 0.0011);
        assert!((m.x_lo_m - 0.0034).abs() < 1e-12 && (m.x_hi_m - 0.0056).abs() < 1e-12);
        // Column 3: row 1 blocked; column 4: rows 0, 1, 2; column 5: row 1.
        assert_eq!(m.max_blocked, 0.75);
        assert!((m.mean_blocked - (0.25 + 0.75 + 0.25) / 3.0).abs() < 1e-12);
        // The fastest fluid cell is column 5, row 3 (5.3); column 5 row 1 (5.1) is blocked.
        assert!((m.peak_u_m_s - 5.3).abs() < 1e-6);
    }

    #[test]
    fn a_full_column_is_blocked_whole_and_the_extent_is_clamped_to_the_grid() {
        let g = grid();
        // Two members at x = 0.5 mm, y = 1 and 3 mm, r = 1.2 mm. The extent -0.7..1.7 mm is
        // clamped to columns 0 and 1. Every cell of column 0 is 0.5 mm from a centre, and
        // every cell of column 1 is sqrt(1 + 0.25) = 1.118 mm from one: all are inside.
        let centres = [[0.0005, 0.001], [0.0005, 0.003]];
        let m = gap_metrics(&g, &field(&g), &centres, 0.0012);
        assert_eq!(m.max_blocked, 1.0);
        // Every cell of both columns is blocked, so no fluid cell is left.
        assert_eq!(m.mean_blocked, 1.0);
        assert!(m.peak_u_m_s.is_nan());
    }

    #[test]
    fn no_members_give_no_extent() {
        let g = grid();
        let m = gap_metrics(&g, &field(&g), &[], 0.001);
        assert!(m.peak_u_m_s.is_nan());
        assert_eq!((m.mean_blocked, m.max_blocked), (0.0, 0.0));
    }
}
