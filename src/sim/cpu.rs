//! Plain-Rust twin of every fluid kernel, on the same buffer layouts and in the same f32
//! arithmetic, so tests can compare the GPU against it element by element. Also a whole
//! control step ([`CpuBatch::step`]) built from the twins.

use crate::config::Advection;
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams};

use super::EnvHealth;

/// What a sampler reads (mirrors SRC_IN / SRC_HAT / SRC_DIFFUSED).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Src {
    In,
    Hat,
    Diffused,
}

/// Grid helpers of `common.wgsl` over one set of velocity arrays.
struct G<'a> {
    p: &'a GpuParams,
    u: &'a [f32],
    v: &'a [f32],
    u_hat: &'a [f32],
    v_hat: &'a [f32],
}

fn u_idx(p: &GpuParams, e: usize, i: usize, j: usize) -> usize {
    (e * p.ny as usize + j) * (p.nx as usize + 1) + i
}

fn v_idx(p: &GpuParams, e: usize, i: usize, j: usize) -> usize {
    (e * (p.ny as usize + 1) + j) * p.nx as usize + i
}

fn c_idx(p: &GpuParams, e: usize, i: usize, j: usize) -> usize {
    (e * p.ny as usize + j) * p.nx as usize + i
}

impl G<'_> {
    fn nx(&self) -> i32 {
        self.p.nx as i32
    }
    fn ny(&self) -> i32 {
        self.p.ny as i32
    }

    fn ghost_u(&self, i: i32, j: i32) -> (i32, i32, f32) {
        let ic = i.clamp(0, self.nx());
        if j < 0 {
            (ic, 0, -1.0)
        } else if j >= self.ny() {
            (ic, self.ny() - 1, -1.0)
        } else {
            (ic, j, 1.0)
        }
    }

    fn ghost_v(&self, i: i32, j: i32) -> (i32, i32, f32) {
        let jc = j.clamp(0, self.ny());
        if i < 0 {
            (0, jc, -1.0)
        } else {
            (i.min(self.nx() - 1), jc, 1.0)
        }
    }

    fn fetch_u_in(&self, e: usize, i: i32, j: i32) -> f32 {
        let (ic, jc, s) = self.ghost_u(i, j);
        s * self.u[u_idx(self.p, e, ic as usize, jc as usize)]
    }

    fn fetch_v_in(&self, e: usize, i: i32, j: i32) -> f32 {
        let (ic, jc, s) = self.ghost_v(i, j);
        s * self.v[v_idx(self.p, e, ic as usize, jc as usize)]
    }

    fn diffusion_u(&self, e: usize, i: i32, j: i32) -> f32 {
        let p = self.p;
        let c = self.fetch_u_in(e, i, j);
        let lx = self.fetch_u_in(e, i + 1, j) + self.fetch_u_in(e, i - 1, j) - 2.0 * c;
        let ly = self.fetch_u_in(e, i, j + 1) + self.fetch_u_in(e, i, j - 1) - 2.0 * c;
        p.dt * p.nu * (lx / (p.dx * p.dx) + ly / (p.dy * p.dy))
    }

    fn diffusion_v(&self, e: usize, i: i32, j: i32) -> f32 {
        let p = self.p;
        let c = self.fetch_v_in(e, i, j);
        let lx = self.fetch_v_in(e, i + 1, j) + self.fetch_v_in(e, i - 1, j) - 2.0 * c;
        let ly = self.fetch_v_in(e, i, j + 1) + self.fetch_v_in(e, i, j - 1) - 2.0 * c;
        p.dt * p.nu * (lx / (p.dx * p.dx) + ly / (p.dy * p.dy))
    }

    fn value_u(&self, src: Src, e: usize, i: i32, j: i32) -> f32 {
        let k = u_idx(self.p, e, i as usize, j as usize);
        match src {
            Src::Hat => self.u_hat[k],
            Src::Diffused if i > 0 => self.u[k] + self.diffusion_u(e, i, j),
            _ => self.u[k],
        }
    }

    fn value_v(&self, src: Src, e: usize, i: i32, j: i32) -> f32 {
        let k = v_idx(self.p, e, i as usize, j as usize);
        match src {
            Src::Hat => self.v_hat[k],
            Src::Diffused if j == 0 || j == self.ny() => 0.0,
            Src::Diffused => self.v[k] + self.diffusion_v(e, i, j),
            Src::In => self.v[k],
        }
    }

    fn fetch_u(&self, src: Src, e: usize, i: i32, j: i32) -> f32 {
        let (ic, jc, s) = self.ghost_u(i, j);
        s * self.value_u(src, e, ic, jc)
    }

    fn fetch_v(&self, src: Src, e: usize, i: i32, j: i32) -> f32 {
        let (ic, jc, s) = self.ghost_v(i, j);
        s * self.value_v(src, e, ic, jc)
    }

    fn stencil_u(&self, src: Src, e: usize, x: f32, y: f32) -> Stencil {
        let fx = (x * self.p.inv_dx).clamp(0.0, self.p.nx as f32);
        let fy = (y * self.p.inv_dy).clamp(0.0, self.p.ny as f32) - 0.5;
        let i0 = (fx.floor() as i32).min(self.nx() - 1);
        let j0 = fy.floor() as i32;
        Stencil {
            vals: [
                self.fetch_u(src, e, i0, j0),
                self.fetch_u(src, e, i0 + 1, j0),
                self.fetch_u(src, e, i0, j0 + 1),
                self.fetch_u(src, e, i0 + 1, j0 + 1),
            ],
            t: [fx - i0 as f32, fy - j0 as f32],
        }
    }

    fn stencil_v(&self, src: Src, e: usize, x: f32, y: f32) -> Stencil {
        let fx = (x * self.p.inv_dx).clamp(0.0, self.p.nx as f32) - 0.5;
        let fy = (y * self.p.inv_dy).clamp(0.0, self.p.ny as f32);
        let i0 = fx.floor() as i32;
        let j0 = (fy.floor() as i32).min(self.ny() - 1);
        Stencil {
            vals: [
                self.fetch_v(src, e, i0, j0),
                self.fetch_v(src, e, i0 + 1, j0),
                self.fetch_v(src, e, i0, j0 + 1),
                self.fetch_v(src, e, i0 + 1, j0 + 1),
            ],
            t: [fx - i0 as f32, fy - j0 as f32],
        }
    }

    fn velocity(&self, e: usize, pos: [f32; 2]) -> [f32; 2] {
        [
            self.stencil_u(Src::In, e, pos[0], pos[1]).bilerp(),
            self.stencil_v(Src::In, e, pos[0], pos[1]).bilerp(),
        ]
    }

    fn trace(&self, e: usize, pos: [f32; 2], v0: [f32; 2], h: f32) -> [f32; 2] {
        if self.p.rk2 == 0 {
            return [pos[0] - h * v0[0], pos[1] - h * v0[1]];
        }
        let mid = [pos[0] - 0.5 * h * v0[0], pos[1] - 0.5 * h * v0[1]];
        let v1 = self.velocity(e, mid);
        [pos[0] - h * v1[0], pos[1] - h * v1[1]]
    }

    fn velocity_at_u_face(&self, e: usize, i: usize, j: usize) -> [f32; 2] {
        let (a, b) = (i as i32, j as i32);
        let v = self.fetch_v(Src::In, e, a - 1, b)
            + self.fetch_v(Src::In, e, a, b)
            + self.fetch_v(Src::In, e, a - 1, b + 1)
            + self.fetch_v(Src::In, e, a, b + 1);
        [self.u[u_idx(self.p, e, i, j)], 0.25 * v]
    }

    fn velocity_at_v_face(&self, e: usize, i: usize, j: usize) -> [f32; 2] {
        let (a, b) = (i as i32, j as i32);
        let u = self.fetch_u(Src::In, e, a, b - 1)
            + self.fetch_u(Src::In, e, a + 1, b - 1)
            + self.fetch_u(Src::In, e, a, b)
            + self.fetch_u(Src::In, e, a + 1, b);
        [0.25 * u, self.v[v_idx(self.p, e, i, j)]]
    }

    fn trace_u_face(&self, e: usize, i: usize, j: usize, h: f32) -> [f32; 2] {
        self.trace(e, self.u_pos(i, j), self.velocity_at_u_face(e, i, j), h)
    }

    fn trace_v_face(&self, e: usize, i: usize, j: usize, h: f32) -> [f32; 2] {
        self.trace(e, self.v_pos(i, j), self.velocity_at_v_face(e, i, j), h)
    }

    fn u_pos(&self, i: usize, j: usize) -> [f32; 2] {
        [i as f32 * self.p.dx, (j as f32 + 0.5) * self.p.dy]
    }

    fn v_pos(&self, i: usize, j: usize) -> [f32; 2] {
        [(i as f32 + 0.5) * self.p.dx, j as f32 * self.p.dy]
    }

    fn sl_u(&self, src: Src, e: usize, i: usize, j: usize, h: f32) -> f32 {
        let d = self.trace_u_face(e, i, j, h);
        self.stencil_u(src, e, d[0], d[1]).bilerp()
    }

    fn sl_v(&self, src: Src, e: usize, i: usize, j: usize, h: f32) -> f32 {
        let d = self.trace_v_face(e, i, j, h);
        self.stencil_v(src, e, d[0], d[1]).bilerp()
    }

    /// MacCormack correction of u face (i, j), clamped to the extrema of the forward stencil.
    fn maccormack_u(&self, e: usize, i: usize, j: usize) -> f32 {
        let back = self.sl_u(Src::Hat, e, i, j, -self.p.dt);
        let d = self.trace_u_face(e, i, j, self.p.dt);
        let st = self.stencil_u(Src::Diffused, e, d[0], d[1]);
        let w = self.value_u(Src::Diffused, e, i as i32, j as i32);
        (self.u_hat[u_idx(self.p, e, i, j)] + 0.5 * (w - back)).clamp(st.min(), st.max())
    }

    fn maccormack_v(&self, e: usize, i: usize, j: usize) -> f32 {
        let back = self.sl_v(Src::Hat, e, i, j, -self.p.dt);
        let d = self.trace_v_face(e, i, j, self.p.dt);
        let st = self.stencil_v(Src::Diffused, e, d[0], d[1]);
        let w = self.value_v(Src::Diffused, e, i as i32, j as i32);
        (self.v_hat[v_idx(self.p, e, i, j)] + 0.5 * (w - back)).clamp(st.min(), st.max())
    }
}

