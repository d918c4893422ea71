//! The CPU control step, written once, a module per stage: [`diffuse`], [`advect`](mod@advect),
//! [`pressure`] (right-hand side, tridiagonal solve, back-transform), [`project`](mod@project), [`members`]
//! (paint, move) and [`diagnostics`](mod@diagnostics). It is both the production CPU backend ([`CpuBatch`],
//! `solver.backend = "native"`) and the reference the WGSL kernels are tested against
//! ([`stages`] applies each stage to a whole batch as a kernel does).
//!
//! Per substep of one environment (SPEC section 1):
//!   paint     body = members painted as discs                  (with a swarm)
//!   advect    u* = A(u^n + dt nu lap u^n), inlet, Brinkman     (diffuse + advect)
//!   pressure  phat = Q^T (rho/dt div u*); (L_x + lambda_k) p_k = phat_k; p = Q p_k
//!   project   u = u* - dt/rho grad p
//!   move      members forced and moved in (u, p)               (with a swarm)
//! State ([`BatchState`], environment outermost): u `[E][ny][nx+1]`, v `[E][ny+1][nx]`,
//! p and body `[E][ny][nx]`, divstar `[E][nx]`, members and actions `[E][N]`, boxes `[E]`.
//! Environments are independent: one rayon task steps one environment through a whole control
//! step, so the result does not depend on the number of threads. [`timing`] times the stages
//! when asked ([`BatchState::step_timed`], [`CpuBatch::profile_step`]) and [`counts`] counts
//! their arithmetic and memory traffic, for `bench`'s roofline.

pub mod advect;
mod batch;
pub mod counts;
pub mod diagnostics;
pub mod diffuse;
pub mod members;
pub mod pressure;
#[cfg(target_arch = "x86_64")]
mod pressure_avx2;
pub mod project;
mod sample;
#[cfg(target_arch = "x86_64")]
mod sample_avx2;
pub mod simd;
pub mod stages;
pub(crate) mod stencil;
pub mod timing;

pub use batch::CpuBatch;
pub use counts::{BodyLoad, StageWork, Work};
pub use members::{cd_times_speed, propulsion};
pub use stages::{
    AdvectInputs, advect, diagnostics, move_members, paint_bodies, pressure_rhs, pressure_solve,
    project,
};
pub use timing::{CpuStage, StageTimes};

use rayon::prelude::*;

use super::EnvHealth;
use crate::config::Advection;
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams};
use advect::AdvectScratch;
use stencil::Dim;
use timing::StageClock;

/// The state of a whole batch on the host: what a control step reads and writes. The GPU
/// batch reads its buffers into one ([`crate::sim::FlowBatch::state`]) and the CPU batch
/// steps one in place.
#[derive(Debug, Clone)]
pub struct BatchState {
    /// Batch-wide constants, as the kernels read them.
    pub params: GpuParams,
    /// Advection scheme.
    pub scheme: Advection,
    /// The fast solver's tables ([`crate::sim::poisson::PoissonTables::to_gpu`]).
    pub poisson: Vec<f32>,
    /// u face velocities `[E][ny][nx+1]` (m/s).
    pub u: Vec<f32>,
    /// v face velocities `[E][ny+1][nx]` (m/s).
    pub v: Vec<f32>,
    /// Cell pressure `[E][ny][nx]` (Pa).
    pub p: Vec<f32>,
    /// Body field (chi, u_body, v_body, 0) `[E][ny][nx]`.
    pub body: Vec<[f32; 4]>,
    /// max_j abs(div u*) of each column before the projection `[E][nx]` (1/s).
    pub divstar: Vec<f32>,
    /// Members `[E][N]`, their raw actions and the swarm boxes `[E]` (empty without a swarm).
    pub members: Vec<GpuMember>,
    /// Raw actions `[E][N]`.
    pub actions: Vec<[f32; 2]>,
    /// Swarm box (x_min, x_max, y_min, y_max) of the member centres `[E]` (m).
    pub boxes: Vec<[f32; 4]>,
}

