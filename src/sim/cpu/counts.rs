//! The arithmetic and memory traffic of the CPU step, counted from the stages' code (as
//! `sim::fluid::profile` counts the kernels' bytes), for `bench`'s roofline. Per environment:
//! [`StageWork::substep`] for one substep, [`StageWork::control_step`] for a control step (the
//! substeps and one diagnostics pass).
//!
//! How it is counted (docs/performance.md, "Roofline of the CPU path", has the tables):
//! - flops: f32 add, sub, mul, div and sqrt as written, one each. Not counted: negation, abs,
//!   min, max, clamp, comparisons, floor, int/float conversions, `is_finite`. libm's `hypot`
//!   counts as 4 (2 mul, add, sqrt), `powf` (the members' drag) as 0. A sub-expression of
//!   parameters only is counted once per stage (hoisted), one of the row index once per row;
//!   plain common sub-expressions once (`2 c` in the Laplacian, `1 - t` in a bilinear blend).
//! - loads, stores: f32 elements of the field-sized arrays (u, v, p, body at 4 f32 a cell,
//!   the advection's padded w and predictor (ghosts included) and its stencil minima and
//!   maxima, modes, the solver's factor tables), each array once per pass over
//!   the grid that reads it and once per pass that writes it, at its full size, like the
//!   kernels' traffic model (neighbouring reads of a row hit the cache). The one-row scratch
//!   of the advection, the y-transform block and the members themselves stay in L1 and are not
//!   traffic, except the members' samples of u, v, p (counted one f32 per corner).
//! - state-dependent paths come from [`BodyLoad`]: the rectangle the Brinkman blend visits
//!   and its faces that meet a body, the cells each member paints, pinned members and
//!   touching pairs. The drag law is counted on its
//!   middle branch (0.1 <= Re < 1000).
//! - the FFT y-transforms of tall grids (ny >= [`super::pressure::FAST_Y_MIN`]) are estimated,
//!   not counted: 2.5 ny log2 ny flops per column per transform.
//!
//! These counts follow the stage code at the time of writing; a stage rewritten for speed does
//! different work and needs its count redone (the test below pins the formulas on a tiny grid).

use std::ops::{Add, AddAssign, Index, Mul};

use std::ops::Range;

use super::BatchState;
use super::advect::solid_extent;
use super::pressure::FAST_Y_MIN;
use super::stencil::{Dim, floor_i32};
use super::timing::CpuStage;
use crate::config::Advection;
use crate::gpu::params::GpuParams;

/// Flops and f32 loads and stores of some work.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Work {
    /// Floating-point operations, counted as the module header says.
    pub flops: u64,
    /// f32 elements loaded.
    pub loads: u64,
    /// f32 elements stored.
    pub stores: u64,
}

impl Work {
    const fn new(flops: u64, loads: u64, stores: u64) -> Self {
        Self {
            flops,
            loads,
            stores,
        }
    }

    /// Bytes moved: 4 per f32 loaded or stored.
    pub fn bytes(&self) -> u64 {
        4 * (self.loads + self.stores)
    }
}

impl Add for Work {
    type Output = Work;
    fn add(self, o: Work) -> Work {
        Work::new(
            self.flops + o.flops,
            self.loads + o.loads,
            self.stores + o.stores,
        )
    }
}

impl AddAssign for Work {
    fn add_assign(&mut self, o: Work) {
        *self = *self + o;
    }
}

impl Mul<u64> for Work {
    type Output = Work;
    fn mul(self, k: u64) -> Work {
        Work::new(self.flops * k, self.loads * k, self.stores * k)
    }
}