struct Stencil {
    vals: [f32; 4],
    t: [f32; 2],
}

fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

impl Stencil {
    fn bilerp(&self) -> f32 {
        let bottom = mix(self.vals[0], self.vals[1], self.t[0]);
        let top = mix(self.vals[2], self.vals[3], self.t[0]);
        mix(bottom, top, self.t[1])
    }
    fn min(&self) -> f32 {
        self.vals.iter().copied().fold(f32::INFINITY, f32::min)
    }
    fn max(&self) -> f32 {
        self.vals.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }
}

/// Inputs of the momentum predictor for the whole batch.
pub struct AdvectInputs<'a> {
    pub u: &'a [f32],
    pub v: &'a [f32],
    /// [E][ny][nx] (chi, u_body, v_body, 0).
    pub body: &'a [[f32; 4]],
    /// [E][S] inlet centreline velocity.
    pub inlet: &'a [f32],
    pub substep: usize,
}

/// Twin of `advect.wgsl`: returns (u*, v*).
pub fn advect(p: &GpuParams, scheme: Advection, inp: &AdvectInputs) -> (Vec<f32>, Vec<f32>) {
    let (nx, ny, ne) = (p.nx as usize, p.ny as usize, p.n_env as usize);
    let mut g = G {
        p,
        u: inp.u,
        v: inp.v,
        u_hat: &[],
        v_hat: &[],
    };
    // MacCormack predictor: u_hat = A(w).
    let (mut u_hat, mut v_hat) = (vec![0.0; inp.u.len()], vec![0.0; inp.v.len()]);
    if scheme == Advection::Maccormack {
        for e in 0..ne {
            for j in 0..ny {
                for i in 0..=nx {
                    let k = u_idx(p, e, i, j);
                    u_hat[k] = if i == 0 {
                        inp.u[k]
                    } else {
                        g.sl_u(Src::Diffused, e, i, j, p.dt)
                    };
                }
            }
            for j in 0..=ny {
                for i in 0..nx {
                    let k = v_idx(p, e, i, j);
                    v_hat[k] = if j == 0 || j == ny {
                        0.0
                    } else {
                        g.sl_v(Src::Diffused, e, i, j, p.dt)
                    };
                }
            }
        }
    }
    g.u_hat = &u_hat;
    g.v_hat = &v_hat;
    let mut u_out = vec![0.0; inp.u.len()];
    let mut v_out = vec![0.0; inp.v.len()];
    for e in 0..ne {
        let centre = inp.inlet[e * p.substeps as usize + inp.substep];
        for j in 0..ny {
            for i in 0..=nx {
                u_out[u_idx(p, e, i, j)] = if i == 0 {
                    let y = (j as f32 + 0.5) * p.dy;
                    4.0 * centre * y * (p.height - y) / (p.height * p.height)
                } else {
                    let w = match scheme {
                        Advection::SemiLagrangian => g.sl_u(Src::Diffused, e, i, j, p.dt),
                        Advection::Maccormack => g.maccormack_u(e, i, j),
                    };
                    let a = inp.body[c_idx(p, e, i.max(1) - 1, j)];
                    let b = inp.body[c_idx(p, e, i.min(nx - 1), j)];
                    brinkman(w, a[0], a[1], b[0], b[1])
                };
            }
        }
        for j in 0..=ny {
            for i in 0..nx {
                v_out[v_idx(p, e, i, j)] = if j == 0 || j == ny {
                    0.0
                } else {
                    let w = match scheme {
                        Advection::SemiLagrangian => g.sl_v(Src::Diffused, e, i, j, p.dt),
                        Advection::Maccormack => g.maccormack_v(e, i, j),
                    };
                    let a = inp.body[c_idx(p, e, i, j - 1)];
                    let b = inp.body[c_idx(p, e, i, j)];
                    brinkman(w, a[0], a[2], b[0], b[2])
                };
            }
        }
    }
    (u_out, v_out)
}