/// Reusable buffers of one environment's step.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    advect: AdvectScratch,
    u_out: Vec<f32>,
    v_out: Vec<f32>,
    modes: Vec<f32>,
    /// A block of columns of the pressure transforms, [ny][32].
    columns: Vec<f32>,
    /// The FFT plans of the y-transforms on tall grids.
    fast_y: Option<pressure::FastY>,
    /// The Thomas factors interleaved for the AVX2 sweeps, remade every control step.
    sweep: Vec<f32>,
    /// Take the plain path even where AVX2 is present ([`Scratch::portable`]).
    portable: bool,
}

impl Scratch {
    /// Scratch whose step takes the plain-Rust path whatever the processor has: the reference
    /// the AVX2 path is tested against (the two give the same bits).
    pub fn portable() -> Self {
        Self {
            portable: true,
            ..Self::default()
        }
    }
}

/// One environment's part of a [`BatchState`], borrowed for its step.
struct EnvMut<'a> {
    u: &'a mut [f32],
    v: &'a mut [f32],
    p: &'a mut [f32],
    body: &'a mut [[f32; 4]],
    divstar: &'a mut [f32],
    members: &'a mut [GpuMember],
    actions: &'a [[f32; 2]],
    bx: &'a mut [f32; 4],
    diags: &'a mut [GpuMemberDiag],
}

/// `data` as `n_env` consecutive chunks of `len` (empty chunks when len is 0).
fn chunks<T>(data: &mut [T], len: usize, n_env: usize) -> Vec<&mut [T]> {
    if len == 0 {
        return (0..n_env).map(|_| <&mut [T]>::default()).collect();
    }
    data.chunks_mut(len).collect()
}

impl BatchState {
    /// One control step of every environment; `inlet` is `[E][S]`. With members, each substep
    /// paints them into the body field first and moves them after the projection.
    pub fn step(&mut self, inlet: &[f32]) -> Vec<EnvHealth> {
        let ne = self.params.n_env as usize;
        let mut scratch = vec![Scratch::default(); ne];
        let mut diags = vec![GpuMemberDiag::default(); ne * self.params.n_members as usize];
        self.step_with(inlet, &mut scratch, &mut diags)
    }

    /// [`Self::step`] with the caller's scratch (one per environment) and the members' forces
    /// of the last substep written to `diags` `[E][N]`.
    pub fn step_with(
        &mut self,
        inlet: &[f32],
        scratch: &mut [Scratch],
        diags: &mut [GpuMemberDiag],
    ) -> Vec<EnvHealth> {
        self.step_inner(inlet, scratch, diags, None)
    }

    /// [`Self::step_with`] with each environment's stage times added to `times` `[E]`; the
    /// same state, bit for bit.
    pub fn step_timed(
        &mut self,
        inlet: &[f32],
        scratch: &mut [Scratch],
        diags: &mut [GpuMemberDiag],
        times: &mut [StageTimes],
    ) -> Vec<EnvHealth> {
        self.step_inner(inlet, scratch, diags, Some(times))
    }

    fn step_inner(
        &mut self,
        inlet: &[f32],
        scratch: &mut [Scratch],
        diags: &mut [GpuMemberDiag],
        times: Option<&mut [StageTimes]>,
    ) -> Vec<EnvHealth> {
        let p = self.params;
        let d = Dim::new(&p);
        let (ne, n, subs) = (p.n_env as usize, p.n_members as usize, p.substeps as usize);
        self.boxes.resize(ne, [0.0; 4]);
        let (scheme, poisson) = (self.scheme, &self.poisson);
        let u = chunks(&mut self.u, d.n_u(), ne);
        let v = chunks(&mut self.v, d.n_v(), ne);
        let pr = chunks(&mut self.p, d.n_c(), ne);
        let body = chunks(&mut self.body, d.n_c(), ne);
        let divstar = chunks(&mut self.divstar, d.nx, ne);
        let members = chunks(&mut self.members, n, ne);
        let diags = chunks(diags, n, ne);
        let actions: Vec<&[[f32; 2]]> = (0..ne)
            .map(|e| self.actions.get(e * n..(e + 1) * n).unwrap_or(&[]))
            .collect();
        let envs: Vec<EnvMut> = u
            .into_iter()
            .zip(v)
            .zip(pr)
            .zip(body)
            .zip(divstar)
            .zip(members)
            .zip(diags)
            .zip(actions)
            .zip(self.boxes.iter_mut())
            .map(
                |((((((((u, v), p), body), divstar), members), diags), actions), bx)| EnvMut {
                    u,
                    v,
                    p,
                    body,
                    divstar,
                    members,
                    actions,
                    bx,
                    diags,
                },
            )
            .collect();
        let clocks: Vec<Option<&mut StageTimes>> = match times {
            Some(t) => t.iter_mut().map(Some).collect(),
            None => (0..ne).map(|_| None).collect(),
        };
        envs.into_par_iter()
            .zip(scratch.par_iter_mut())
            .zip(clocks)
            .enumerate()
            .map(|(e, ((env, s), times))| {
                let clock = StageClock::start(times);
                let inlet = &inlet[e * subs..(e + 1) * subs];
                step_env(&d, scheme, poisson, env, inlet, s, clock)
            })
            .collect()
    }
}

