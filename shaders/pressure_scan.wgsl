// Exact solve of the empty channel's pressure Poisson equation, one y-mode per workgroup, as
// two parallel scans: the GPU variant of `pressure_solve` (same Thomas factors, same equations,
// the same result up to the order of rounding).
//
// The Thomas sweeps of mode k are first-order affine recurrences along x:
//   forward   y[i] = (dx^2 b[i] - y[i-1]) / m[i]    = A_i y[i-1] + B_i,  y[-1] = 0
//   backward  x[i] = y[i] - c'[i] x[i+1]            = C_i x[i+1] + y[i], x[nx] = 0
// An affine map f(y) = a y + b composes as (f2 . f1)(y) = a2 a1 y + (a2 b1 + b2), an
// associative operation, so each sweep is a scan. Thread t owns the chunk of
// ceil(nx / SCAN_THREADS) consecutive rows starting at t ceil(nx / SCAN_THREADS) (empty past
// nx): it composes its chunk's maps, a Hillis-Steele scan over the threads' maps in workgroup
// memory (log2 SCAN_THREADS steps) gives every chunk its incoming value, and the thread then
// runs its chunk from that value, writing the result. The backward sweep scans the threads in
// reverse order. No thread runs more than 4 ceil(nx / SCAN_THREADS) dependent steps, against
// 2 nx for a thread of the sequential sweep.
// Dispatch: (ny, E, 1) workgroups of SCAN_THREADS; workgroup (k, e) solves phat[e][k][:] in place.

const SCAN_THREADS: u32 = 256u;
var<workgroup> scan_a: array<f32, SCAN_THREADS>;
var<workgroup> scan_b: array<f32, SCAN_THREADS>;

// Inclusive scan of the threads' maps (a, b) in the order r = 0, 1, ...: afterwards position r
// of scan_a / scan_b holds F_r . F_{r-1} . ... . F_0. Call from uniform control flow.
fn scan_maps(r: u32, a_own: f32, b_own: f32) {
    var a = a_own;
    var b = b_own;
    workgroupBarrier(); // every read of the previous scan's result is done
    scan_a[r] = a;
    scan_b[r] = b;
    for (var offset = 1u; offset < SCAN_THREADS; offset *= 2u) {
        workgroupBarrier();
        var earlier_a = 1.0;
        var earlier_b = 0.0;
        if (r >= offset) {
            earlier_a = scan_a[r - offset];
            earlier_b = scan_b[r - offset];
        }
        workgroupBarrier();
        // This map applied after the earlier ones.
        b = a * earlier_b + b;
        a = a * earlier_a;
        scan_a[r] = a;
        scan_b[r] = b;
    }
    workgroupBarrier();
}

// The value entering position r of the last scan: the composed maps of positions < r applied
// to 0 (the boundary value), i.e. their b.
fn scan_incoming(r: u32) -> f32 {
    if (r == 0u) {
        return 0.0;
    }
    return scan_b[r - 1u];
}

@compute @workgroup_size(256, 1, 1)
fn pressure_scan(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) l: vec3<u32>) {
    let k = wg.x;
    let e = wg.y;
    let t = l.x;
    if (k >= P.ny || e >= P.n_env) {
        return; // uniform: the whole workgroup leaves
    }
    let base = (e * P.ny + k) * P.nx;
    let c_base = P.ny * P.ny + k * P.nx;
    let m_base = P.ny * P.ny + P.ny * P.nx + k * P.nx;
    let dx2 = P.dx * P.dx;
    let chunk = (P.nx + SCAN_THREADS - 1u) / SCAN_THREADS;
    let lo = min(t * chunk, P.nx);
    let hi = min(lo + chunk, P.nx);

    // Forward sweep. The chunk's map: y[hi-1] as a function of y[lo-1].
    var a = 1.0;
    var b = 0.0;
    for (var i = lo; i < hi; i++) {
        let inv_m = poisson[m_base + i];
        b = -inv_m * b + phat[base + i] * dx2 * inv_m;
        a = -inv_m * a;
    }
    scan_maps(t, a, b);
    var y = scan_incoming(t);
    for (var i = lo; i < hi; i++) {
        y = (phat[base + i] * dx2 - y) * poisson[m_base + i];
        phat[base + i] = y;
    }

    // Backward sweep, threads in reverse order. The chunk's map: x[lo] as a function of x[hi].
    let r = SCAN_THREADS - 1u - t;
    a = 1.0;
    b = 0.0;
    for (var n = hi; n > lo; n--) {
        let c = -poisson[c_base + n - 1u];
        b = c * b + phat[base + n - 1u];
        a = c * a;
    }
    scan_maps(r, a, b);
    var x = scan_incoming(r);
    for (var n = hi; n > lo; n--) {
        x = phat[base + n - 1u] - poisson[c_base + n - 1u] * x;
        phat[base + n - 1u] = x;
    }
}
