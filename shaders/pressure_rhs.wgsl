// Pressure right-hand side, transformed to the y-cosine modes of each column.
//
//   b(i, j) = rho / dt * div u*(i, j),   div = (u[i+1,j] - u[i,j]) / dx + (v[i,j+1] - v[i,j]) / dy
//   phat[e][k][i] = sum_j Q[j][k] b(i, j)          (Q: orthonormal DCT-II, Neumann walls)
// Also records max_j |div u*| of each column in divstar[e][i] (for the relative residual).
// Dispatch: (ceil(nx/64), ny, E); thread (i, k, e). Reads u_out/v_out (the predicted field).

@compute @workgroup_size(64, 1, 1)
fn pressure_rhs(@builtin(global_invocation_id) g: vec3<u32>) {
    let i = g.x;
    let k = g.y;
    let e = g.z;
    if (i >= P.nx || k >= P.ny || e >= P.n_env) {
        return;
    }
    var acc = 0.0;
    var dmax = 0.0;
    for (var j = 0u; j < P.ny; j++) {
        let div = (u_out[u_idx(e, i + 1u, j)] - u_out[u_idx(e, i, j)]) / P.dx
            + (v_out[v_idx(e, i, j + 1u)] - v_out[v_idx(e, i, j)]) / P.dy;
        acc += poisson[j * P.ny + k] * div;
        dmax = max(dmax, abs(div));
    }
    phat[(e * P.ny + k) * P.nx + i] = acc * P.rho / P.dt;
    if (k == 0u) {
        divstar[e * P.nx + i] = dmax;
    }
}
