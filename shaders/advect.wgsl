// Momentum predictor: explicit viscous diffusion, then semi-Lagrangian advection (RK2 trace
// in the velocity u^n, bilinear), inlet/wall boundary values and Brinkman blending.
//
//   `diffuse`: w = u^n + dt nu lap u^n   (w_u, w_v; inlet and wall faces keep their values);
//              with members it also paints the body field (`paint_cell`): one pass over the
//              grid instead of two, since lavapipe pays per invocation
//   u* = A(w),   then  u* <- (1 - chi_f) u* + chi_f u_body   (solid faces)
//
// Advecting the diffused field (sequential splitting) keeps the scheme stable at CFL ~ 1;
// adding lap u^n at the arrival point instead amplifies the grid-scale modes when the flow
// moves about one cell per substep.
// A is plain semi-Lagrangian (`advect_diffuse`), or MacCormack (Selle et al. 2008):
//   `advect_predict`:     u_hat = A(w)
//   `maccormack_correct`: u* = clamp(u_hat + (w - A^-1(u_hat)) / 2, extrema of A's stencil of w)
// Dispatch: (ceil((nx+1)/64), ny+1, E); thread (i, j, e) owns u face (i, j) and v face (i, j).
// Reads u_in/v_in, w_u/w_v (and u_hat/v_hat), body, inlet; writes w, u_hat/v_hat or u_out/v_out.
// Bindings per entry point: src/gpu/kernels/advect.rs. So that `maccormack_correct` fits in 10
// storage buffers, `advect_predict` stores the inlet face's value in u_hat[k].w (i = 0; that
// component is otherwise unused there) and the correction copies it instead of reading inlet.

// Velocity of the input field at (x, y).
fn velocity_in(e: u32, pos: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(
        bilerp(stencil_u_in(e, pos.x, pos.y)),
        bilerp(stencil_v_in(e, pos.x, pos.y)),
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
        v = fetch_v_in(e, a - 1, b) + fetch_v_in(e, a, b)
            + fetch_v_in(e, a - 1, b + 1) + fetch_v_in(e, a, b + 1);
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
        u = fetch_u_in(e, a, b - 1) + fetch_u_in(e, a + 1, b - 1)
            + fetch_u_in(e, a, b) + fetch_u_in(e, a + 1, b);
    }
    return vec2<f32>(0.25 * u, v_in[v_idx(e, i, j)]);
}

fn trace_u_face(e: u32, i: u32, j: u32, h: f32) -> vec2<f32> {
    return trace(e, u_face_pos(i, j), velocity_at_u_face(e, i, j), h);
}

fn trace_v_face(e: u32, i: u32, j: u32, h: f32) -> vec2<f32> {
    return trace(e, v_face_pos(i, j), velocity_at_v_face(e, i, j), h);
}


fn inlet_profile(e: u32, j: u32) -> f32 {
    let y = (f32(j) + 0.5) * P.dy;
    let centre = inlet[e * P.substeps + S.index];
    return 4.0 * centre * y * (P.height - y) / (P.height * P.height);
}

// dt nu lap u at the stored u face (i, j) of the input field (ghosts as in common.wgsl).
fn diffusion_u(e: u32, i: i32, j: i32) -> f32 {
    if (i >= 1 && i < i32(P.nx) && j >= 1 && j + 1 < i32(P.ny)) {
        // Interior: the five faces need no ghost mapping.
        let k = u_idx(e, u32(i), u32(j));
        let row = P.nx + 1u;
        let c = u_in[k];
        let lx = u_in[k + 1u] + u_in[k - 1u] - 2.0 * c;
        let ly = u_in[k + row] + u_in[k - row] - 2.0 * c;
        return P.dt * P.nu * (lx / (P.dx * P.dx) + ly / (P.dy * P.dy));
    }
    let c = fetch_u_in(e, i, j);
    let lx = fetch_u_in(e, i + 1, j) + fetch_u_in(e, i - 1, j) - 2.0 * c;
    let ly = fetch_u_in(e, i, j + 1) + fetch_u_in(e, i, j - 1) - 2.0 * c;
    return P.dt * P.nu * (lx / (P.dx * P.dx) + ly / (P.dy * P.dy));
}

fn diffusion_v(e: u32, i: i32, j: i32) -> f32 {
    if (i >= 1 && i + 1 < i32(P.nx) && j >= 1 && j < i32(P.ny)) {
        let k = v_idx(e, u32(i), u32(j));
        let c = v_in[k];
        let lx = v_in[k + 1u] + v_in[k - 1u] - 2.0 * c;
        let ly = v_in[k + P.nx] + v_in[k - P.nx] - 2.0 * c;
        return P.dt * P.nu * (lx / (P.dx * P.dx) + ly / (P.dy * P.dy));
    }
    let c = fetch_v_in(e, i, j);
    let lx = fetch_v_in(e, i + 1, j) + fetch_v_in(e, i - 1, j) - 2.0 * c;
    let ly = fetch_v_in(e, i, j + 1) + fetch_v_in(e, i, j - 1) - 2.0 * c;
    return P.dt * P.nu * (lx / (P.dx * P.dx) + ly / (P.dy * P.dy));
}