/// The state the step's work depends on, for one environment.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BodyLoad {
    /// The rectangle of cells the Brinkman blend visits (with a swarm: the cells near the
    /// swarm box that the paint may touch and clears again; without: the extent of chi > 0),
    /// its rows and columns.
    pub rect_rows: u64,
    /// Columns of that rectangle.
    pub rect_cols: u64,
    /// u faces (of the ny nx advected) and interior v faces next to a cell with chi > 0.
    pub solid_u_faces: u64,
    /// Interior v faces next to a cell with chi > 0.
    pub solid_v_faces: u64,
    /// The paint's (member, cell) visits in each member's window, (member, row) pairs, and the
    /// visits inside the swarm box grown by r + dx (these compute a distance and chi).
    pub paint_visits: u64,
    /// The paint's (member, row) pairs.
    pub paint_rows: u64,
    /// Paint visits inside the swarm box grown by r + dx.
    pub paint_hits: u64,
    /// Members not pinned, ordered pairs of distinct members within 2 r, and those of them
    /// whose first member is not pinned.
    pub free_members: u64,
    /// Ordered pairs of distinct members within 2 r.
    pub touching_pairs: u64,
    /// Touching pairs whose first member is not pinned.
    pub touching_free_pairs: u64,
}

/// The cells whose centres may lie in [lo, hi] along an axis of n cells of size h, as
/// `members::paint_bodies` bounds them (a cell of margin either side).
fn paint_range(lo: f32, hi: f32, h: f32, n: usize) -> Range<usize> {
    let a = floor_i32(lo / h - 0.5) - 1;
    let b = floor_i32(hi / h - 0.5) + 2;
    a.clamp(0, n as i32) as usize..b.clamp(0, n as i32) as usize
}

impl BodyLoad {
    /// Environment e of a batch's state as it stands.
    pub fn of(state: &BatchState, e: usize) -> Self {
        let d = Dim::new(&state.params);
        let (nx, ny, p, n) = (d.nx, d.ny, &d.p, state.params.n_members as usize);
        let body = &state.body[e * d.n_c()..(e + 1) * d.n_c()];
        let solid = |i: usize, j: usize| body[j * nx + i][0] != 0.0;
        let mut load = Self::default();
        for j in 0..ny {
            for i in 1..=nx {
                load.solid_u_faces += (solid(i - 1, j) || solid(i.min(nx - 1), j)) as u64;
            }
        }
        for j in 1..ny {
            for i in 0..nx {
                load.solid_v_faces += (solid(i, j - 1) || solid(i, j)) as u64;
            }
        }
        if n == 0 {
            if let Some(r) = solid_extent(&d, body) {
                (load.rect_rows, load.rect_cols) = (r.j.len() as u64, r.i.len() as u64);
            }
            return load;
        }
        let bx = state.boxes.get(e).copied().unwrap_or_default();
        let reach = p.radius + p.dx;
        let (bi, bj) = (
            paint_range(bx[0] - reach, bx[1] + reach, p.dx, nx),
            paint_range(bx[2] - reach, bx[3] + reach, p.dy, ny),
        );
        (load.rect_rows, load.rect_cols) = (bj.len() as u64, bi.len() as u64);
        let in_box = |c: [f32; 2]| {
            c[0] >= bx[0] - reach
                && c[0] <= bx[1] + reach
                && c[1] >= bx[2] - reach
                && c[1] <= bx[3] + reach
        };
        let clip = |a: Range<usize>, b: &Range<usize>| a.start.max(b.start)..a.end.min(b.end);
        let m = &state.members[e * n..(e + 1) * n];
        for mem in m {
            let (x, y) = (mem.pos[0], mem.pos[1]);
            let cols = clip(paint_range(x - reach, x + reach, p.dx, nx), &bi);
            let rows = clip(paint_range(y - reach, y + reach, p.dy, ny), &bj);
            load.paint_rows += rows.len() as u64;
            load.paint_visits += (rows.len() * cols.len()) as u64;
            for j in rows {
                for i in cols.clone() {
                    let c = [(i as f32 + 0.5) * p.dx, (j as f32 + 0.5) * p.dy];
                    load.paint_hits += in_box(c) as u64;
                }
            }
        }
        let two_r = 2.0 * p.radius;
        load.free_members = m.iter().filter(|a| a.pinned == 0.0).count() as u64;
        for (k, a) in m.iter().enumerate() {
            for (l, b) in m.iter().enumerate() {
                let dist = (a.pos[0] - b.pos[0]).hypot(a.pos[1] - b.pos[1]);
                if k != l && dist > 0.0 && dist <= two_r {
                    load.touching_pairs += 1;
                    load.touching_free_pairs += (a.pinned == 0.0) as u64;
                }
            }
        }
        load
    }