/// Brinkman blend of a face between cells a and b (solid fractions chi, body velocities w).
fn brinkman(w: f32, chi_a: f32, w_a: f32, chi_b: f32, w_b: f32) -> f32 {
    if chi_a == 0.0 && chi_b == 0.0 {
        return w;
    }
    let chi = 0.5 * (chi_a + chi_b);
    (1.0 - chi) * w + 0.5 * (chi_a * w_a + chi_b * w_b)
}

/// Twin of `pressure_rhs.wgsl`: returns (modes [E][ny][nx], divstar [E][nx]).
pub fn pressure_rhs(p: &GpuParams, poisson: &[f32], u: &[f32], v: &[f32]) -> (Vec<f32>, Vec<f32>) {
    let (nx, ny, ne) = (p.nx as usize, p.ny as usize, p.n_env as usize);
    let mut modes = vec![0.0; ne * nx * ny];
    let mut divstar = vec![0.0; ne * nx];
    for e in 0..ne {
        for i in 0..nx {
            let mut column: Vec<f32> = (0..ny)
                .map(|j| {
                    (u[u_idx(p, e, i + 1, j)] - u[u_idx(p, e, i, j)]) / p.dx
                        + (v[v_idx(p, e, i, j + 1)] - v[v_idx(p, e, i, j)]) / p.dy
                })
                .collect();
            divstar[e * nx + i] = column.iter().fold(0.0f32, |m, d| m.max(d.abs()));
            let half = ny / 2;
            for j in 0..half {
                let (lo, hi) = (column[j], column[ny - 1 - j]);
                column[j] = lo + hi;
                column[ny - 1 - j] = lo - hi;
            }
            for k in 0..ny {
                let mut acc = 0.0f32;
                if k % 2 == 0 {
                    for j in 0..half {
                        acc += poisson[j * ny + k] * column[j];
                    }
                    if ny % 2 == 1 {
                        acc += poisson[half * ny + k] * column[half];
                    }
                } else {
                    for j in 0..half {
                        acc += poisson[j * ny + k] * column[ny - 1 - j];
                    }
                }
                modes[(e * ny + k) * nx + i] = acc * (p.rho / p.dt);
            }
        }
    }
    (modes, divstar)
}

