// Pressure right-hand side, transformed to the y-cosine modes of each column.
//
//   b(i, j) = rho / dt * div u*(i, j),   div = (u[i+1,j] - u[i,j]) / dx + (v[i,j+1] - v[i,j]) / dy
//   phat[e][k][i] = sum_j Q[j][k] b(i, j)          (Q: orthonormal DCT-II, Neumann walls)
// Also records max_j |div u*| of each column in divstar[e][i] (for the relative residual).
// Dispatch: (ceil(nx/LANES), E, 1); thread (i, e) owns column i: ny divergences (computed once,
// kept in lane-interleaved workgroup scratch), then ny^2 / 2 multiply-adds: the basis is
// mirror-symmetric, Q[ny-1-j][k] = (-1)^k Q[j][k], so even modes need only the sums
// b_j + b_{ny-1-j} and odd modes the differences (and the middle row of an odd ny only
// reaches even modes). The modes go four at a time (vec4), so each column value is loaded
// once per four modes. Needs ny <= MAX_NY.
// MAX_NY and LANES come from the module's header, chosen for the batch's ny
// (src/gpu/kernels/mod.rs, `Columns`: 64 x 64, 128 x 32 or 256 x 16, 16 KiB of scratch each), and
// so do the workgroup size (LANES) and the dispatch (ceil(nx/LANES), E, 1). A thread's loops run
// about ny^2 / 8 trips in all (under 9,000 at ny = 256), far below the 65,535 of a capped Mesa.
// Reads u_out/v_out (the predicted field).

var<workgroup> column: array<f32, MAX_NY * LANES>; // [j * LANES + lane]

@compute @workgroup_size(LANES, 1, 1)
fn pressure_rhs(@builtin(global_invocation_id) g: vec3<u32>, @builtin(local_invocation_id) l: vec3<u32>) {
    let i = g.x;
    let e = g.y;
    let lane = l.x;
    if (i >= P.nx || e >= P.n_env) {
        return;
    }
    var dmax = 0.0;
    for (var j = 0u; j < P.ny; j++) {
        let div = (u_out[u_idx(e, i + 1u, j)] - u_out[u_idx(e, i, j)]) / P.dx
            + (v_out[v_idx(e, i, j + 1u)] - v_out[v_idx(e, i, j)]) / P.dy;
        column[j * LANES + lane] = div;
        dmax = max(dmax, abs(div));
    }
    divstar[e * P.nx + i] = dmax;
    // In place: slot j <- b_j + b_{ny-1-j}, slot ny-1-j <- b_j - b_{ny-1-j} (j < ny/2).
    let half = P.ny / 2u;
    for (var j = 0u; j < half; j++) {
        let lo = column[j * LANES + lane];
        let hi = column[(P.ny - 1u - j) * LANES + lane];
        column[j * LANES + lane] = lo + hi;
        column[(P.ny - 1u - j) * LANES + lane] = lo - hi;
    }
    // Four modes of one parity per pass over the half column: one load of the column value
    // feeds four multiply-adds (table: PoissonTables::forward_packed, vec4 per row).
    let scale = P.rho / P.dt;
    let rows = (P.ny + 1u) / 2u;
    let groups = (rows + 3u) / 4u;
    let table = P.ny * P.ny + 2u * P.ny * P.nx;
    for (var parity = 0u; parity < 2u; parity++) {
        for (var group = 0u; group < groups; group++) {
            var acc = vec4<f32>(0.0);
            let at = table + ((parity * groups + group) * rows) * 4u;
            var n = rows;
            if (parity == 1u) {
                n = half; // odd modes do not reach the middle row
            }
            for (var j = 0u; j < n; j++) {
                var slot = j;
                if (parity == 1u) {
                    slot = P.ny - 1u - j;
                }
                let b = column[slot * LANES + lane];
                let q = at + j * 4u;
                acc += b * vec4<f32>(poisson[q], poisson[q + 1u], poisson[q + 2u], poisson[q + 3u]);
            }
            let k0 = 8u * group + parity;
            let out = e * P.ny;
            if (k0 < P.ny) {
                phat[(out + k0) * P.nx + i] = acc.x * scale;
            }
            if (k0 + 2u < P.ny) {
                phat[(out + k0 + 2u) * P.nx + i] = acc.y * scale;
            }
            if (k0 + 4u < P.ny) {
                phat[(out + k0 + 4u) * P.nx + i] = acc.z * scale;
            }
            if (k0 + 6u < P.ny) {
                phat[(out + k0 + 6u) * P.nx + i] = acc.w * scale;
            }
        }
    }
}
