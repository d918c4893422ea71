// Shared prelude of every fluid kernel: the batch parameters (bindings 0 and 1), the index and
// ghost helpers of the staggered (MAC) grid and the loads the samplers (sample.wgsl) read.
//
// Each kernel's module is built for ONE entry point (src/gpu/shaders.rs): its storage bindings
// 2..=21 are declared by a generated header, `read` or `read_write` as that entry point's table
// (src/gpu/kernels/<kernel>.rs) says, so its pipeline binds only what it touches. Helpers
// therefore only read storage; every storage write is in an entry point.
// The header also declares the column layout of the batch's grid, `const MAX_NY: u32` (cells a
// column kernel holds per column) and `const LANES: u32` (columns per workgroup), which size the
// workgroup scratch and workgroup of `pressure_rhs` and `pressure_back` (`Columns` in
// src/gpu/kernels/mod.rs).
//
// Buffer shapes (environment index outermost, row-major, x fastest):
//   u faces  [E][ny][nx+1]  at x = i dx,        y = (j + 1/2) dy
//   v faces  [E][ny+1][nx]  at x = (i + 1/2) dx, y = j dy
//   cells    [E][ny][nx]    at x = (i + 1/2) dx, y = (j + 1/2) dy   (p, body)
//   modes    [E][ny][nx]    phat[e][k][i]: y-cosine mode k of column i
//   inlet    [E][substeps]  inlet centreline velocity U (m/s) at the end of each substep
//   poisson  [ny*ny | ny*nx | ny*nx]  Q (orthonormal DCT-II, Q[j*ny + k]), Thomas c', 1/m
//   w_u, w_v like u, v: the input velocity after one explicit diffusion step
//   u_hat, v_hat like u, v but vec4: (MacCormack predictor, min, max of its stencil, the face's
//   transverse velocity; at the inlet faces i = 0 of u_hat the inlet value instead)
//   members, member_diag, thrust (raw actions) [E][N]; swarm_box [E][2] (x/y extent of the centres; the extent at the last paint, where the body
//   field may be non-zero)
// Boundary ghosts: walls (y = 0, H) no-slip (u odd, v = 0 on the wall faces); inlet (x = 0)
// Dirichlet u, v = 0 (v odd); outlet (x = L) zero-gradient velocity, p = 0 on the face.
// Mirrors `src/gpu/params.rs` (GpuParams, SubstepUniform).

struct Params {
    nx: u32,
    ny: u32,
    n_env: u32,
    substeps: u32,
    dx: f32,
    dy: f32,
    dt: f32,
    nu: f32,
    rho: f32,
    height: f32,
    // 1: second-order (midpoint, RK2) backtrace; 0: first-order (Euler) backtrace.
    rk2: u32,
    pad1: f32,
    // 1 / dx, 1 / dy (1/m).
    inv_dx: f32,
    inv_dy: f32,
    // Channel length L (m), dynamic viscosity mu (Pa s).
    length: f32,
    mu: f32,
    // Swarm: members per environment, 1 if the empirical drag is on.
    n_members: u32,
    drag: u32,
    // Member radius r, pressure-sampling radius R_s, effective depth 4 r^2 / (3 R_s) (m),
    // mass 4/3 pi r^3 rho_s (kg).
    radius: f32,
    sample_radius: f32,
    depth: f32,
    mass: f32,
    // Thrust bound F_max (N); thrust[] holds raw actions a, F_prop = F_max a / max(1, |a|).
    max_thrust: f32,
    pad4: f32,
    pad5: f32,
    pad6: f32,
    pad7: f32,
    pad8: f32,
}

// One swarm member (32 B); pinned = 1 holds it fixed.
struct Member {
    pos: vec2<f32>,
    vel: vec2<f32>,
    pinned: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}

// Forces on a member in the last substep (N) and its four pressure samples (Pa) (48 B).
struct MemberDiag {
    hydro: vec2<f32>,
    drag: vec2<f32>,
    contact: vec2<f32>,
    prop: vec2<f32>,
    p: vec4<f32>,
}