/// Twin of `pressure_solve.wgsl`: in place on the modes.
pub fn pressure_solve(p: &GpuParams, poisson: &[f32], modes: &mut [f32]) {
    let (nx, ny, ne) = (p.nx as usize, p.ny as usize, p.n_env as usize);
    let dx2 = p.dx * p.dx;
    for e in 0..ne {
        for k in 0..ny {
            let base = (e * ny + k) * nx;
            let c_base = ny * ny + k * nx;
            let m_base = ny * ny + ny * nx + k * nx;
            let mut prev = 0.0f32;
            for i in 0..nx {
                let d = (modes[base + i] * dx2 - prev) * poisson[m_base + i];
                modes[base + i] = d;
                prev = d;
            }
            let mut next = 0.0f32;
            for i in (0..nx).rev() {
                let x = modes[base + i] - poisson[c_base + i] * next;
                modes[base + i] = x;
                next = x;
            }
        }
    }
}

/// Twin of `project.wgsl`: corrects u, v in place and returns p [E][ny][nx].
pub fn project(
    p: &GpuParams,
    poisson: &[f32],
    modes: &[f32],
    u: &mut [f32],
    v: &mut [f32],
) -> Vec<f32> {
    let (nx, ny, ne) = (p.nx as usize, p.ny as usize, p.n_env as usize);
    let scale = p.dt / p.rho;
    let mut pres = vec![0.0; ne * nx * ny];
    for e in 0..ne {
        // pressure_back: even/odd mode sums give a row and its mirror.
        for i in 0..nx {
            let mode = |k: usize| modes[(e * ny + k) * nx + i];
            for j in 0..ny.div_ceil(2) {
                let even: f32 = (0..ny)
                    .step_by(2)
                    .fold(0.0, |a, k| a + poisson[j * ny + k] * mode(k));
                let odd: f32 = (1..ny)
                    .step_by(2)
                    .fold(0.0, |a, k| a + poisson[j * ny + k] * mode(k));
                let mirror = ny - 1 - j;
                if mirror == j {
                    pres[c_idx(p, e, i, j)] = even;
                } else {
                    pres[c_idx(p, e, i, j)] = even + odd;
                    pres[c_idx(p, e, i, mirror)] = even - odd;
                }
            }
        }
        // project: the velocity correction.
        let at = |i: usize, j: usize| pres[c_idx(p, e, i, j)];
        for j in 0..=ny {
            for i in 0..=nx {
                if j < ny && i >= 1 {
                    let left = at(i - 1, j);
                    let right = if i == nx { -left } else { at(i, j) };
                    u[u_idx(p, e, i, j)] -= scale * (right - left) / p.dx;
                }
                if i < nx && j >= 1 && j < ny {
                    v[v_idx(p, e, i, j)] -= scale * (at(i, j) - at(i, j - 1)) / p.dy;
                }
            }
        }
    }
    pres
}

