// Driver self-check: counts the trips of a long loop. Debian 12's Mesa 22.3 lavapipe silently
// stops every shader invocation after 65,535 loop trips in total; a correct driver counts all.
// Dispatch (1, 1, 1); out[0] = number of trips actually executed (expected: n[0]).

@group(0) @binding(0) var<storage, read_write> probe: array<u32>;

@compute @workgroup_size(1, 1, 1)
fn loop_probe() {
    let n = probe[0];
    var count = 0u;
    for (var i = 0u; i < n; i++) {
        count += 1u + (i & probe[2]);
    }
    probe[1] = count;
}
