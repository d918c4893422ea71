// Exact solve of the empty channel's pressure Poisson equation, one y-mode at a time.
//
// In the cosine basis of the walls the 5-point Laplacian separates: for mode k,
//   (p[i-1] - 2 p[i] + p[i+1]) / dx^2 + lambda_k p[i] = b[i],  lambda_k = -4 sin^2(pi k / 2ny) / dy^2
// with p[-1] = p[0] (Neumann inlet) and p[nx] = -p[nx-1] (p = 0 on the outlet face). The
// tridiagonal LU (Thomas) factors c' and 1/m come precomputed in f64 from the CPU.
// Dispatch: (ceil(ny/16), E, 1); thread (k, e) runs the forward and backward sweeps over nx
// (2 nx loop trips, far below any driver loop cap). In place on phat[e][k][:].

@compute @workgroup_size(16, 1, 1)
fn pressure_solve(@builtin(global_invocation_id) g: vec3<u32>) {
    let k = g.x;
    let e = g.y;
    if (k >= P.ny || e >= P.n_env) {
        return;
    }
    let base = (e * P.ny + k) * P.nx;
    let c_base = P.ny * P.ny + k * P.nx;
    let m_base = P.ny * P.ny + P.ny * P.nx + k * P.nx;
    let dx2 = P.dx * P.dx;
    var prev = 0.0;
    for (var i = 0u; i < P.nx; i++) {
        let d = (phat[base + i] * dx2 - prev) * poisson[m_base + i];
        phat[base + i] = d;
        prev = d;
    }
    var next = 0.0;
    for (var i = P.nx; i > 0u; i--) {
        let x = phat[base + i - 1u] - poisson[c_base + i - 1u] * next;
        phat[base + i - 1u] = x;
        next = x;
    }
}