@compute @workgroup_size(64, 1, 1)
fn diffuse(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let j = g.y;
    let e = g.z;
    if (e >= P.n_env) {
        return;
    }
    if (i <= P.nx && j < P.ny) {
        let k = u_idx(e, i, j);
        if (i == 0u) {
            w_u[k] = u_in[k];
        } else {
            w_u[k] = u_in[k] + diffusion_u(e, i32(i), i32(j));
        }
    }
    if (i < P.nx && j <= P.ny) {
        let k = v_idx(e, i, j);
        if (j == 0u || j == P.ny) {
            w_v[k] = 0.0;
        } else {
            w_v[k] = v_in[k] + diffusion_v(e, i32(i), i32(j));
        }
    }
    if (P.n_members > 0u && i < P.nx && j < P.ny) {
        let paint = paint_cell(e, i, j);
        if (paint.write) {
            body[c_idx(e, i, j)] = paint.cell;
        }
    }
}

// Whether a face lies so far from the swarm's bounding box that both its cells are fluid:
// `paint_bodies` leaves chi = 0 beyond r + dx/2 of every member, so the body field need not be
// read there. A batch without members (bodies from `set_body`) always reads it.
fn clear_of_swarm(e: u32, pos: vec2<f32>) -> bool {
    if (P.n_members == 0u) {
        return false;
    }
    let bx = swarm_box[2u * e];
    let reach = P.radius + 2.0 * max(P.dx, P.dy);
    return pos.x < bx.x - reach || pos.x > bx.y + reach || pos.y < bx.z - reach || pos.y > bx.w + reach;
}

// Brinkman blend on a face between cells a and b: (1 - chi_f) w + (chi_a w_a + chi_b w_b) / 2
// with chi_f = (chi_a + chi_b) / 2 (component 1: body u, component 2: body v).
fn brinkman_u(e: u32, i: u32, j: u32, w: f32) -> f32 {
    if (clear_of_swarm(e, u_face_pos(i, j))) {
        return w;
    }
    let ka = c_idx(e, max(i, 1u) - 1u, j);
    let kb = c_idx(e, min(i, P.nx - 1u), j);
    let chi_a = body[ka].x;
    let chi_b = body[kb].x;
    if (chi_a == 0.0 && chi_b == 0.0) {
        return w; // fluid face: the body velocities are not read
    }
    let chi = 0.5 * (chi_a + chi_b);
    return (1.0 - chi) * w + 0.5 * (chi_a * body[ka].y + chi_b * body[kb].y);
}

fn brinkman_v(e: u32, i: u32, j: u32, w: f32) -> f32 {
    if (clear_of_swarm(e, v_face_pos(i, j))) {
        return w;
    }
    let ka = c_idx(e, i, j - 1u);
    let kb = c_idx(e, i, j);
    let chi_a = body[ka].x;
    let chi_b = body[kb].x;
    if (chi_a == 0.0 && chi_b == 0.0) {
        return w;
    }
    let chi = 0.5 * (chi_a + chi_b);
    return (1.0 - chi) * w + 0.5 * (chi_a * body[ka].z + chi_b * body[kb].z);
}

// Semi-Lagrangian value at a face: the face traced back by h in the input velocity, then the
// diffused field (`advect_diffuse`) or the predictor (the correction's backward step) there.
fn sl_u_diffused(e: u32, i: u32, j: u32, h: f32) -> f32 {
    let d = trace_u_face(e, i, j, h);
    return bilerp(stencil_u_diffused(e, d.x, d.y));
}

fn sl_v_diffused(e: u32, i: u32, j: u32, h: f32) -> f32 {
    let d = trace_v_face(e, i, j, h);
    return bilerp(stencil_v_diffused(e, d.x, d.y));
}

fn sl_u_hat(e: u32, i: u32, j: u32, h: f32) -> f32 {
    let d = trace_u_face(e, i, j, h);
    return bilerp(stencil_u_hat(e, d.x, d.y));
}

fn sl_v_hat(e: u32, i: u32, j: u32, h: f32) -> f32 {
    let d = trace_v_face(e, i, j, h);
    return bilerp(stencil_v_hat(e, d.x, d.y));
}

// Finish a u face from its advected value: inlet value, or Brinkman blend.
fn finish_u(e: u32, i: u32, j: u32, advected: f32) -> f32 {
    if (i == 0u) {
        return inlet_profile(e, j);
    }
    return brinkman_u(e, i, j, advected);
}

fn finish_v(e: u32, i: u32, j: u32, advected: f32) -> f32 {
    if (j == 0u || j == P.ny) {
        return 0.0;
    }
    return brinkman_v(e, i, j, advected);
}

