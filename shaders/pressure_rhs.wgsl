// Pressure right-hand side, transformed to the y-cosine modes of each column.
//
//   b(i, j) = rho / dt * div u*(i, j),   div = (u[i+1,j] - u[i,j]) / dx + (v[i,j+1] - v[i,j]) / dy
//   phat[e][k][i] = sum_j Q[j][k] b(i, j)          (Q: orthonormal DCT-II, Neumann walls)
// Also records max_j |div u*| of each column in divstar[e][i] (for the relative residual).
// Dispatch: (ceil(nx/64), E, 1); thread (i, e) owns column i: ny divergences (computed once,
// kept in lane-interleaved workgroup scratch), then ny^2 / 2 multiply-adds: the basis is
// mirror-symmetric, Q[ny-1-j][k] = (-1)^k Q[j][k], so even modes need only the sums
// b_j + b_{ny-1-j} and odd modes the differences (and the middle row of an odd ny only
// reaches even modes). Needs ny <= MAX_NY.
// Reads u_out/v_out (the predicted field).

const MAX_NY: u32 = 64u;
const LANES: u32 = 64u;
var<workgroup> column: array<f32, 4096>; // [j * LANES + lane], MAX_NY * LANES

@compute @workgroup_size(64, 1, 1)
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
    let scale = P.rho / P.dt;
    let odd_ny = (P.ny & 1u) == 1u;
    for (var k = 0u; k < P.ny; k++) {
        var acc = 0.0;
        if ((k & 1u) == 0u) {
            for (var j = 0u; j < half; j++) {
                acc += poisson[j * P.ny + k] * column[j * LANES + lane];
            }
            if (odd_ny) {
                acc += poisson[half * P.ny + k] * column[half * LANES + lane];
            }
        } else {
            for (var j = 0u; j < half; j++) {
                acc += poisson[j * P.ny + k] * column[(P.ny - 1u - j) * LANES + lane];
            }
        }
        phat[(e * P.ny + k) * P.nx + i] = acc * scale;
    }
}