    fn rect_cells(&self) -> u64 {
        self.rect_rows * self.rect_cols
    }
}

/// Flops of the helpers every stage shares (stencil.rs, diffuse.rs, advect.rs, members.rs).
mod cost {
    /// c + dt nu (lx / dx^2 + ly / dy^2), lx = a + b - 2 c (2 c shared by lx and ly).
    pub const LAPLACE_UPDATE: u64 = 10;
    /// The mean of four neighbours: 3 adds and a scaling.
    pub const FACE_VELOCITY: u64 = 4;
    /// `corner_u` / `corner_v`: two scalings, the half-cell shift, two fractions.
    pub const CORNER: u64 = 5;
    /// `bilerp`: three `mix`es of 4 flops, 1 - t shared by the first two.
    pub const BILERP: u64 = 11;
    pub const SAMPLE: u64 = CORNER + BILERP;
    /// Euler departure of a u face, x = (i dx) - h u, y = y_row - h v; of a v face (with the
    /// half-cell x); the row's y is counted once per row (2 flops for u rows, 1 for v rows).
    /// Every departure pass first averages the face velocity ([`FACE_VELOCITY`]).
    pub const EULER_U: u64 = 5;
    pub const EULER_V: u64 = 6;
    /// Midpoint departure: the face's x, the half step (4), the velocity there (two samples),
    /// the full step (4).
    pub const RK2_U: u64 = 1 + 4 + 2 * SAMPLE + 4;
    pub const RK2_V: u64 = 2 + 4 + 2 * SAMPLE + 4;
    pub const ROW_U: u64 = 2;
    pub const ROW_V: u64 = 1;
    /// MacCormack: hat + (w - back) / 2.
    pub const CORRECTION: u64 = 3;
    /// The Brinkman blend of a face next to a body (the fluid path is a comparison).
    pub const BRINKMAN_SOLID: u64 = 9;
    /// The inlet profile of a row, its y included.
    pub const INLET_ROW: u64 = 6;
    /// `project`: (right - left) dt/rho / dx subtracted.
    pub const PROJECT: u64 = 4;
    /// One member of `move_members`, its forces: propulsion (hypot, a division, 2 products),
    /// the four sample points (4), four pressure samples (17 each), four velocity samples (2 x
    /// 16 each) summed and averaged (10), the pressure force (4), the relative velocity (2),
    /// the drag diagnostics (2).
    pub const MEMBER: u64 = 7 + 4 + 4 * 17 + 4 * 2 * 16 + 10 + 4 + 2 + 2;
    /// The drag law (hypot, Re, the middle branch, the coefficient).
    pub const DRAG: u64 = 4 + 4 + 3 + 1;
    /// Distance to another member (2 subs and hypot), and the contact force of a touching pair.
    pub const PAIR: u64 = 6;
    pub const CONTACT: u64 = 13;
    /// The semi-implicit Euler step of a free member.
    pub const INTEGRATE: u64 = 20;
    /// One constraint pass of a free member: its new position and velocity (4), and the
    /// correction of a touching pair.
    pub const PASS: u64 = 4;
    pub const OVERLAP: u64 = 18;
    pub const PASSES: u64 = 4;
    /// A cell a member paints: distance (6) and chi (3); each visit its x (2), each row its y.
    pub const PAINT_HIT: u64 = 9;
    pub const PAINT_VISIT: u64 = 2;
    pub const PAINT_ROW: u64 = 2;
}

