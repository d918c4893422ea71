// Health of each environment after a control step (the only per-step read-back).
//
// `diag_columns`, dispatch (ceil((nx+1)/64), E, 1), thread (i, e), for cross-section x = i dx:
//   colstats[e][i] = (flux = sum_j u(i, j) dy  [m^2/s],  max_j |div u| of cell column i [1/s],
//                     max |u|, |v| of the column's faces [m/s],  count of non-finite values)
// `diag_reduce`, dispatch (E, 1, 1), one workgroup of 64 per environment:
//   health[e][0] = (min flux, max flux, max |div u|, max speed)
//   health[e][1] = (non-finite count, max |div u*| before projection, inlet flux, 0)
// Reads u_out/v_out/p (the current field) and divstar.

@compute @workgroup_size(64, 1, 1)
fn diag_columns(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let e = g.y;
    if (i > P.nx || e >= P.n_env) {
        return;
    }
    var flux = 0.0;
    var dmax = 0.0;
    var speed = 0.0;
    var bad = 0.0;
    for (var j = 0u; j < P.ny; j++) {
        let uc = u_out[u_idx(e, i, j)];
        flux += uc * P.dy;
        speed = max(speed, abs(uc));
        if (!is_finite(uc)) {
            bad += 1.0;
        }
        if (i < P.nx) {
            let div = (u_out[u_idx(e, i + 1u, j)] - uc) / P.dx
                + (v_out[v_idx(e, i, j + 1u)] - v_out[v_idx(e, i, j)]) / P.dy;
            dmax = max(dmax, abs(div));
            let vc = v_out[v_idx(e, i, j)];
            speed = max(speed, abs(vc));
            let pc = p[c_idx(e, i, j)];
            if (!is_finite(vc) || !is_finite(pc) || !is_finite(div)) {
                bad += 1.0;
            }
        }
    }
    colstats[e * (P.nx + 1u) + i] = vec4<f32>(flux, dmax, speed, bad);
}

const REDUCE: u32 = 64u;
var<workgroup> red_a: array<vec4<f32>, 64>;
var<workgroup> red_b: array<vec4<f32>, 64>;

@compute @workgroup_size(64, 1, 1)
fn diag_reduce(@builtin(local_invocation_id) l: vec3<u32>, @builtin(workgroup_id) w: vec3<u32>) {
    let e = w.x;
    let t = l.x;
    // (min flux, max flux, max div, max speed), (bad, max div*, -, -)
    var a = vec4<f32>(3.0e38, -3.0e38, 0.0, 0.0);
    var b = vec4<f32>(0.0);
    if (e < P.n_env) {
        for (var i = t; i <= P.nx; i += REDUCE) {
            let c = colstats[e * (P.nx + 1u) + i];
            a = vec4<f32>(min(a.x, c.x), max(a.y, c.x), max(a.z, c.y), max(a.w, c.z));
            b.x += c.w;
        }
        for (var i = t; i < P.nx; i += REDUCE) {
            b.y = max(b.y, divstar[e * P.nx + i]);
        }
    }
    red_a[t] = a;
    red_b[t] = b;
    workgroupBarrier();
    for (var s = REDUCE / 2u; s > 0u; s >>= 1u) {
        if (t < s) {
            let x = red_a[t];
            let y = red_a[t + s];
            red_a[t] = vec4<f32>(min(x.x, y.x), max(x.y, y.y), max(x.z, y.z), max(x.w, y.w));
            red_b[t] = vec4<f32>(red_b[t].x + red_b[t + s].x, max(red_b[t].y, red_b[t + s].y), 0.0, 0.0);
        }
        workgroupBarrier();
    }
    if (t == 0u && e < P.n_env) {
        health[2u * e] = red_a[0];
        health[2u * e + 1u] = vec4<f32>(red_b[0].x, red_b[0].y, colstats[e * (P.nx + 1u)].x, 0.0);
    }
}
