//! Tables of the exact fast solver for the empty channel's pressure Poisson equation.
//!
//! The 5-point Laplacian on the cells, with Neumann walls and inlet and p = 0 on the outlet
//! face, is separable: L = Lx (x) I + I (x) Ly. Ly (Neumann-Neumann, ny x ny) is diagonalised by
//! the orthonormal DCT-II  Q`[j][k]` = c_k cos(pi k (j + 1/2) / ny)  with eigenvalues
//! lambda_k = -4 sin^2(pi k / (2 ny)) / dy^2. Each mode k leaves a tridiagonal system along x,
//!   p`[i-1]` + (-2 + lambda_k dx^2) p`[i]` + p`[i+1]` = dx^2 b`[i]`,
//! with the first diagonal entry -1 + lambda_k dx^2 (Neumann inlet) and the last
//! -3 + lambda_k dx^2 (ghost p`[nx]` = -p`[nx-1]`). Its Thomas factors (c'`[i]`, 1/m`[i]`) are
//! computed here in f64, once.
//! GPU buffer layout (f32): [Q: ny*ny, Q[j*ny + k]] [c': ny*nx, k-major] [1/m: ny*nx, k-major]
//! [forward vec4 table] [backward vec4 table] (see [`PoissonTables::forward_packed`] and
//! [`PoissonTables::backward_packed`]: Q regrouped so that the transforms do four modes or
//! four rows per load of the column).

use super::Grid;

/// The fast solver's tables for one grid, in f64.
#[derive(Debug, Clone)]
pub struct PoissonTables {
    /// Cells along x.
    pub nx: usize,
    /// Cells across the height.
    pub ny: usize,
    /// Q[j * ny + k].
    pub q: Vec<f64>,
    /// c'[k * nx + i].
    pub c_prime: Vec<f64>,
    /// 1 / m[k * nx + i].
    pub m_inv: Vec<f64>,
}

impl PoissonTables {
    /// Computes Q and the Thomas factors of every mode for `grid`.
    pub fn new(grid: &Grid) -> Self {
        let (nx, ny) = (grid.nx, grid.ny);
        let (dx, dy) = (grid.dx(), grid.dy());
        let pi = std::f64::consts::PI;
        let mut q = vec![0.0; ny * ny];
        for j in 0..ny {
            for k in 0..ny {
                let c = if k == 0 {
                    (1.0 / ny as f64).sqrt()
                } else {
                    (2.0 / ny as f64).sqrt()
                };
                q[j * ny + k] = c * (pi * k as f64 * (j as f64 + 0.5) / ny as f64).cos();
            }
        }
        let mut c_prime = vec![0.0; ny * nx];
        let mut m_inv = vec![0.0; ny * nx];
        for k in 0..ny {
            let shift = eigenvalue(k, ny, dy) * dx * dx;
            let mut prev_c = 0.0;
            for i in 0..nx {
                let b = match i {
                    0 => -1.0 + shift,
                    _ if i == nx - 1 => -3.0 + shift,
                    _ => -2.0 + shift,
                };
                let a = if i == 0 { 0.0 } else { 1.0 };
                let c = if i == nx - 1 { 0.0 } else { 1.0 };
                let m = b - a * prev_c;
                c_prime[k * nx + i] = c / m;
                m_inv[k * nx + i] = 1.0 / m;
                prev_c = c / m;
            }
        }
        Self {
            nx,
            ny,
            q,
            c_prime,
            m_inv,
        }
    }

    /// Rows of the half column: (ny + 1) / 2 (the middle row of an odd ny included).
    pub fn half_rows(&self) -> usize {
        self.ny.div_ceil(2)
    }

    /// Groups of four modes of one parity: ceil(ceil(ny / 2) / 4).
    pub fn mode_groups(&self) -> usize {
        self.ny.div_ceil(2).div_ceil(4)
    }

    /// The forward transform's table, `[parity][group][row][4]`: entry c is
    /// Q[row][8 group + parity + 2c] (0 past ny, and 0 for odd modes on the middle row of an odd
    /// ny, which they do not reach). Even modes multiply b_j + b_{ny-1-j} (b_mid on the middle
    /// row), odd modes b_j - b_{ny-1-j}.
    pub fn forward_packed(&self) -> Vec<f64> {
        let (ny, hr, g) = (self.ny, self.half_rows(), self.mode_groups());
        let mut out = Vec::with_capacity(2 * g * hr * 4);
        for parity in 0..2 {
            for group in 0..g {
                for row in 0..hr {
                    for c in 0..4 {
                        let k = 8 * group + parity + 2 * c;
                        let middle = ny % 2 == 1 && row == ny / 2;
                        let odd_on_middle = parity == 1 && middle;
                        out.push(if k < ny && !odd_on_middle {
                            self.q[row * ny + k]
                        } else {
                            0.0
                        });
                    }
                }
            }
        }
        out
    }

    /// The backward transform's table, `[row group][mode][4]`: entry c is Q`[4 group + c][k]`
    /// (0 past the half rows).
    pub fn backward_packed(&self) -> Vec<f64> {
        let (ny, hr) = (self.ny, self.half_rows());
        let mut out = Vec::with_capacity(hr.div_ceil(4) * ny * 4);
        for group in 0..hr.div_ceil(4) {
            for k in 0..ny {
                for c in 0..4 {
                    let row = 4 * group + c;
                    out.push(if row < hr { self.q[row * ny + k] } else { 0.0 });
                }
            }
        }
        out
    }

    /// The concatenated f32 buffer the GPU reads.
    pub fn to_gpu(&self) -> Vec<f32> {
        self.q
            .iter()
            .chain(&self.c_prime)
            .chain(&self.m_inv)
            .chain(&self.forward_packed())
            .chain(&self.backward_packed())
            .map(|&x| x as f32)
            .collect()
    }
}

/// Eigenvalue of the Neumann-Neumann second difference for mode k.
pub fn eigenvalue(k: usize, ny: usize, dy: f64) -> f64 {
    let s = (std::f64::consts::PI * k as f64 / (2.0 * ny as f64)).sin();
    -4.0 * s * s / (dy * dy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q_is_orthonormal() {
        let g = Grid {
            nx: 5,
            ny: 7,
            length_m: 1.0,
            height_m: 1.0,
        };
        let t = PoissonTables::new(&g);
        for a in 0..7 {
            for b in 0..7 {
                let dot: f64 = (0..7).map(|j| t.q[j * 7 + a] * t.q[j * 7 + b]).sum();
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((dot - want).abs() < 1e-12, "{a} {b} {dot}");
            }
        }
    }

    #[test]
    fn columns_are_eigenvectors_of_the_neumann_second_difference() {
        let ny = 9;
        let dy = 0.5;
        let g = Grid {
            nx: 3,
            ny,
            length_m: 1.0,
            height_m: ny as f64 * dy,
        };
        let t = PoissonTables::new(&g);
        for k in 0..ny {
            let v: Vec<f64> = (0..ny).map(|j| t.q[j * ny + k]).collect();
            for j in 0..ny {
                let lo = if j == 0 { v[0] } else { v[j - 1] };
                let hi = if j == ny - 1 { v[ny - 1] } else { v[j + 1] };
                let lap = (lo - 2.0 * v[j] + hi) / (dy * dy);
                assert!((lap - eigenvalue(k, ny, dy) * v[j]).abs() < 1e-10);
            }
        }
    }
}
