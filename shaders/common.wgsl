// Shared prelude of every fluid kernel: the batch parameters, the bindings of the field bind
// group and the index/sampling helpers of the staggered (MAC) grid.
//
// Buffer shapes (environment index outermost, row-major, x fastest):
//   u faces  [E][ny][nx+1]  at x = i dx,        y = (j + 1/2) dy
//   v faces  [E][ny+1][nx]  at x = (i + 1/2) dx, y = j dy
//   cells    [E][ny][nx]    at x = (i + 1/2) dx, y = (j + 1/2) dy   (p, body)
//   modes    [E][ny][nx]    phat[e][k][i]: y-cosine mode k of column i
//   inlet    [E][substeps]  inlet centreline velocity U (m/s) at the end of each substep
//   poisson  [ny*ny | ny*nx | ny*nx]  Q (orthonormal DCT-II, Q[j*ny + k]), Thomas c', 1/m
//   w_u, w_v like u, v: the input velocity after one explicit diffusion step
//   u_hat, v_hat like u, v but vec4: (MacCormack predictor, min, max of its stencil, 0)
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
@group(0) @binding(2) var<storage, read_write> u_in: array<f32>;
@group(0) @binding(3) var<storage, read_write> v_in: array<f32>;
@group(0) @binding(4) var<storage, read_write> u_out: array<f32>;
@group(0) @binding(5) var<storage, read_write> v_out: array<f32>;
@group(0) @binding(6) var<storage, read_write> u_hat: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> v_hat: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> p: array<f32>;
@group(0) @binding(9) var<storage, read_write> phat: array<f32>;
@group(0) @binding(10) var<storage, read_write> body: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> inlet: array<f32>;
@group(0) @binding(12) var<storage, read_write> poisson: array<f32>;
@group(0) @binding(13) var<storage, read_write> divstar: array<f32>;
@group(0) @binding(14) var<storage, read_write> colstats: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read_write> health: array<vec4<f32>>;
@group(0) @binding(16) var<storage, read_write> w_u: array<f32>;
@group(0) @binding(17) var<storage, read_write> w_v: array<f32>;
@group(0) @binding(18) var<storage, read_write> members: array<Member>;
@group(0) @binding(19) var<storage, read_write> member_diag: array<MemberDiag>;
@group(0) @binding(20) var<storage, read_write> thrust: array<vec2<f32>>;
@group(0) @binding(21) var<storage, read_write> swarm_box: array<vec4<f32>>;

// What a sampler reads: the input velocity, the MacCormack predictor, the input velocity
// after one explicit diffusion step, w = u + dt nu lap u (written by `diffuse`), or the
// output velocity (after the projection).
const SRC_IN: u32 = 0u;
const SRC_HAT: u32 = 1u;
const SRC_DIFFUSED: u32 = 2u;
const SRC_OUT: u32 = 3u;

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

fn value_u(src: u32, e: u32, i: i32, j: i32) -> f32 {
    return value_u_at(src, u_idx(e, u32(i), u32(j)));
}

// The stored u value at flat index k of buffer `src`.
fn value_u_at(src: u32, k: u32) -> f32 {
    if (src == SRC_HAT) {
        return u_hat[k].x;
    }
    if (src == SRC_DIFFUSED) {
        return w_u[k];
    }
    if (src == SRC_OUT) {
        return u_out[k];
    }
    return u_in[k];
}

fn value_v(src: u32, e: u32, i: i32, j: i32) -> f32 {
    return value_v_at(src, v_idx(e, u32(i), u32(j)));
}

fn value_v_at(src: u32, k: u32) -> f32 {
    if (src == SRC_HAT) {
        return v_hat[k].x;
    }
    if (src == SRC_DIFFUSED) {
        return w_v[k];
    }
    if (src == SRC_OUT) {
        return v_out[k];
    }
    return v_in[k];
}

