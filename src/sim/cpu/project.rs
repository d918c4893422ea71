//! The velocity correction of the projection, u = u* - dt/rho grad p, on every interior face
//! (the outlet face sees the ghost p = -p_last, i.e. p = 0 on the face; the inlet u faces and
//! the wall v faces keep their boundary values). Mirrors `project` in `shaders/project.wgsl`.
//! Shapes: u `[ny][nx+1]`, v `[ny+1][nx]`, p `[ny][nx]`. Reads u*, v* (the advected velocity)
//! and writes u, v of the state: 3 loads, 1 store, 4 flops per face.

use super::stencil::Dim;

/// u = u* - dt/rho grad p and likewise v, written into `u`, `v` from `u_star`, `v_star` (the
/// faces the correction does not touch are copied): the projection and the copy of the
/// corrected velocity into the state in one pass.
#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn project(
    d: &Dim,
    pres: &[f32],
    (u_star, v_star): (&[f32], &[f32]),
    u: &mut [f32],
    v: &mut [f32],
) {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let scale = p.dt / p.rho;
    let row = nx + 1;
    for j in 0..ny {
        let cells = &pres[j * nx..(j + 1) * nx];
        let star = &u_star[j * row..(j + 1) * row];
        let out = &mut u[j * row..(j + 1) * row];
        // The inlet face keeps its boundary value.
        out[0] = star[0];
        let (star, out) = (&star[1..], &mut out[1..]);
        for i in 0..nx - 1 {
            out[i] = star[i] - scale * (cells[i + 1] - cells[i]) / p.dx;
        }
        // The outlet face: the ghost p = -p_last.
        let left = cells[nx - 1];
        out[nx - 1] = star[nx - 1] - scale * (-left - left) / p.dx;
    }
    // The wall faces keep their boundary values.
    v[..nx].copy_from_slice(&v_star[..nx]);
    v[ny * nx..].copy_from_slice(&v_star[ny * nx..]);
    for j in 1..ny {
        let (below, above) = (&pres[(j - 1) * nx..j * nx], &pres[j * nx..(j + 1) * nx]);
        let star = &v_star[j * nx..(j + 1) * nx];
        for (i, face) in v[j * nx..(j + 1) * nx].iter_mut().enumerate() {
            *face = star[i] - scale * (above[i] - below[i]) / p.dy;
        }
    }
}

/// [`project`] in place on u, v.
pub(crate) fn project_in_place(d: &Dim, pres: &[f32], u: &mut [f32], v: &mut [f32]) {
    let (u_star, v_star) = (u.to_vec(), v.to_vec());
    project(d, pres, (&u_star, &v_star), u, v);
}