struct Substep {
    index: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<uniform> S: Substep;
// Storage bindings 2..=21 (u_in, v_in, u_out, v_out, u_hat, v_hat, p, phat, body, inlet, poisson,
// divstar, colstats, health, w_u, w_v, members, member_diag, thrust, swarm_box): see the header.

// What a sampler reads (sample.wgsl is instantiated once per source): the input velocity
// (`in`), the input velocity after one explicit diffusion step, w = u + dt nu lap u (written by
// `diffuse`; `diffused`), the MacCormack predictor (`hat`), or the output velocity after the
// projection (`out`). One function per buffer, so that an entry point binds only the buffers
// its samplers really read.
fn load_u_in(k: u32) -> f32 {
    return u_in[k];
}

fn load_v_in(k: u32) -> f32 {
    return v_in[k];
}

fn load_u_diffused(k: u32) -> f32 {
    return w_u[k];
}

fn load_v_diffused(k: u32) -> f32 {
    return w_v[k];
}

fn load_u_hat(k: u32) -> f32 {
    return u_hat[k].x;
}

fn load_v_hat(k: u32) -> f32 {
    return v_hat[k].x;
}

fn load_u_out(k: u32) -> f32 {
    return u_out[k];
}

fn load_v_out(k: u32) -> f32 {
    return v_out[k];
}

fn u_idx(e: u32, i: u32, j: u32) -> u32 {
    return (e * P.ny + j) * (P.nx + 1u) + i;
}

fn v_idx(e: u32, i: u32, j: u32) -> u32 {
    return (e * (P.ny + 1u) + j) * P.nx + i;
}

fn c_idx(e: u32, i: u32, j: u32) -> u32 {
    return (e * P.ny + j) * P.nx + i;
}

// Ghost mapping of a u face index: (stored i, stored j, sign). i is clamped to [0, nx]; rows -1
// and ny mirror with a sign change (no-slip: u = 0 on the wall).
fn ghost_u(i: i32, j: i32) -> vec3<i32> {
    let ic = clamp(i, 0, i32(P.nx));
    if (j < 0) {
        return vec3<i32>(ic, 0, -1);
    }
    if (j >= i32(P.ny)) {
        return vec3<i32>(ic, i32(P.ny) - 1, -1);
    }
    return vec3<i32>(ic, j, 1);
}

// Ghost mapping of a v face index: column -1 mirrors with a sign change (v = 0 at the inlet),
// column nx repeats column nx-1 (zero gradient at the outlet); j clamped to [0, ny].
fn ghost_v(i: i32, j: i32) -> vec3<i32> {
    let jc = clamp(j, 0, i32(P.ny));
    if (i < 0) {
        return vec3<i32>(0, jc, -1);
    }
    return vec3<i32>(min(i, i32(P.nx) - 1), jc, 1);
}

// The four values of a bilinear stencil and the fractional position inside it.
struct Stencil {
    vals: vec4<f32>,
    t: vec2<f32>,
}

fn bilerp(st: Stencil) -> f32 {
    let bottom = mix(st.vals.x, st.vals.y, st.t.x);
    let top = mix(st.vals.z, st.vals.w, st.t.x);
    return mix(bottom, top, st.t.y);
}

fn stencil_min(st: Stencil) -> f32 {
    return min(min(st.vals.x, st.vals.y), min(st.vals.z, st.vals.w));
}

fn stencil_max(st: Stencil) -> f32 {
    return max(max(st.vals.x, st.vals.y), max(st.vals.z, st.vals.w));
}

fn u_face_pos(i: u32, j: u32) -> vec2<f32> {
    return vec2<f32>(f32(i) * P.dx, (f32(j) + 0.5) * P.dy);
}

fn v_face_pos(i: u32, j: u32) -> vec2<f32> {
    return vec2<f32>((f32(i) + 0.5) * P.dx, f32(j) * P.dy);
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// The painted value of cell (i, j) of environment e (see members.wgsl, `paint_bodies`):
// chi = max over members of clamp(1/2 + (r - |x_c - x_m|) / dx, 0, 1), body velocity that
// member's; only inside the current or the last painted swarm box (elsewhere it is zero and
// `write` is false: nothing to clear). The caller stores it (helpers write no storage).
struct Paint {
    cell: vec4<f32>,
    write: bool,
}

fn paint_cell(e: u32, i: u32, j: u32) -> Paint {
    let c = vec2<f32>((f32(i) + 0.5) * P.dx, (f32(j) + 0.5) * P.dy);
    let reach = P.radius + P.dx;
    let bx = swarm_box[2u * e];
    let old = swarm_box[2u * e + 1u];
    let inside = c.x >= bx.x - reach && c.x <= bx.y + reach && c.y >= bx.z - reach && c.y <= bx.w + reach;
    let was_inside = c.x >= old.x - reach && c.x <= old.y + reach && c.y >= old.z - reach
        && c.y <= old.w + reach;
    var cell = vec4<f32>(0.0);
    if (!inside && !was_inside) {
        return Paint(cell, false); // zero since the last paint: nothing to clear
    }
    if (inside) {
        for (var m = 0u; m < P.n_members; m++) {
            let mem = members[e * P.n_members + m];
            let chi = clamp(0.5 + (P.radius - length(c - mem.pos)) * P.inv_dx, 0.0, 1.0);
            if (chi > cell.x) {
                cell = vec4<f32>(chi, mem.vel, 0.0);
            }
        }
    }
    return Paint(cell, true);
}
