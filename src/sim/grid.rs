//! Geometry of the staggered (MAC) grid: nx x ny cells of dx x dy; u on the nx+1 vertical
//! faces of each row, v on the ny+1 horizontal faces of each column, p at cell centres.
//! Index helpers give the position inside one environment's slice (x fastest).

use crate::config::Config;

/// The channel's staggered grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Cells along x.
    pub nx: usize,
    /// Cells across the height.
    pub ny: usize,
    /// Channel length L (m).
    pub length_m: f64,
    /// Channel height H (m).
    pub height_m: f64,
}

impl Grid {
    /// The grid of `c`'s `[domain]`.
    pub fn from_config(c: &Config) -> Self {
        Self {
            nx: c.domain.nx as usize,
            ny: c.domain.ny as usize,
            length_m: c.domain.length_m,
            height_m: c.domain.height_m,
        }
    }

    /// Cell width L / nx (m).
    pub fn dx(&self) -> f64 {
        self.length_m / self.nx as f64
    }

    /// Cell height H / ny (m).
    pub fn dy(&self) -> f64 {
        self.height_m / self.ny as f64
    }

    /// u faces per environment: ny x (nx + 1).
    pub fn n_u(&self) -> usize {
        self.ny * (self.nx + 1)
    }

    /// v faces per environment: (ny + 1) x nx.
    pub fn n_v(&self) -> usize {
        (self.ny + 1) * self.nx
    }

    /// Cells per environment: ny x nx.
    pub fn n_cells(&self) -> usize {
        self.nx * self.ny
    }

    /// Index of u face (i, j) in one environment's `[ny][nx+1]` slice.
    pub fn u_idx(&self, i: usize, j: usize) -> usize {
        j * (self.nx + 1) + i
    }

    /// Index of v face (i, j) in one environment's `[ny+1][nx]` slice.
    pub fn v_idx(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }

    /// Index of cell (i, j) in one environment's `[ny][nx]` slice.
    pub fn c_idx(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }

    /// Parabolic inlet profile 4 U y (H - y) / H^2 at the centre of row j.
    pub fn inlet_profile(&self, centre_u: f64, j: usize) -> f64 {
        let y = (j as f64 + 0.5) * self.dy();
        let h = self.height_m;
        4.0 * centre_u * y * (h - y) / (h * h)
    }
}
