//! Each CPU stage applied to a whole batch `[E]` as its WGSL kernel is, for the kernel tests
//! (`tests/kernels.rs`, `tests/swarm.rs`): the same functions the CPU step calls, looped over
//! the environments. Shapes as in [`super::BatchState`].

use super::advect::AdvectScratch;
use super::stencil::Dim;
use super::{diagnostics as diag, members, pressure, project as proj};
use crate::config::Advection;
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams};
use crate::sim::EnvHealth;

/// Inputs of the momentum predictor for the whole batch.
pub struct AdvectInputs<'a> {
    /// Input u face velocities `[E][ny][nx+1]` (m/s).
    pub u: &'a [f32],
    /// Input v face velocities `[E][ny+1][nx]` (m/s).
    pub v: &'a [f32],
    /// `[E][ny][nx]` (chi, u_body, v_body, 0).
    pub body: &'a [[f32; 4]],
    /// `[E][S]` inlet centreline velocity.
    pub inlet: &'a [f32],
    /// Index of the substep within the control step (selects the inlet value).
    pub substep: usize,
}

/// The momentum predictor (`advect.wgsl`): returns (u*, v*).
pub fn advect(p: &GpuParams, scheme: Advection, inp: &AdvectInputs) -> (Vec<f32>, Vec<f32>) {
    let d = Dim::new(p);
    let (nu, nv, nc) = (d.n_u(), d.n_v(), d.n_c());
    let mut u_out = vec![0.0; inp.u.len()];
    let mut v_out = vec![0.0; inp.v.len()];
    let mut s = AdvectScratch::default();
    for e in 0..p.n_env as usize {
        let centre = inp.inlet[e * p.substeps as usize + inp.substep];
        let body = &inp.body[e * nc..(e + 1) * nc];
        super::advect::advect::<false>(
            &d,
            scheme,
            &inp.u[e * nu..(e + 1) * nu],
            &inp.v[e * nv..(e + 1) * nv],
            body,
            super::advect::solid_extent(&d, body).as_ref(),
            centre,
            &mut s,
            &mut u_out[e * nu..(e + 1) * nu],
            &mut v_out[e * nv..(e + 1) * nv],
        );
    }
    (u_out, v_out)
}

/// `pressure_rhs.wgsl`: returns (modes `[E][ny][nx]`, divstar `[E][nx]`).
pub fn pressure_rhs(p: &GpuParams, poisson: &[f32], u: &[f32], v: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let d = Dim::new(p);
    let ne = p.n_env as usize;
    let (nu, nv, nc) = (d.n_u(), d.n_v(), d.n_c());
    let mut modes = vec![0.0; ne * nc];
    let mut divstar = vec![0.0; ne * d.nx];
    for e in 0..ne {
        pressure::rhs(
            &d,
            poisson,
            &u[e * nu..(e + 1) * nu],
            &v[e * nv..(e + 1) * nv],
            &mut modes[e * nc..(e + 1) * nc],
            &mut divstar[e * d.nx..(e + 1) * d.nx],
            &mut Vec::new(),
            &mut None,
        );
    }
    (modes, divstar)
}

/// `pressure_solve.wgsl`: in place on the modes.
pub fn pressure_solve(p: &GpuParams, poisson: &[f32], modes: &mut [f32]) {
    let d = Dim::new(p);
    for m in modes.chunks_mut(d.n_c()) {
        pressure::solve::<false>(&d, poisson, &[], m);
    }
}

/// `project.wgsl` (`pressure_back`, then `project`): corrects u, v in place and returns
/// p `[E][ny][nx]`.
pub fn project(
    p: &GpuParams,
    poisson: &[f32],
    modes: &[f32],
    u: &mut [f32],
    v: &mut [f32],
) -> Vec<f32> {
    let d = Dim::new(p);
    let (nu, nv, nc) = (d.n_u(), d.n_v(), d.n_c());
    let mut pres = vec![0.0; modes.len()];
    for e in 0..p.n_env as usize {
        let pe = &mut pres[e * nc..(e + 1) * nc];
        pressure::back::<false>(
            &d,
            poisson,
            &modes[e * nc..(e + 1) * nc],
            pe,
            &mut Vec::new(),
            &mut None,
        );
        proj::project_in_place(
            &d,
            pe,
            &mut u[e * nu..(e + 1) * nu],
            &mut v[e * nv..(e + 1) * nv],
        );
    }
    pres
}

/// `diagnostics.wgsl`: the health of every environment.
pub fn diagnostics(
    p: &GpuParams,
    u: &[f32],
    v: &[f32],
    pres: &[f32],
    divstar: &[f32],
) -> Vec<EnvHealth> {
    let d = Dim::new(p);
    let (nu, nv, nc) = (d.n_u(), d.n_v(), d.n_c());
    (0..p.n_env as usize)
        .map(|e| {
            diag::diagnostics(
                &d,
                &u[e * nu..(e + 1) * nu],
                &v[e * nv..(e + 1) * nv],
                &pres[e * nc..(e + 1) * nc],
                &divstar[e * d.nx..(e + 1) * d.nx],
            )
        })
        .collect()
}

/// `paint_bodies` (`members.wgsl`): the body field `[E][ny][nx]` from the members.
pub fn paint_bodies(p: &GpuParams, members: &[GpuMember], swarm_box: &[[f32; 4]]) -> Vec<[f32; 4]> {
    let d = Dim::new(p);
    let (n, nc) = (p.n_members as usize, d.n_c());
    let mut body = vec![[0.0f32; 4]; p.n_env as usize * nc];
    for (e, cells) in body.chunks_mut(nc).enumerate() {
        members::paint_bodies(&d, &members[e * n..(e + 1) * n], swarm_box[e], cells, None);
    }
    body
}

/// `move_members` (`members.wgsl`) for every environment: the moved members, their forces and
/// samples, and the swarm boxes. `u`, `v` are the projected velocity.
pub fn move_members(
    p: &GpuParams,
    members: &[GpuMember],
    actions: &[[f32; 2]],
    pres: &[f32],
    u: &[f32],
    v: &[f32],
) -> (Vec<GpuMember>, Vec<GpuMemberDiag>, Vec<[f32; 4]>) {
    let d = Dim::new(p);
    let (ne, n) = (p.n_env as usize, p.n_members as usize);
    let (nu, nv, nc) = (d.n_u(), d.n_v(), d.n_c());
    let mut out = members.to_vec();
    let mut diags = vec![GpuMemberDiag::default(); ne * n];
    let mut boxes = vec![[0.0f32; 4]; ne];
    for e in 0..ne {
        members::move_members(
            &d,
            &mut out[e * n..(e + 1) * n],
            &actions[e * n..(e + 1) * n],
            &pres[e * nc..(e + 1) * nc],
            &u[e * nu..(e + 1) * nu],
            &v[e * nv..(e + 1) * nv],
            &mut diags[e * n..(e + 1) * n],
            &mut boxes[e],
        );
    }
    (out, diags, boxes)
}