@compute @workgroup_size(64, 1, 1)
fn advect_diffuse(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let j = g.y;
    let e = g.z;
    if (e >= P.n_env) {
        return;
    }
    if (i <= P.nx && j < P.ny) {
        var adv = 0.0;
        if (i > 0u) {
            adv = sl_u_diffused(e, i, j, P.dt);
        }
        u_out[u_idx(e, i, j)] = finish_u(e, i, j, adv);
    }
    if (i < P.nx && j <= P.ny) {
        var adv = 0.0;
        if (j > 0u && j < P.ny) {
            adv = sl_v_diffused(e, i, j, P.dt);
        }
        v_out[v_idx(e, i, j)] = finish_v(e, i, j, adv);
    }
}

// MacCormack predictor with the extrema of its stencil (for the correction's clamp) and, in
// .w, the face's interpolated transverse velocity, so that the correction's Euler back-trace
// (the same velocity, the other direction) need not gather it again.
fn predict_u(e: u32, i: u32, j: u32) -> vec4<f32> {
    let vel = velocity_at_u_face(e, i, j);
    let d = trace(e, u_face_pos(i, j), vel, P.dt);
    let st = stencil_u_diffused(e, d.x, d.y);
    return vec4<f32>(bilerp(st), stencil_min(st), stencil_max(st), vel.y);
}

fn predict_v(e: u32, i: u32, j: u32) -> vec4<f32> {
    let vel = velocity_at_v_face(e, i, j);
    let d = trace(e, v_face_pos(i, j), vel, P.dt);
    let st = stencil_v_diffused(e, d.x, d.y);
    return vec4<f32>(bilerp(st), stencil_min(st), stencil_max(st), vel.x);
}

// The correction's backward semi-Lagrangian value A^-1(u_hat) at u face (i, j); h = u_hat[k].
fn back_u(e: u32, i: u32, j: u32, k: u32, h: vec4<f32>) -> f32 {
    if (P.rk2 != 0u) {
        return sl_u_hat(e, i, j, -P.dt);
    }
    let d = u_face_pos(i, j) + P.dt * vec2<f32>(u_in[k], h.w);
    return bilerp(stencil_u_hat(e, d.x, d.y));
}

fn back_v(e: u32, i: u32, j: u32, k: u32, h: vec4<f32>) -> f32 {
    if (P.rk2 != 0u) {
        return sl_v_hat(e, i, j, -P.dt);
    }
    let d = v_face_pos(i, j) + P.dt * vec2<f32>(h.w, v_in[k]);
    return bilerp(stencil_v_hat(e, d.x, d.y));
}

@compute @workgroup_size(64, 1, 1)
fn advect_predict(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let j = g.y;
    let e = g.z;
    if (e >= P.n_env) {
        return;
    }
    if (i <= P.nx && j < P.ny) {
        let k = u_idx(e, i, j);
        if (i == 0u) {
            // .w: the inlet value, which `maccormack_correct` copies to u_out.
            u_hat[k] = vec4<f32>(u_in[k], u_in[k], u_in[k], inlet_profile(e, j));
        } else {
            u_hat[k] = predict_u(e, i, j);
        }
    }
    if (i < P.nx && j <= P.ny) {
        let k = v_idx(e, i, j);
        if (j == 0u || j == P.ny) {
            v_hat[k] = vec4<f32>(0.0);
        } else {
            v_hat[k] = predict_v(e, i, j);
        }
    }
}

// MacCormack value clamped to the predictor's stencil extrema. A non-finite value is passed
// through unclamped: min/max ignore NaN, and clamping would hide a blow-up from the health check.
fn limited(h: vec4<f32>, w: f32, back: f32) -> f32 {
    let raw = h.x + 0.5 * (w - back);
    if (!is_finite(raw)) {
        return raw;
    }
    return clamp(raw, h.y, h.z);
}

@compute @workgroup_size(64, 1, 1)
fn maccormack_correct(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let j = g.y;
    let e = g.z;
    if (e >= P.n_env) {
        return;
    }
    if (i <= P.nx && j < P.ny) {
        let k = u_idx(e, i, j);
        let h = u_hat[k];
        if (i == 0u) {
            u_out[k] = h.w; // the inlet value (`advect_predict`), as finish_u would give
        } else {
            u_out[k] = brinkman_u(e, i, j, limited(h, w_u[k], back_u(e, i, j, k, h)));
        }
    }
    if (i < P.nx && j <= P.ny) {
        var adv = 0.0;
        if (j > 0u && j < P.ny) {
            let k = v_idx(e, i, j);
            let h = v_hat[k];
            adv = limited(h, w_v[k], back_v(e, i, j, k, h));
        }
        v_out[v_idx(e, i, j)] = finish_v(e, i, j, adv);
    }
}