/// One control step of one environment (the inlet centreline velocity at the end of each
/// substep in `inlet`), with AVX2 where the processor has it ([`simd`]).
fn step_env(
    d: &Dim,
    scheme: Advection,
    poisson: &[f32],
    env: EnvMut,
    inlet: &[f32],
    s: &mut Scratch,
    clock: StageClock,
) -> EnvHealth {
    #[cfg(target_arch = "x86_64")]
    if !s.portable && simd::avx2() {
        // SAFETY: the processor has AVX2.
        return unsafe { step_env_avx2(d, scheme, poisson, env, inlet, s, clock) };
    }
    step_env_with::<false>(d, scheme, poisson, env, inlet, s, clock)
}

/// [`step_env_with`] compiled for AVX2 (the stages are inlined into it).
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn step_env_avx2(
    d: &Dim,
    scheme: Advection,
    poisson: &[f32],
    env: EnvMut,
    inlet: &[f32],
    s: &mut Scratch,
    clock: StageClock,
) -> EnvHealth {
    step_env_with::<true>(d, scheme, poisson, env, inlet, s, clock)
}

/// [`step_env`] on the chosen vector path.
#[inline(always)]
fn step_env_with<const AVX2: bool>(
    d: &Dim,
    scheme: Advection,
    poisson: &[f32],
    env: EnvMut,
    inlet: &[f32],
    s: &mut Scratch,
    mut clock: StageClock,
) -> EnvHealth {
    use CpuStage::*;
    s.u_out.resize(d.n_u(), 0.0);
    s.v_out.resize(d.n_v(), 0.0);
    s.modes.resize(d.n_c(), 0.0);
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        let tables = (d.ny * d.ny, d.ny * d.ny + d.ny * d.nx);
        pressure_avx2::interleave(d.nx, d.ny, poisson, tables, &mut s.sweep);
    }
    let swarm = !env.members.is_empty();
    // Without a swarm the body field is fixed for the control step; with one, each substep
    // repaints it, clearing only what the last substep painted.
    let mut solid = if swarm {
        None
    } else {
        advect::solid_extent(d, env.body)
    };
    for &centre in inlet {
        if swarm {
            solid = Some(members::paint_bodies(
                d,
                env.members,
                *env.bx,
                env.body,
                solid.as_ref(),
            ));
            clock.lap(Paint);
        }
        let (u_out, v_out) = (&mut s.u_out, &mut s.v_out);
        advect::advect::<AVX2>(
            d,
            scheme,
            env.u,
            env.v,
            env.body,
            solid.as_ref(),
            centre,
            &mut s.advect,
            u_out,
            v_out,
        );
        clock.lap(Advect);
        let (columns, fast) = (&mut s.columns, &mut s.fast_y);
        pressure::rhs(
            d,
            poisson,
            u_out,
            v_out,
            &mut s.modes,
            env.divstar,
            columns,
            fast,
        );
        clock.lap(PressureRhs);
        pressure::solve::<AVX2>(d, poisson, &s.sweep, &mut s.modes);
        clock.lap(PressureSolve);
        pressure::back::<AVX2>(d, poisson, &s.modes, env.p, columns, fast);
        clock.lap(PressureBack);
        project::project(d, env.p, (u_out, v_out), env.u, env.v);
        clock.lap(Project);
        if swarm {
            let (m, a) = (&mut *env.members, env.actions);
            members::move_members(d, m, a, env.p, env.u, env.v, env.diags, env.bx);
            clock.lap(Move);
        }
    }
    let health = diagnostics::diagnostics(d, env.u, env.v, env.p, env.divstar);
    clock.lap(Diagnostics);
    health
}