/// Estimated flops of one FFT-based DCT of length n (not counted from rustdct's code).
fn fft_dct(n: u64) -> u64 {
    (2.5 * n as f64 * (n as f64).log2()).round() as u64
}

/// The work of each stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StageWork {
    /// Work per stage, indexed by [`CpuStage::index`].
    pub work: [Work; CpuStage::COUNT],
}

impl Index<CpuStage> for StageWork {
    type Output = Work;
    fn index(&self, s: CpuStage) -> &Work {
        &self.work[s.index()]
    }
}

impl AddAssign for StageWork {
    fn add_assign(&mut self, o: Self) {
        for (a, b) in self.work.iter_mut().zip(o.work) {
            *a += b;
        }
    }
}

impl StageWork {
    /// All stages together.
    pub fn total(&self) -> Work {
        self.work.iter().fold(Work::default(), |a, &b| a + b)
    }

    /// One control step of one environment: `substeps` substeps and the diagnostics.
    pub fn control_step(p: &GpuParams, scheme: Advection, load: &BodyLoad) -> Self {
        let mut w = Self::substep(p, scheme, load);
        for s in &mut w.work {
            *s = *s * p.substeps as u64;
        }
        let nc = (p.nx * p.ny) as u64;
        if p.n_members > 0 {
            // The first substep clears the whole body field, the others the last rectangle.
            w.work[CpuStage::Paint.index()].stores += 4 * (nc - load.rect_cells().min(nc));
        } else {
            // The body's extent, found once per control step (4 f32 a cell).
            w.work[CpuStage::Advect.index()].loads += 4 * nc;
        }
        w.work[CpuStage::Diagnostics.index()] = diagnostics(p);
        w
    }

    /// One substep of one environment (no diagnostics: they run once per control step).
    pub fn substep(p: &GpuParams, scheme: Advection, load: &BodyLoad) -> Self {
        let mut w = Self::default();
        let mut set = |s: CpuStage, work: Work| w.work[s.index()] = work;
        let swarm = p.n_members > 0;
        if swarm {
            set(CpuStage::Paint, paint(load));
        }
        set(CpuStage::Advect, advect(p, scheme, load));
        set(CpuStage::PressureRhs, pressure_rhs(p));
        set(CpuStage::PressureSolve, pressure_solve(p));
        set(CpuStage::PressureBack, pressure_back(p));
        set(CpuStage::Project, project(p));
        if swarm {
            set(CpuStage::Move, move_members(p, load));
        }
        w
    }
}

/// Sizes: (nx, ny, cells, u faces, v faces, advected u faces, interior v faces).
fn sizes(p: &GpuParams) -> (u64, u64, u64, u64, u64, u64, u64) {
    let (nx, ny) = (p.nx as u64, p.ny as u64);
    let (nc, nu, nv) = (nx * ny, ny * (nx + 1), (ny + 1) * nx);
    (nx, ny, nc, nu, nv, ny * nx, (ny - 1) * nx)
}

/// Sizes of the padded fields of the advection (`sample::Padded`): w and the predictor with
/// their ghosts, (ny + 2) (nx + 2) for u-like, (ny + 1) (nx + 2) for v-like fields.
fn padded(p: &GpuParams) -> (u64, u64) {
    let (nx, ny) = (p.nx as u64, p.ny as u64);
    ((ny + 2) * (nx + 2), (ny + 1) * (nx + 2))
}

