// The swarm: members as moving Brinkman bodies, and their motion.
//
// `paint_bodies`, dispatch (ceil(nx/64), ny, E), thread (i, j, e) = cell (`paint_cell` in
// common.wgsl; the control step runs it inside `diffuse`, this entry serves tests and timing):
//   chi = max over members of clamp(1/2 + (r - |x_c - x_m|) / dx, 0, 1) (a one-cell ramp, so a
//   moving member changes the field smoothly), body velocity = that member's velocity.
//   Cells outside the swarm's bounding box (swarm_box[e][0], grown by r + dx) skip the member
//   loop, and cells outside both it and the box of the previous paint (swarm_box[e][1]) are
//   already zero and are not written at all.
// `move_members`, dispatch (E, 1, 1), one workgroup of 64 per environment, thread m = member:
//   p_k, u_k sampled (bilinear) at the 4 points x + R_s (cos t_k, sin t_k), t_k = 0, 90, 180,
//   270 deg, clamped into the channel; after the projection (the `out` samplers).
//   F_hydro = -(pi r / 2) d sum_k p_k (cos t_k, sin t_k),  d = 4 r^2 / (3 R_s)
//   F_prop  = F_max a / max(1, |a|) for the raw action a in thrust[]
//   F_drag  = k (u_f - v),  k = 1/2 rho pi r^2 C_d |u_f - v|  (Schiller-Naumann; 0 if off),
//             u_f the mean of the u_k; C_d |v_rel| is evaluated without dividing by |v_rel|
//   F_contact,i = sum_{j touching} [ (F_j . n_ij)+ + (F_i . n_ji)+ ] n_ij   (push + reaction)
//   semi-implicit Euler: v' = (v + dt/m (F_hydro + F_prop + F_contact + k u_f)) / (1 + dt k/m),
//   x' = x + dt v'; then 4 Jacobi sweeps remove overlaps with other members (half each, all of
//   it against a pinned one), the walls and the ends, and the approaching normal velocity.
// Every member reads the others from workgroup memory: deterministic, no atomics.

const PI: f32 = 3.14159265358979;
const SWEEPS: u32 = 4u;

@compute @workgroup_size(64, 1, 1)
fn paint_bodies(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let j = g.y;
    let e = g.z;
    if (i >= P.nx || j >= P.ny || e >= P.n_env) {
        return;
    }
    let paint = paint_cell(e, i, j);
    if (paint.write) {
        body[c_idx(e, i, j)] = paint.cell;
    }
}

// Pressure at (x, y), bilinear in the cell centres, constant beyond the outer centres.
fn sample_p(e: u32, x: f32, y: f32) -> f32 {
    let fx = clamp(x * P.inv_dx - 0.5, 0.0, f32(P.nx - 1u));
    let fy = clamp(y * P.inv_dy - 0.5, 0.0, f32(P.ny - 1u));
    let i0 = min(u32(fx), P.nx - 2u);
    let j0 = min(u32(fy), P.ny - 2u);
    let tx = fx - f32(i0);
    let ty = fy - f32(j0);
    let bottom = mix(p[c_idx(e, i0, j0)], p[c_idx(e, i0 + 1u, j0)], tx);
    let top = mix(p[c_idx(e, i0, j0 + 1u)], p[c_idx(e, i0 + 1u, j0 + 1u)], tx);
    return mix(bottom, top, ty);
}

// F_prop = F_max a / max(1, |a|) for the raw action a (N).
fn propulsion(a: vec2<f32>) -> vec2<f32> {
    return P.max_thrust * a / max(1.0, length(a));
}

// C_d |v_rel| of the Schiller-Naumann law (m/s), finite at v_rel = 0.
fn cd_times_speed(speed: f32) -> f32 {
    let re = P.rho * speed * 2.0 * P.radius / P.mu;
    let stokes = 24.0 * P.mu / (P.rho * 2.0 * P.radius); // (24 / Re) |v_rel|
    if (re < 0.1) {
        return stokes;
    }
    if (re < 1000.0) {
        return stokes * (1.0 + 0.15 * pow(re, 0.687));
    }
    return 0.44 * speed;
}

var<workgroup> wpos: array<vec2<f32>, 64>;
var<workgroup> wvel: array<vec2<f32>, 64>;
var<workgroup> wforce: array<vec2<f32>, 64>;
var<workgroup> wpin: array<f32, 64>;

