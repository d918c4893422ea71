//! Explicit viscous diffusion of the input velocity, w = u + dt nu lap u, on every face
//! (inlet u faces and the wall v faces keep u and 0), the first half of the momentum predictor.
//! Mirrors `diffuse` in `shaders/advect.wgsl`. Shapes: u `[ny][nx+1]`, v `[ny+1][nx]`; w_u, w_v
//! padded with their ghosts as in `sample`, ready to be sampled.
//! Cost: 5 loads, 1 store and 10 flops per face; interior runs of a row go through a
//! branch-free loop (which the compiler vectorises), faces next to a boundary map their ghosts.

use super::sample::Padded;
use super::stencil::Dim;

/// w = u + dt nu lap u into `w_u`, `w_v` (sized and their ghosts filled here).
#[allow(clippy::needless_range_loop)] // input and padded output rows indexed together
#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn diffuse(d: &Dim, u: &[f32], v: &[f32], w_u: &mut Padded, w_v: &mut Padded) {
    use super::sample::Face;
    w_u.resize(d, Face::U);
    w_v.resize(d, Face::V);
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
        let o = w_u.at_u(0, j as isize);
        let out = &mut w_u.data[o..o + row];
        out[0] = u[j * row];
        if j >= 1 && j + 1 < ny {
            let (down, mid, up) = (
                &u[(j - 1) * row..j * row],
                &u[j * row..(j + 1) * row],
                &u[(j + 1) * row..(j + 2) * row],
            );
            for i in 1..nx {
                let c = mid[i];
                let lx = mid[i + 1] + mid[i - 1] - 2.0 * c;
                let ly = up[i] + down[i] - 2.0 * c;
                out[i] = c + coef * (lx / ax + ly / ay);
            }
            out[nx] = edge_u(nx, j);
        } else {
            for (i, w) in out.iter_mut().enumerate().skip(1) {
                *w = edge_u(i, j);
            }
        }
    }
    w_u.fill_ghosts_u(d);
    let edge_v = |i: usize, j: usize| {
        let (a, b) = (i as i32, j as i32);
        let c = v[j * nx + i];
        let lx = d.fetch_v(v, a + 1, b) + d.fetch_v(v, a - 1, b) - 2.0 * c;
        let ly = d.fetch_v(v, a, b + 1) + d.fetch_v(v, a, b - 1) - 2.0 * c;
        c + coef * (lx / ax + ly / ay)
    };
    for j in [0, ny] {
        let o = w_v.at_v(0, j);
        w_v.data[o..o + nx].fill(0.0);
    }
    for j in 1..ny {
        let o = w_v.at_v(0, j);
        let out = &mut w_v.data[o..o + nx];
        out[0] = edge_v(0, j);
        let (down, mid, up) = (
            &v[(j - 1) * nx..j * nx],
            &v[j * nx..(j + 1) * nx],
            &v[(j + 1) * nx..(j + 2) * nx],
        );
        for i in 1..nx - 1 {
            let c = mid[i];
            let lx = mid[i + 1] + mid[i - 1] - 2.0 * c;
            let ly = up[i] + down[i] - 2.0 * c;
            out[i] = c + coef * (lx / ax + ly / ay);
        }
        out[nx - 1] = edge_v(nx - 1, j);
    }
    w_v.fill_ghosts_v(d);
}