/// Diffusion and advection (advect.rs, diffuse.rs, sample.rs, stencil.rs). Passes: diffuse
/// (u, v in; padded w_u, w_v out), then per scheme the row passes below, each of which reads
/// u and v for the face velocities (and the midpoint backtrace), then the Brinkman blend over
/// the body's rectangle (body in, 4 f32 a cell per pass; the faces read and written).
pub fn advect(p: &GpuParams, scheme: Advection, load: &BodyLoad) -> Work {
    use cost::*;
    let (nx, ny, _, nu, nv, fu, fv) = sizes(p);
    let (pu, pv) = padded(p);
    let rk2 = p.rk2 != 0;
    let (dep_u, dep_v) = if rk2 {
        (RK2_U, RK2_V)
    } else {
        (EULER_U, EULER_V)
    };
    let mut w = Work::new(LAPLACE_UPDATE * (fu + fv), nu + nv, pu + pv);
    // A row pass over the u faces: departures, samples, `extra` flops per face, `row` per row.
    let row_u = |extra: u64, row: u64, loads: u64, stores: u64| {
        Work::new(
            fu * (FACE_VELOCITY + dep_u + SAMPLE + extra) + ny * (ROW_U + row),
            nu + nv + loads,
            stores,
        )
    };
    let row_v = |extra: u64, loads: u64, stores: u64| {
        Work::new(
            fv * (FACE_VELOCITY + dep_v + SAMPLE + extra) + (ny - 1) * ROW_V,
            nu + nv + loads,
            stores,
        )
    };
    match scheme {
        Advection::Maccormack => {
            // Predictors: w in; the predictor (padded) and its stencil's min and max out.
            w += row_u(0, 0, pu, pu + 2 * nu);
            w += row_v(0, pv, pv + 2 * nv);
            // Correctors: predictor, w (padded), min, max in; u* out.
            w += row_u(CORRECTION, INLET_ROW, 2 * pu + 2 * nu, nu);
            w += row_v(CORRECTION, 2 * pv + 2 * nv, nv);
        }
        Advection::SemiLagrangian => {
            w += row_u(0, INLET_ROW, pu, nu);
            w += row_v(0, pv, nv);
        }
    }
    if load.rect_cells() > 0 {
        let (rows, cols) = (load.rect_rows, load.rect_cols);
        // u faces of the rectangle's rows (one more than its columns, at most nx), v faces of
        // its columns (between its rows and the walls' neighbours, at most ny - 1 rows).
        let faces = rows * (cols + 1).min(nx) + (rows + 1).min(ny - 1) * cols;
        w += Work::new(0, 2 * 4 * load.rect_cells() + faces, faces);
    }
    w.flops += BRINKMAN_SOLID * (load.solid_u_faces + load.solid_v_faces);
    w
}

/// div u* (2 subs, 2 divisions, an add a cell), the even/odd fold (2 a pair of rows), the
/// y-modes (2 per multiply-add, ny / 2 of them per mode) and their scaling (1 a mode). One
/// pass: u, v and the table Q (ny^2) in; modes and divstar out.
pub fn pressure_rhs(p: &GpuParams) -> Work {
    let (nx, ny, nc, nu, nv, _, _) = sizes(p);
    let half = ny / 2;
    let div = 5 * nc;
    if ny as usize >= FAST_Y_MIN {
        return Work::new(div + nx * (fft_dct(ny) + 2 * ny), nu + nv, nc + nx);
    }
    let terms = ny.div_ceil(2) * (half + ny % 2) + (ny / 2) * half;
    let column = 2 * half + 2 * terms + ny;
    Work::new(div + nx * column, nu + nv + ny * ny, nc + nx)
}

/// The Thomas sweeps: 3 flops a cell forward, 2 back; modes and the tables c', 1/m in, modes
/// out (the sweeps of four modes stay in L1 between the two directions).
pub fn pressure_solve(p: &GpuParams) -> Work {
    let (_, _, nc, _, _, _, _) = sizes(p);
    Work::new(5 * nc, 3 * nc, nc)
}

/// p = Q p_k: per column, ceil(ny / 2) rows of ny multiply-adds (even and odd modes), and the
/// row and its mirror (2) for ny / 2 of them. Modes and Q in, p out.
pub fn pressure_back(p: &GpuParams) -> Work {
    let (nx, ny, nc, _, _, _, _) = sizes(p);
    if ny as usize >= FAST_Y_MIN {
        return Work::new(nx * (fft_dct(ny) + ny), nc, nc);
    }
    let column = ny.div_ceil(2) * 2 * ny + 2 * (ny / 2);
    Work::new(nx * column, nc + ny * ny, nc)
}

