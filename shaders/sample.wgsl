// Samplers of one velocity source: src/gpu/shaders.rs instantiates this file once per source,
// replacing SRC by `in`, `diffused`, `hat` or `out` (the loads load_u_SRC / load_v_SRC are in
// common.wgsl), so that a kernel's entry point binds only the buffers it samples.

// The u value at face (i, j) of the source, with the ghosts of common.wgsl (`ghost_u`).
fn fetch_u_SRC(e: u32, i: i32, j: i32) -> f32 {
    let m = ghost_u(i, j);
    return f32(m.z) * load_u_SRC(u_idx(e, u32(m.x), u32(m.y)));
}

fn fetch_v_SRC(e: u32, i: i32, j: i32) -> f32 {
    let m = ghost_v(i, j);
    return f32(m.z) * load_v_SRC(v_idx(e, u32(m.x), u32(m.y)));
}

// Stencil of u around the point (x, y) in metres; the point is clamped into the channel.
fn stencil_u_SRC(e: u32, x: f32, y: f32) -> Stencil {
    let fx = clamp(x * P.inv_dx, 0.0, f32(P.nx));
    let fy = clamp(y * P.inv_dy, 0.0, f32(P.ny)) - 0.5;
    let i0 = min(i32(floor(fx)), i32(P.nx) - 1);
    let j0 = i32(floor(fy));
    var st: Stencil;
    if (j0 >= 0 && j0 + 1 < i32(P.ny)) {
        // Interior (i0 + 1 <= nx always): no ghost mapping needed.
        let k = u_idx(e, u32(i0), u32(j0));
        let row = P.nx + 1u;
        st.vals = vec4<f32>(
            load_u_SRC(k),
            load_u_SRC(k + 1u),
            load_u_SRC(k + row),
            load_u_SRC(k + row + 1u),
        );
    } else {
        st.vals = vec4<f32>(
            fetch_u_SRC(e, i0, j0),
            fetch_u_SRC(e, i0 + 1, j0),
            fetch_u_SRC(e, i0, j0 + 1),
            fetch_u_SRC(e, i0 + 1, j0 + 1),
        );
    }
    st.t = vec2<f32>(fx - f32(i0), fy - f32(j0));
    return st;
}

// Stencil of v around the point (x, y) in metres; the point is clamped into the channel.
fn stencil_v_SRC(e: u32, x: f32, y: f32) -> Stencil {
    let fx = clamp(x * P.inv_dx, 0.0, f32(P.nx)) - 0.5;
    let fy = clamp(y * P.inv_dy, 0.0, f32(P.ny));
    let i0 = i32(floor(fx));
    let j0 = min(i32(floor(fy)), i32(P.ny) - 1);
    var st: Stencil;
    if (i0 >= 0 && i0 + 1 < i32(P.nx)) {
        // Interior (j0 + 1 <= ny always): no ghost mapping needed.
        let k = v_idx(e, u32(i0), u32(j0));
        st.vals = vec4<f32>(
            load_v_SRC(k),
            load_v_SRC(k + 1u),
            load_v_SRC(k + P.nx),
            load_v_SRC(k + P.nx + 1u),
        );
    } else {
        st.vals = vec4<f32>(
            fetch_v_SRC(e, i0, j0),
            fetch_v_SRC(e, i0 + 1, j0),
            fetch_v_SRC(e, i0, j0 + 1),
            fetch_v_SRC(e, i0 + 1, j0 + 1),
        );
    }
    st.t = vec2<f32>(fx - f32(i0), fy - f32(j0));
    return st;
}