/// Twin of `diagnostics.wgsl`: the health of every environment.
pub fn diagnostics(
    p: &GpuParams,
    u: &[f32],
    v: &[f32],
    pres: &[f32],
    divstar: &[f32],
) -> Vec<EnvHealth> {
    let (nx, ny, ne) = (p.nx as usize, p.ny as usize, p.n_env as usize);
    let finite = |x: f32| x.is_finite();
    (0..ne)
        .map(|e| {
            let mut h = EnvHealth {
                flux_min: f32::MAX,
                flux_max: f32::MIN,
                ..Default::default()
            };
            for i in 0..=nx {
                let (mut flux, mut bad) = (0.0f32, 0u32);
                for j in 0..ny {
                    let uc = u[u_idx(p, e, i, j)];
                    flux += uc * p.dy;
                    h.max_speed = h.max_speed.max(uc.abs());
                    bad += !finite(uc) as u32;
                    if i < nx {
                        let div = (u[u_idx(p, e, i + 1, j)] - uc) / p.dx
                            + (v[v_idx(p, e, i, j + 1)] - v[v_idx(p, e, i, j)]) / p.dy;
                        h.max_div = h.max_div.max(div.abs());
                        let vc = v[v_idx(p, e, i, j)];
                        h.max_speed = h.max_speed.max(vc.abs());
                        let pc = pres[c_idx(p, e, i, j)];
                        bad += (!finite(vc) || !finite(pc) || !finite(div)) as u32;
                    }
                }
                h.flux_min = h.flux_min.min(flux);
                h.flux_max = h.flux_max.max(flux);
                h.nonfinite += bad;
                if i == 0 {
                    h.inlet_flux = flux;
                }
            }
            h.div_before = divstar[e * nx..(e + 1) * nx]
                .iter()
                .copied()
                .fold(0.0, f32::max);
            h
        })
        .collect()
}