/// The correction of every advected face (4 flops), written straight into the state: p, u*,
/// v* in, u, v out (the faces it does not correct copied).
pub fn project(p: &GpuParams) -> Work {
    let (_, _, nc, nu, nv, fu, fv) = sizes(p);
    Work::new(cost::PROJECT * (fu + fv), nc + nu + nv, nu + nv)
}

/// The body's rectangle cleared (4 f32 a cell; the whole field once per control step, in
/// [`StageWork::control_step`]), then each member's window: every visit its cell's x, every
/// row its y, and the cells in reach of the swarm box a distance and chi, the cell read and
/// (at most) written.
pub fn paint(load: &BodyLoad) -> Work {
    use cost::*;
    Work::new(
        PAINT_VISIT * load.paint_visits + PAINT_ROW * load.paint_rows + PAINT_HIT * load.paint_hits,
        load.paint_hits,
        4 * load.rect_cells() + 4 * load.paint_hits,
    )
}

/// The members' forces and step (per member: `MEMBER`, the drag law when on, the
/// distance to every member and the contact of touching pairs; per free member the step and
/// four constraint passes over every member). Loads: each member's state (5) and action (2),
/// its 48 samples of p, u, v (4 points x 4 corners x 3 fields) and the positions of the others
/// (2 each); per constraint pass and free member the others' snapshots (4 each). Stores: the
/// diagnostics (12) and the state (4), and per pass and free member the new state (4).
pub fn move_members(p: &GpuParams, load: &BodyLoad) -> Work {
    use cost::*;
    let n = p.n_members as u64;
    let drag = if p.drag != 0 { DRAG } else { 0 };
    let flops = n * (MEMBER + drag + PAIR * n)
        + CONTACT * load.touching_pairs
        + load.free_members * (INTEGRATE + PASSES * (PASS + PAIR * n))
        + PASSES * OVERLAP * load.touching_free_pairs;
    let loads = n * (5 + 2 + 48 + 2 * n) + load.free_members * PASSES * 4 * n;
    let stores = n * 16 + load.free_members * PASSES * 4;
    Work::new(flops, loads, stores)
}