fn fetch_u(src: u32, e: u32, i: i32, j: i32) -> f32 {
    let m = ghost_u(i, j);
    return f32(m.z) * value_u(src, e, m.x, m.y);
}

fn fetch_v(src: u32, e: u32, i: i32, j: i32) -> f32 {
    let m = ghost_v(i, j);
    return f32(m.z) * value_v(src, e, m.x, m.y);
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

// Stencil of u around the point (x, y) in metres; the point is clamped into the channel.
fn stencil_u(src: u32, e: u32, x: f32, y: f32) -> Stencil {
    let fx = clamp(x * P.inv_dx, 0.0, f32(P.nx));
    let fy = clamp(y * P.inv_dy, 0.0, f32(P.ny)) - 0.5;
    let i0 = min(i32(floor(fx)), i32(P.nx) - 1);
    let j0 = i32(floor(fy));
    var st: Stencil;
    if (j0 >= 0 && j0 + 1 < i32(P.ny)) {
        // Interior (i0 + 1 <= nx always): no ghost mapping needed.
        let k = u_idx(e, u32(i0), u32(j0));
        let row = P.nx + 1u;
        st.vals = vec4<f32>(
            value_u_at(src, k),
            value_u_at(src, k + 1u),
            value_u_at(src, k + row),
            value_u_at(src, k + row + 1u),
        );
    } else {
        st.vals = vec4<f32>(
            fetch_u(src, e, i0, j0),
            fetch_u(src, e, i0 + 1, j0),
            fetch_u(src, e, i0, j0 + 1),
            fetch_u(src, e, i0 + 1, j0 + 1),
        );
    }
    st.t = vec2<f32>(fx - f32(i0), fy - f32(j0));
    return st;
}

// Stencil of v around the point (x, y) in metres; the point is clamped into the channel.
fn stencil_v(src: u32, e: u32, x: f32, y: f32) -> Stencil {
    let fx = clamp(x * P.inv_dx, 0.0, f32(P.nx)) - 0.5;
    let fy = clamp(y * P.inv_dy, 0.0, f32(P.ny));
    let i0 = i32(floor(fx));
    let j0 = min(i32(floor(fy)), i32(P.ny) - 1);
    var st: Stencil;
    if (i0 >= 0 && i0 + 1 < i32(P.nx)) {
        // Interior (j0 + 1 <= ny always): no ghost mapping needed.
        let k = v_idx(e, u32(i0), u32(j0));
        st.vals = vec4<f32>(
            value_v_at(src, k),
            value_v_at(src, k + 1u),
            value_v_at(src, k + P.nx),
            value_v_at(src, k + P.nx + 1u),
        );
    } else {
        st.vals = vec4<f32>(
            fetch_v(src, e, i0, j0),
            fetch_v(src, e, i0 + 1, j0),
            fetch_v(src, e, i0, j0 + 1),
            fetch_v(src, e, i0 + 1, j0 + 1),
        );
    }
    st.t = vec2<f32>(fx - f32(i0), fy - f32(j0));
    return st;
}

// Velocity of the input field at (x, y).
fn velocity_in(e: u32, pos: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(
        bilerp(stencil_u(SRC_IN, e, pos.x, pos.y)),
        bilerp(stencil_v(SRC_IN, e, pos.x, pos.y)),
    );
}

// Departure point of a trajectory that ends at pos after a step h, given the velocity at pos:
// midpoint rule (RK2) or Euler.
fn trace(e: u32, pos: vec2<f32>, vel: vec2<f32>, h: f32) -> vec2<f32> {
    if (P.rk2 == 0u) {
        return pos - h * vel;
    }
    let mid = pos - 0.5 * h * vel;
    return pos - h * velocity_in(e, mid);
}

fn u_face_pos(i: u32, j: u32) -> vec2<f32> {
    return vec2<f32>(f32(i) * P.dx, (f32(j) + 0.5) * P.dy);
}

fn v_face_pos(i: u32, j: u32) -> vec2<f32> {
    return vec2<f32>((f32(i) + 0.5) * P.dx, f32(j) * P.dy);
}

// Input velocity at u face (i, j): its own u and the mean of the four v faces around it.
fn velocity_at_u_face(e: u32, i: u32, j: u32) -> vec2<f32> {
    let a = i32(i);
    let b = i32(j);
    var v: f32;
    if (i >= 1u && i < P.nx) {
        // Interior: the four v faces (i-1 and i, rows j and j+1) need no ghost mapping.
        let k = v_idx(e, i - 1u, j);
        v = v_in[k] + v_in[k + 1u] + v_in[k + P.nx] + v_in[k + P.nx + 1u];
    } else {
        v = fetch_v(SRC_IN, e, a - 1, b) + fetch_v(SRC_IN, e, a, b)
            + fetch_v(SRC_IN, e, a - 1, b + 1) + fetch_v(SRC_IN, e, a, b + 1);
    }
    return vec2<f32>(u_in[u_idx(e, i, j)], 0.25 * v);
}

// Input velocity at v face (i, j): its own v and the mean of the four u faces around it.
fn velocity_at_v_face(e: u32, i: u32, j: u32) -> vec2<f32> {
    let a = i32(i);
    let b = i32(j);
    var u: f32;
    if (j >= 1u && j < P.ny) {
        // Interior: the four u faces (i and i+1, rows j-1 and j) need no ghost mapping.
        let k = u_idx(e, i, j - 1u);
        let row = P.nx + 1u;
        u = u_in[k] + u_in[k + 1u] + u_in[k + row] + u_in[k + row + 1u];
    } else {
        u = fetch_u(SRC_IN, e, a, b - 1) + fetch_u(SRC_IN, e, a + 1, b - 1)
            + fetch_u(SRC_IN, e, a, b) + fetch_u(SRC_IN, e, a + 1, b);
    }
    return vec2<f32>(0.25 * u, v_in[v_idx(e, i, j)]);
}

fn trace_u_face(e: u32, i: u32, j: u32, h: f32) -> vec2<f32> {
    return trace(e, u_face_pos(i, j), velocity_at_u_face(e, i, j), h);
}

fn trace_v_face(e: u32, i: u32, j: u32, h: f32) -> vec2<f32> {
    return trace(e, v_face_pos(i, j), velocity_at_v_face(e, i, j), h);
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// Paints cell (i, j) of environment e from the members (see members.wgsl, `paint_bodies`):
// chi = max over members of clamp(1/2 + (r - |x_c - x_m|) / dx, 0, 1), body velocity that
// member's; only inside the current or the last painted swarm box (elsewhere it is zero).
fn paint_cell(e: u32, i: u32, j: u32) {
    let c = vec2<f32>((f32(i) + 0.5) * P.dx, (f32(j) + 0.5) * P.dy);
    let reach = P.radius + P.dx;
    let bx = swarm_box[2u * e];
    let old = swarm_box[2u * e + 1u];
    let inside = c.x >= bx.x - reach && c.x <= bx.y + reach && c.y >= bx.z - reach && c.y <= bx.w + reach;
    let was_inside = c.x >= old.x - reach && c.x <= old.y + reach && c.y >= old.z - reach
        && c.y <= old.w + reach;
    if (!inside && !was_inside) {
        return; // zero since the last paint: nothing to clear
    }
    var cell = vec4<f32>(0.0);
    if (inside) {
        for (var m = 0u; m < P.n_members; m++) {
            let mem = members[e * P.n_members + m];
            let chi = clamp(0.5 + (P.radius - length(c - mem.pos)) * P.inv_dx, 0.0, 1.0);
            if (chi > cell.x) {
                cell = vec4<f32>(chi, mem.vel, 0.0);
            }
        }
    }
    body[c_idx(e, i, j)] = cell;
}