/// A whole batch advanced on the CPU with the twins (the reference for whole-step tests, and
/// the native yardstick of `benches/substep.rs`).
#[derive(Debug, Clone)]
pub struct CpuBatch {
    pub params: GpuParams,
    pub scheme: Advection,
    pub poisson: Vec<f32>,
    pub u: Vec<f32>,
    pub v: Vec<f32>,
    pub p: Vec<f32>,
    pub body: Vec<[f32; 4]>,
    pub divstar: Vec<f32>,
    /// Members [E][N], their raw actions and the swarm boxes [E] (empty without a swarm).
    pub members: Vec<GpuMember>,
    pub actions: Vec<[f32; 2]>,
    pub boxes: Vec<[f32; 4]>,
}

impl CpuBatch {
    /// One control step; `inlet` is [E][S]. With members, each substep paints them into the
    /// body field first and moves them after the projection, as the GPU step does.
    pub fn step(&mut self, inlet: &[f32]) -> Vec<EnvHealth> {
        let p = self.params;
        for s in 0..p.substeps as usize {
            if p.n_members > 0 {
                self.body = paint_bodies(&p, &self.members, &self.boxes);
            }
            let (mut u, mut v) = advect(
                &p,
                self.scheme,
                &AdvectInputs {
                    u: &self.u,
                    v: &self.v,
                    body: &self.body,
                    inlet,
                    substep: s,
                },
            );
            let (mut modes, divstar) = pressure_rhs(&p, &self.poisson, &u, &v);
            pressure_solve(&p, &self.poisson, &mut modes);
            self.p = project(&p, &self.poisson, &modes, &mut u, &mut v);
            if p.n_members > 0 {
                let (m, _, boxes) = move_members(&p, &self.members, &self.actions, &self.p, &u, &v);
                self.members = m;
                self.boxes = boxes;
            }
            self.u = u;
            self.v = v;
            self.divstar = divstar;
        }
        diagnostics(&p, &self.u, &self.v, &self.p, &self.divstar)
    }
}

/// Twin of `paint_bodies` (`members.wgsl`): the body field [E][ny][nx] from the members.
pub fn paint_bodies(p: &GpuParams, members: &[GpuMember], swarm_box: &[[f32; 4]]) -> Vec<[f32; 4]> {
    let (nx, ny, ne, n) = (
        p.nx as usize,
        p.ny as usize,
        p.n_env as usize,
        p.n_members as usize,
    );
    let mut body = vec![[0.0f32; 4]; ne * nx * ny];
    let reach = p.radius + p.dx;
    for e in 0..ne {
        let bx = swarm_box[e];
        for j in 0..ny {
            for i in 0..nx {
                let c = [(i as f32 + 0.5) * p.dx, (j as f32 + 0.5) * p.dy];
                let mut cell = [0.0f32; 4];
                if c[0] >= bx[0] - reach
                    && c[0] <= bx[1] + reach
                    && c[1] >= bx[2] - reach
                    && c[1] <= bx[3] + reach
                {
                    for mem in &members[e * n..(e + 1) * n] {
                        let d = (c[0] - mem.pos[0]).hypot(c[1] - mem.pos[1]);
                        let chi = (0.5 + (p.radius - d) * p.inv_dx).clamp(0.0, 1.0);
                        if chi > cell[0] {
                            cell = [chi, mem.vel[0], mem.vel[1], 0.0];
                        }
                    }
                }
                body[c_idx(p, e, i, j)] = cell;
            }
        }
    }
    body
}