/// The health checks, once per control step: the flux through every u column (2 a face) and
/// div u (5 a cell); u, v, p and divstar in.
pub fn diagnostics(p: &GpuParams) -> Work {
    let (nx, _, nc, nu, nv, _, _) = sizes(p);
    Work::new(2 * nu + 5 * nc, nu + nv + nc + nx, 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 x 3 grid: 15 u faces (12 advected), 16 v faces (8 interior), 12 cells.
    fn tiny(rk2: u32, members: u32) -> GpuParams {
        GpuParams {
            nx: 4,
            ny: 3,
            substeps: 2,
            rk2,
            n_members: members,
            drag: 1,
            ..bytemuck::Zeroable::zeroed()
        }
    }

    #[test]
    fn fluid_stages_match_a_hand_count_on_a_tiny_grid() {
        let p = tiny(0, 0);
        let none = BodyLoad::default();
        // Padded fields: 5 x 6 = 30 (u-like), 4 x 6 = 24 (v-like); u, v: 15 + 16 = 31.
        // MacCormack, Euler. Flops: diffuse 10 x 20 = 200, predictor u 12 x (4 + 5 + 16) +
        // 3 rows x 2 = 306, predictor v 8 x 26 + 2 = 210, corrector u 12 x 28 + 3 x (2 + 6) =
        // 360, corrector v 8 x 29 + 2 = 234: 1310. Loads: 31 + (31 + 30) + (31 + 24) + (31 +
        // 60 + 30) + (31 + 48 + 32) = 379. Stores: 54 + (30 + 30) + (24 + 32) + 15 + 16 = 201.
        assert_eq!(
            advect(&p, Advection::Maccormack, &none),
            Work::new(1310, 379, 201)
        );
        // Semi-Lagrangian: 200 + (12 x 25 + 3 x 8) + (8 x 26 + 2) = 734 flops; loads 31 +
        // (31 + 30) + (31 + 24) = 147; stores 54 + 15 + 16 = 85.
        assert_eq!(
            advect(&p, Advection::SemiLagrangian, &none),
            Work::new(734, 147, 85)
        );
        // Midpoint: every departure costs 36 more flops (u: 41 - 5, v: 42 - 6), 40 of them.
        assert_eq!(
            advect(&tiny(1, 0), Advection::Maccormack, &none),
            Work::new(2750, 379, 201)
        );
        // Two faces next to a body: 9 flops each; a 1 x 2 rectangle: 1 x 3 u faces and 2 x 2 v
        // faces read and written, its cells read in both passes (2 x 4 x 2).
        let body = BodyLoad {
            solid_u_faces: 1,
            solid_v_faces: 1,
            rect_rows: 1,
            rect_cols: 2,
            ..none
        };
        assert_eq!(
            advect(&p, Advection::SemiLagrangian, &body),
            Work::new(752, 170, 92)
        );
        // rhs: div 5 x 12, fold 4 x 2, modes 4 x (2 x 5 + 3): 120 flops; u, v, Q (9) in.
        assert_eq!(pressure_rhs(&p), Work::new(120, 40, 16));
        assert_eq!(pressure_solve(&p), Work::new(60, 36, 12));
        // back: 4 columns x (2 rows x 3 multiply-adds x 2 + 2 for the one mirrored pair).
        assert_eq!(pressure_back(&p), Work::new(56, 21, 12));
        assert_eq!(project(&p), Work::new(80, 43, 31));
        assert_eq!(diagnostics(&p), Work::new(90, 47, 0));
        let step = StageWork::control_step(&p, Advection::Maccormack, &none);
        let sub = 1310 + 120 + 60 + 56 + 80;
        assert_eq!(step.total().flops, 2 * sub + 90);
        // The body's extent, scanned once per control step without a swarm.
        assert_eq!(step[CpuStage::Advect].loads, 2 * 379 + 48);
        assert_eq!(step[CpuStage::Paint], Work::default());
        assert_eq!(step[CpuStage::Move], Work::default());
        assert_eq!(
            step.total().bytes(),
            4 * (step.total().loads + step.total().stores)
        );
    }

    #[test]
    fn swarm_stages_match_a_hand_count() {
        let p = tiny(0, 2);
        let load = BodyLoad {
            rect_rows: 2,
            rect_cols: 3,
            paint_visits: 6,
            paint_rows: 2,
            paint_hits: 5,
            free_members: 1,
            touching_pairs: 2,
            touching_free_pairs: 1,
            ..BodyLoad::default()
        };
        // Paint: 6 visits x 2 + 2 rows x 2 + 5 hits x 9 = 61; the hits read; the 6 cells of the
        // rectangle cleared and the hits written (24 + 20).
        assert_eq!(paint(&load), Work::new(61, 5, 44));
        // Over a control step of 2 substeps the first also clears the other 6 cells.
        let step = StageWork::control_step(&p, Advection::SemiLagrangian, &load);
        assert_eq!(step[CpuStage::Paint].stores, 2 * 44 + 4 * 6);
        // Move: per member 225 + 12 (drag) + 2 x 6 = 249, x 2 = 498; contacts 2 x 13 = 26; the
        // free member 20 + 4 x (4 + 12) = 84; its overlap 4 x 18 = 72: 680 flops. Loads 2 x
        // (55 + 4) + 1 x 4 x 4 x 2 = 150; stores 32 + 16 = 48.
        assert_eq!(cost::MEMBER, 225);
        assert_eq!(move_members(&p, &load), Work::new(680, 150, 48));
    }
}
