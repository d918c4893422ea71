//! The velocity correction of the projection, u = u* - dt/rho grad p, on every interior face
//! (the outlet face sees the ghost p = -p_last, i.e. p = 0 on the face; the inlet u faces and
//! the wall v faces keep their boundary values). Mirrors `project` in `shaders/project.wgsl`.
//! Shapes: u `[ny][nx+1]`, v `[ny+1][nx]`, p `[ny][nx]`. 2 loads, 1 store, 4 flops per face.

use super::stencil::Dim;

/// Subtracts dt/rho grad p from u, v in place.
#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn project(d: &Dim, pres: &[f32], u: &mut [f32], v: &mut [f32]) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let scale = p.dt / p.rho;
    let row = nx + 1;
    for j in 0..ny {
        let (cells, faces) = (
            &pres[j * nx..(j + 1) * nx],
            &mut u[j * row + 1..(j + 1) * row],
        );
        for i in 0..nx - 1 {
            faces[i] -= scale * (cells[i + 1] - cells[i]) / p.dx;
        }
        // The outlet face: the ghost p = -p_last.
        let left = cells[nx - 1];
        faces[nx - 1] -= scale * (-left - left) / p.dx;
    }
    for j in 1..ny {
        let (below, above) = (&pres[(j - 1) * nx..j * nx], &pres[j * nx..(j + 1) * nx]);
        for (i, face) in v[j * nx..(j + 1) * nx].iter_mut().enumerate() {
            *face -= scale * (above[i] - below[i]) / p.dy;
        }
    }
}