/// F_prop = F_max a / max(1, |a|) (N).
pub fn propulsion(p: &GpuParams, a: [f32; 2]) -> [f32; 2] {
    let s = p.max_thrust / a[0].hypot(a[1]).max(1.0);
    [s * a[0], s * a[1]]
}

/// C_d |v_rel| of the Schiller-Naumann law (m/s), as `members.wgsl` evaluates it.
pub fn cd_times_speed(p: &GpuParams, speed: f32) -> f32 {
    let re = p.rho * speed * 2.0 * p.radius / p.mu;
    let stokes = 24.0 * p.mu / (p.rho * 2.0 * p.radius);
    if re < 0.1 {
        stokes
    } else if re < 1000.0 {
        stokes * (1.0 + 0.15 * re.powf(0.687))
    } else {
        0.44 * speed
    }
}

/// Pressure at (x, y), bilinear in the cell centres (twin of `sample_p`).
fn sample_p(p: &GpuParams, pres: &[f32], e: usize, x: f32, y: f32) -> f32 {
    let (nx, ny) = (p.nx as usize, p.ny as usize);
    let fx = (x * p.inv_dx - 0.5).clamp(0.0, (nx - 1) as f32);
    let fy = (y * p.inv_dy - 0.5).clamp(0.0, (ny - 1) as f32);
    let i0 = (fx as usize).min(nx - 2);
    let j0 = (fy as usize).min(ny - 2);
    let (tx, ty) = (fx - i0 as f32, fy - j0 as f32);
    let at = |i, j| pres[c_idx(p, e, i, j)];
    let bottom = mix(at(i0, j0), at(i0 + 1, j0), tx);
    let top = mix(at(i0, j0 + 1), at(i0 + 1, j0 + 1), tx);
    mix(bottom, top, ty)
}

