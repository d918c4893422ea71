// Projection, in two passes.
//
// `pressure_back`: p(i, j) = sum_k Q[j][k] phat[e][k][i] (Pa). Dispatch (ceil(nx/LANES), E, 1);
//   thread (i, e) owns column i (modes kept in lane-interleaved workgroup scratch; ny <= MAX_NY;
//   MAX_NY, LANES and the workgroup size from the module's header, as in pressure_rhs.wgsl).
//   Mirror symmetry halves the work: with E_j, O_j the sums over even and odd k,
//   p(j) = E_j + O_j and p(ny-1-j) = E_j - O_j; the middle row of an odd ny is E_j alone.
// `project`: u <- u - dt / rho * (p(i, j) - p(i-1, j)) / dx,  v <- v - dt / rho * (p(i, j) - p(i, j-1)) / dy.
//   Inlet and wall faces keep their Dirichlet values; the outlet face uses the ghost
//   p(nx, j) = -p(nx-1, j) (p = 0 on the face). Dispatch (ceil((nx+1)/64), ny+1, E); thread
//   (i, j, e) owns u face (i, j) and v face (i, j). Writes u_out/v_out in place.

var<workgroup> modes: array<f32, MAX_NY * LANES>; // [k * LANES + lane]

@compute @workgroup_size(LANES, 1, 1)
fn pressure_back(@builtin(global_invocation_id) g: vec3<u32>, @builtin(local_invocation_id) l: vec3<u32>) {
    let i = g.x;
    let e = g.y;
    let lane = l.x;
    if (i >= P.nx || e >= P.n_env) {
        return;
    }
    for (var k = 0u; k < P.ny; k++) {
        modes[k * LANES + lane] = phat[(e * P.ny + k) * P.nx + i];
    }
    // Four rows per pass over the modes: one load of each mode feeds four multiply-adds
    // (table: PoissonTables::backward_packed, vec4 per mode).
    let rows = (P.ny + 1u) / 2u;
    let table = P.ny * P.ny + 2u * P.ny * P.nx + 2u * ((rows + 3u) / 4u) * rows * 4u;
    for (var group = 0u; group < (rows + 3u) / 4u; group++) {
        var even = vec4<f32>(0.0);
        var odd = vec4<f32>(0.0);
        let at = table + group * P.ny * 4u;
        for (var k = 0u; k < P.ny; k++) {
            let q = at + k * 4u;
            let term = modes[k * LANES + lane]
                * vec4<f32>(poisson[q], poisson[q + 1u], poisson[q + 2u], poisson[q + 3u]);
            if ((k & 1u) == 0u) {
                even += term;
            } else {
                odd += term;
            }
        }
        // p at rows j and their mirrors ny-1-j from the even and odd mode sums (rows past the
        // half skip).
        let j0 = 4u * group;
        for (var r = 0u; r < 4u; r++) {
            let j = j0 + r;
            if (j >= (P.ny + 1u) / 2u) {
                break;
            }
            let mirror = P.ny - 1u - j;
            if (mirror == j) {
                p[c_idx(e, i, j)] = even[r];
            } else {
                p[c_idx(e, i, j)] = even[r] + odd[r];
                p[c_idx(e, i, mirror)] = even[r] - odd[r];
            }
        }
    }
}

@compute @workgroup_size(64, 1, 1)
fn project(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let j = g.y;
    let e = g.z;
    if (e >= P.n_env || i > P.nx || j > P.ny) {
        return;
    }
    let scale = P.dt / P.rho;
    if (j < P.ny && i >= 1u) {
        let left = p[c_idx(e, i - 1u, j)];
        var right = -left;
        if (i < P.nx) {
            right = p[c_idx(e, i, j)];
        }
        u_out[u_idx(e, i, j)] -= scale * (right - left) / P.dx;
    }
    if (i < P.nx && j >= 1u && j < P.ny) {
        v_out[v_idx(e, i, j)] -= scale * (p[c_idx(e, i, j)] - p[c_idx(e, i, j - 1u)]) / P.dy;
    }
}
