// Projection: back from modes to pressure, and the velocity correction.
//
//   p(i, j) = sum_k Q[j][k] phat[e][k][i]                       (Pa)
//   u <- u - dt / rho * (p(i, j) - p(i-1, j)) / dx,  v <- v - dt / rho * (p(i, j) - p(i, j-1)) / dy
// Inlet and wall faces keep their Dirichlet values; the outlet face uses the ghost
// p(nx, j) = -p(nx-1, j) (p = 0 on the face).
// Dispatch: (ceil((nx+1)/64), ny+1, E); thread (i, j, e) owns cell (i, j), u face (i, j) and
// v face (i, j). Reads phat; writes p and u_out/v_out in place.

fn p_cell(e: u32, i: u32, j: u32) -> f32 {
    var acc = 0.0;
    for (var k = 0u; k < P.ny; k++) {
        acc += poisson[j * P.ny + k] * phat[(e * P.ny + k) * P.nx + i];
    }
    return acc;
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
    var here = 0.0;
    if (i < P.nx && j < P.ny) {
        here = p_cell(e, i, j);
        p[c_idx(e, i, j)] = here;
    }
    if (j < P.ny && i >= 1u) {
        let left = p_cell(e, i - 1u, j);
        var right = here;
        if (i == P.nx) {
            right = -left;
        }
        u_out[u_idx(e, i, j)] -= scale * (right - left) / P.dx;
    }
    if (i < P.nx && j >= 1u && j < P.ny) {
        let below = p_cell(e, i, j - 1u);
        v_out[v_idx(e, i, j)] -= scale * (here - below) / P.dy;
    }
}