@compute @workgroup_size(64, 1, 1)
fn move_members(@builtin(local_invocation_id) l: vec3<u32>, @builtin(workgroup_id) w: vec3<u32>) {
    let e = w.x;
    let m = l.x;
    let n = P.n_members;
    let live = m < n && e < P.n_env;
    let k = e * n + m;
    var me = Member(vec2<f32>(0.0), vec2<f32>(0.0), 0.0, 0.0, 0.0, 0.0);
    if (live) {
        me = members[k];
        wpos[m] = me.pos;
        wforce[m] = propulsion(thrust[k]);
        wpin[m] = me.pinned;
    }
    workgroupBarrier();
    var diag = MemberDiag(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), vec4<f32>(0.0));
    var vel = me.vel;
    var pos = me.pos;
    if (live) {
        // Samples at 0, 90, 180, 270 degrees, clamped into the channel.
        let lo = vec2<f32>(0.0, 0.0);
        let hi = vec2<f32>(P.length, P.height);
        let q0 = clamp(me.pos + vec2<f32>(P.sample_radius, 0.0), lo, hi);
        let q1 = clamp(me.pos + vec2<f32>(0.0, P.sample_radius), lo, hi);
        let q2 = clamp(me.pos - vec2<f32>(P.sample_radius, 0.0), lo, hi);
        let q3 = clamp(me.pos - vec2<f32>(0.0, P.sample_radius), lo, hi);
        let ps = vec4<f32>(sample_p(e, q0.x, q0.y), sample_p(e, q1.x, q1.y), sample_p(e, q2.x, q2.y), sample_p(e, q3.x, q3.y));
        var uf = vec2<f32>(0.0);
        for (var s = 0u; s < 4u; s++) {
            var q = q0;
            if (s == 1u) { q = q1; } else if (s == 2u) { q = q2; } else if (s == 3u) { q = q3; }
            uf += vec2<f32>(bilerp(stencil_u_out(e, q.x, q.y)), bilerp(stencil_v_out(e, q.x, q.y)));
        }
        uf *= 0.25;
        let hydro = -(PI * P.radius / 2.0) * P.depth * vec2<f32>(ps.x - ps.z, ps.y - ps.w);
        let rel = uf - me.vel;
        var kd = 0.0;
        if (P.drag != 0u) {
            kd = 0.5 * P.rho * PI * P.radius * P.radius * cd_times_speed(length(rel));
        }
        let own = wforce[m];
        var contact = vec2<f32>(0.0);
        for (var j = 0u; j < n; j++) {
            let d = me.pos - wpos[j];
            let dist = length(d);
            if (j != m && dist > 0.0 && dist <= 2.0 * P.radius) {
                let nij = d / dist;
                contact += (max(dot(wforce[j], nij), 0.0) + max(dot(own, -nij), 0.0)) * nij;
            }
        }
        diag.hydro = hydro;
        diag.drag = kd * rel;
        diag.contact = contact;
        diag.prop = own;
        diag.p = ps;
        if (me.pinned == 0.0) {
            let h = P.dt / P.mass;
            vel = (me.vel + h * (hydro + own + contact + kd * uf)) / (1.0 + h * kd);
            pos = me.pos + P.dt * vel;
        } else {
            vel = vec2<f32>(0.0);
        }
    }
    workgroupBarrier();
    if (live) {
        wpos[m] = pos;
        wvel[m] = vel;
    }
    workgroupBarrier();
    for (var sweep = 0u; sweep < SWEEPS; sweep++) {
        var dpos = vec2<f32>(0.0);
        var dvel = vec2<f32>(0.0);
        if (live && me.pinned == 0.0) {
            for (var j = 0u; j < n; j++) {
                let d = wpos[m] - wpos[j];
                let dist = length(d);
                if (j != m && dist > 0.0 && dist < 2.0 * P.radius) {
                    let nij = d / dist;
                    let share = select(0.5, 1.0, wpin[j] != 0.0);
                    dpos += share * (2.0 * P.radius - dist) * nij;
                    let approach = dot(wvel[m] - wvel[j], nij);
                    if (approach < 0.0) {
                        dvel -= share * approach * nij;
                    }
                }
            }
        }
        workgroupBarrier();
        if (live && me.pinned == 0.0) {
            var q = wpos[m] + dpos;
            var v = wvel[m] + dvel;
            let lo = vec2<f32>(P.radius, P.radius);
            let hi = vec2<f32>(P.length - P.radius, P.height - P.radius);
            if (q.x < lo.x) { q.x = lo.x; v.x = max(v.x, 0.0); }
            if (q.x > hi.x) { q.x = hi.x; v.x = min(v.x, 0.0); }
            if (q.y < lo.y) { q.y = lo.y; v.y = max(v.y, 0.0); }
            if (q.y > hi.y) { q.y = hi.y; v.y = min(v.y, 0.0); }
            wpos[m] = q;
            wvel[m] = v;
        }
        workgroupBarrier();
    }
    if (live) {
        members[k] = Member(wpos[m], wvel[m], me.pinned, 0.0, 0.0, 0.0);
        member_diag[k] = diag;
    }
    if (m == 0u && e < P.n_env && n > 0u) {
        var bx = vec4<f32>(wpos[0].x, wpos[0].x, wpos[0].y, wpos[0].y);
        for (var j = 1u; j < n; j++) {
            bx = vec4<f32>(min(bx.x, wpos[j].x), max(bx.y, wpos[j].x), min(bx.z, wpos[j].y), max(bx.w, wpos[j].y));
        }
        // The box just painted becomes the one to clear next time.
        swarm_box[2u * e + 1u] = swarm_box[2u * e];
        swarm_box[2u * e] = bx;
    }
}
