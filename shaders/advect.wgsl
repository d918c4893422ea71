// Momentum predictor: explicit viscous diffusion, then semi-Lagrangian advection (RK2 trace
// in the velocity u^n, bilinear), inlet/wall boundary values and Brinkman blending.
//
//   w = u^n + dt nu lap u^n   (evaluated on the fly at the stencil nodes: SRC_DIFFUSED)
//   u* = A(w),   then  u* <- (1 - chi_f) u* + chi_f u_body   (solid faces)
//
// Advecting the diffused field (sequential splitting) keeps the scheme stable at CFL ~ 1;
// adding lap u^n at the arrival point instead amplifies the grid-scale modes when the flow
// moves about one cell per substep.
// A is plain semi-Lagrangian (`advect_diffuse`), or MacCormack (Selle et al. 2008):
//   `advect_predict`:     u_hat = A(w)
//   `maccormack_correct`: u* = clamp(u_hat + (w - A^-1(u_hat)) / 2, extrema of A's stencil of w)
// Dispatch: (ceil((nx+1)/64), ny+1, E); thread (i, j, e) owns u face (i, j) and v face (i, j).
// Reads u_in/v_in (and u_hat/v_hat), body, inlet; writes u_out/v_out (or u_hat/v_hat).

fn inlet_profile(e: u32, j: u32) -> f32 {
    let y = (f32(j) + 0.5) * P.dy;
    let centre = inlet[e * P.substeps + S.index];
    return 4.0 * centre * y * (P.height - y) / (P.height * P.height);
}

// Brinkman blend on a face between cells a and b: (1 - chi_f) w + (chi_a w_a + chi_b w_b) / 2
// with chi_f = (chi_a + chi_b) / 2 (component 1: body u, component 2: body v).
fn brinkman_u(e: u32, i: u32, j: u32, w: f32) -> f32 {
    let a = body[c_idx(e, max(i, 1u) - 1u, j)];
    let b = body[c_idx(e, min(i, P.nx - 1u), j)];
    let chi = 0.5 * (a.x + b.x);
    return (1.0 - chi) * w + 0.5 * (a.x * a.y + b.x * b.y);
}

fn brinkman_v(e: u32, i: u32, j: u32, w: f32) -> f32 {
    let a = body[c_idx(e, i, j - 1u)];
    let b = body[c_idx(e, i, j)];
    let chi = 0.5 * (a.x + b.x);
    return (1.0 - chi) * w + 0.5 * (a.x * a.z + b.x * b.z);
}

fn u_face_pos(i: u32, j: u32) -> vec2<f32> {
    return vec2<f32>(f32(i) * P.dx, (f32(j) + 0.5) * P.dy);
}

fn v_face_pos(i: u32, j: u32) -> vec2<f32> {
    return vec2<f32>((f32(i) + 0.5) * P.dx, f32(j) * P.dy);
}

fn sl_u(src: u32, e: u32, i: u32, j: u32, h: f32) -> f32 {
    let d = trace(e, u_face_pos(i, j), h);
    return bilerp(stencil_u(src, e, d.x, d.y));
}

fn sl_v(src: u32, e: u32, i: u32, j: u32, h: f32) -> f32 {
    let d = trace(e, v_face_pos(i, j), h);
    return bilerp(stencil_v(src, e, d.x, d.y));
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
            adv = sl_u(SRC_DIFFUSED, e, i, j, P.dt);
        }
        u_out[u_idx(e, i, j)] = finish_u(e, i, j, adv);
    }
    if (i < P.nx && j <= P.ny) {
        var adv = 0.0;
        if (j > 0u && j < P.ny) {
            adv = sl_v(SRC_DIFFUSED, e, i, j, P.dt);
        }
        v_out[v_idx(e, i, j)] = finish_v(e, i, j, adv);
    }
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
            u_hat[k] = u_in[k];
        } else {
            u_hat[k] = sl_u(SRC_DIFFUSED, e, i, j, P.dt);
        }
    }
    if (i < P.nx && j <= P.ny) {
        let k = v_idx(e, i, j);
        if (j == 0u || j == P.ny) {
            v_hat[k] = 0.0;
        } else {
            v_hat[k] = sl_v(SRC_DIFFUSED, e, i, j, P.dt);
        }
    }
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
        var adv = 0.0;
        if (i > 0u) {
            let pos = u_face_pos(i, j);
            let k = u_idx(e, i, j);
            let back = sl_u(SRC_HAT, e, i, j, -P.dt);
            let d = trace(e, pos, P.dt);
            let st = stencil_u(SRC_DIFFUSED, e, d.x, d.y);
            let w = value_u(SRC_DIFFUSED, e, i32(i), i32(j));
            adv = clamp(u_hat[k] + 0.5 * (w - back), stencil_min(st), stencil_max(st));
        }
        u_out[u_idx(e, i, j)] = finish_u(e, i, j, adv);
    }
    if (i < P.nx && j <= P.ny) {
        var adv = 0.0;
        if (j > 0u && j < P.ny) {
            let pos = v_face_pos(i, j);
            let k = v_idx(e, i, j);
            let back = sl_v(SRC_HAT, e, i, j, -P.dt);
            let d = trace(e, pos, P.dt);
            let st = stencil_v(SRC_DIFFUSED, e, d.x, d.y);
            let w = value_v(SRC_DIFFUSED, e, i32(i), i32(j));
            adv = clamp(v_hat[k] + 0.5 * (w - back), stencil_min(st), stencil_max(st));
        }
        v_out[v_idx(e, i, j)] = finish_v(e, i, j, adv);
    }
}