/// Twin of `move_members` (`members.wgsl`) for every environment: the moved members, their
/// forces and samples, and the swarm boxes. `u`, `v` are the projected velocity.
pub fn move_members(
    p: &GpuParams,
    members: &[GpuMember],
    actions: &[[f32; 2]],
    pres: &[f32],
    u: &[f32],
    v: &[f32],
) -> (Vec<GpuMember>, Vec<GpuMemberDiag>, Vec<[f32; 4]>) {
    let (ne, n) = (p.n_env as usize, p.n_members as usize);
    let g = G {
        p,
        u,
        v,
        u_hat: &[],
        v_hat: &[],
    };
    let pi = std::f32::consts::PI;
    let (mut out, mut diags, mut boxes) = (Vec::new(), Vec::new(), Vec::new());
    for e in 0..ne {
        let swarm = &members[e * n..(e + 1) * n];
        let force: Vec<[f32; 2]> = actions[e * n..(e + 1) * n]
            .iter()
            .map(|&a| propulsion(p, a))
            .collect();
        let mut pos = Vec::new();
        let mut vel = Vec::new();
        for (m, me) in swarm.iter().enumerate() {
            let clampq = |q: [f32; 2]| [q[0].clamp(0.0, p.length), q[1].clamp(0.0, p.height)];
            let rs = p.sample_radius;
            let q = [
                clampq([me.pos[0] + rs, me.pos[1]]),
                clampq([me.pos[0], me.pos[1] + rs]),
                clampq([me.pos[0] - rs, me.pos[1]]),
                clampq([me.pos[0], me.pos[1] - rs]),
            ];
            let ps: Vec<f32> = q.iter().map(|q| sample_p(p, pres, e, q[0], q[1])).collect();
            let mut uf = [0.0f32; 2];
            for q in &q {
                uf[0] += g.stencil_u(Src::In, e, q[0], q[1]).bilerp();
                uf[1] += g.stencil_v(Src::In, e, q[0], q[1]).bilerp();
            }
            uf = [uf[0] * 0.25, uf[1] * 0.25];
            let c = -(pi * p.radius / 2.0) * p.depth;
            let hydro = [c * (ps[0] - ps[2]), c * (ps[1] - ps[3])];
            let rel = [uf[0] - me.vel[0], uf[1] - me.vel[1]];
            let kd = if p.drag != 0 {
                0.5 * p.rho * pi * p.radius * p.radius * cd_times_speed(p, rel[0].hypot(rel[1]))
            } else {
                0.0
            };
            let mut contact = [0.0f32; 2];
            for (j, other) in swarm.iter().enumerate() {
                let d = [me.pos[0] - other.pos[0], me.pos[1] - other.pos[1]];
                let dist = d[0].hypot(d[1]);
                if j != m && dist > 0.0 && dist <= 2.0 * p.radius {
                    let nij = [d[0] / dist, d[1] / dist];
                    let push = (force[j][0] * nij[0] + force[j][1] * nij[1]).max(0.0)
                        + (-(force[m][0] * nij[0] + force[m][1] * nij[1])).max(0.0);
                    contact = [contact[0] + push * nij[0], contact[1] + push * nij[1]];
                }
            }
            diags.push(GpuMemberDiag {
                hydro,
                drag: [kd * rel[0], kd * rel[1]],
                contact,
                prop: force[m],
                p: [ps[0], ps[1], ps[2], ps[3]],
            });
            if me.pinned == 0.0 {
                let h = p.dt / p.mass;
                let nv = |k: usize| {
                    (me.vel[k] + h * (hydro[k] + force[m][k] + contact[k] + kd * uf[k]))
                        / (1.0 + h * kd)
                };
                let nvel = [nv(0), nv(1)];
                vel.push(nvel);
                pos.push([me.pos[0] + p.dt * nvel[0], me.pos[1] + p.dt * nvel[1]]);
            } else {
                vel.push([0.0, 0.0]);
                pos.push(me.pos);
            }
        }
        for _ in 0..4 {
            let (snap_p, snap_v) = (pos.clone(), vel.clone());
            for (m, me) in swarm.iter().enumerate() {
                if me.pinned != 0.0 {
                    continue;
                }
                let (mut dp, mut dv) = ([0.0f32; 2], [0.0f32; 2]);
                for j in 0..n {
                    let d = [snap_p[m][0] - snap_p[j][0], snap_p[m][1] - snap_p[j][1]];
                    let dist = d[0].hypot(d[1]);
                    if j != m && dist > 0.0 && dist < 2.0 * p.radius {
                        let nij = [d[0] / dist, d[1] / dist];
                        let share = if swarm[j].pinned != 0.0 { 1.0 } else { 0.5 };
                        let over = share * (2.0 * p.radius - dist);
                        dp = [dp[0] + over * nij[0], dp[1] + over * nij[1]];
                        let approach = (snap_v[m][0] - snap_v[j][0]) * nij[0]
                            + (snap_v[m][1] - snap_v[j][1]) * nij[1];
                        if approach < 0.0 {
                            dv = [
                                dv[0] - share * approach * nij[0],
                                dv[1] - share * approach * nij[1],
                            ];
                        }
                    }
                }
                let mut q = [snap_p[m][0] + dp[0], snap_p[m][1] + dp[1]];
                let mut w = [snap_v[m][0] + dv[0], snap_v[m][1] + dv[1]];
                let (lo, hi) = (
                    [p.radius, p.radius],
                    [p.length - p.radius, p.height - p.radius],
                );
                for k in 0..2 {
                    if q[k] < lo[k] {
                        q[k] = lo[k];
                        w[k] = w[k].max(0.0);
                    }
                    if q[k] > hi[k] {
                        q[k] = hi[k];
                        w[k] = w[k].min(0.0);
                    }
                }
                pos[m] = q;
                vel[m] = w;
            }
        }
        for (m, me) in swarm.iter().enumerate() {
            out.push(GpuMember {
                pos: pos[m],
                vel: vel[m],
                pinned: me.pinned,
                pad: [0.0; 3],
            });
        }
        let mut bx = [pos[0][0], pos[0][0], pos[0][1], pos[0][1]];
        for q in &pos[1..] {
            bx = [
                bx[0].min(q[0]),
                bx[1].max(q[0]),
                bx[2].min(q[1]),
                bx[3].max(q[1]),
            ];
        }
        boxes.push(bx);
    }
    (out, diags, boxes)
}
