//! Explicit viscous diffusion of the input velocity, w = u + dt nu lap u, on every face
//! (inlet u faces and the wall v faces keep u and 0), the first half of the momentum predictor.
//! Mirrors `diffuse` in `shaders/advect.wgsl`. Shapes: u, w_u [ny][nx+1]; v, w_v [ny+1][nx].
//! Cost: 5 loads, 1 store and 10 flops per face; interior runs of a row go through a
//! branch-free loop (which the compiler vectorises), faces next to a boundary map their ghosts.

use super::stencil::Dim;

/// w = u + dt nu lap u into `w_u`, `w_v`.
pub(crate) fn diffuse(d: &Dim, u: &[f32], v: &[f32], w_u: &mut [f32], w_v: &mut [f32]) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let (ax, ay) = (p.dx * p.dx, p.dy * p.dy);
    let coef = p.dt * p.nu;
    let row = nx + 1;
    let edge_u = |i: usize, j: usize| {
        let (a, b) = (i as i32, j as i32);
        let c = d.fetch_u(u, a, b);
        let lx = d.fetch_u(u, a + 1, b) + d.fetch_u(u, a - 1, b) - 2.0 * c;
        let ly = d.fetch_u(u, a, b + 1) + d.fetch_u(u, a, b - 1) - 2.0 * c;
        u[j * row + i] + coef * (lx / ax + ly / ay)
    };
    for j in 0..ny {
        w_u[j * row] = u[j * row];
        if j >= 1 && j + 1 < ny {
            let (lo, hi) = (j * row + 1, j * row + nx);
            for k in lo..hi {
                let c = u[k];
                let lx = u[k + 1] + u[k - 1] - 2.0 * c;
                let ly = u[k + row] + u[k - row] - 2.0 * c;
                w_u[k] = c + coef * (lx / ax + ly / ay);
            }
            w_u[j * row + nx] = edge_u(nx, j);
        } else {
            for i in 1..=nx {
                w_u[j * row + i] = edge_u(i, j);
            }
        }
    }
    let edge_v = |i: usize, j: usize| {
        let (a, b) = (i as i32, j as i32);
        let c = v[j * nx + i];
        let lx = d.fetch_v(v, a + 1, b) + d.fetch_v(v, a - 1, b) - 2.0 * c;
        let ly = d.fetch_v(v, a, b + 1) + d.fetch_v(v, a, b - 1) - 2.0 * c;
        c + coef * (lx / ax + ly / ay)
    };
    w_v[..nx].fill(0.0);
    w_v[ny * nx..(ny + 1) * nx].fill(0.0);
    for j in 1..ny {
        w_v[j * nx] = edge_v(0, j);
        for k in j * nx + 1..j * nx + nx - 1 {
            let c = v[k];
            let lx = v[k + 1] + v[k - 1] - 2.0 * c;
            let ly = v[k + nx] + v[k - nx] - 2.0 * c;
            w_v[k] = c + coef * (lx / ax + ly / ay);
        }
        w_v[j * nx + nx - 1] = edge_v(nx - 1, j);
    }
}
