//! What one WGSL compute invocation costs on the adapter: a few toy kernels over a grid of
//! the paper's size at E = 16 (1000 x 20 x 16 = 320,000 cells), each dispatched 40 times in
//! one compute pass, median of five submissions.
//!
//! Every kernel reads `a`, `b` (f32) or `av` (vec4) and writes `o`, `o2` or `ov`; cell
//! c = (e ny + j) nx + i. The cases separate the cost of an invocation, a load, a store, a
//! data-dependent gather, a loop, a divergent branch and an array in workgroup or private
//! memory (docs/performance.md, "What lavapipe charges for").
//!
//! `cargo run --release --example lavapipe_costs [-- NAME_FILTER...]`
use std::time::Instant;

use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};
use wgpu::util::DeviceExt;

const NX: u32 = 1000;
const NY: u32 = 20;
const NE: u32 = 16;
const CELLS: u32 = NX * NY * NE;
const REPS: u32 = 40;

/// One toy kernel: its body, workgroup size, workgroup count and the cells it covers.
struct Case {
    name: &'static str,
    body: String,
    workgroup: [u32; 3],
    groups: [u32; 3],
}

/// Thread (i, j, e) of a 3D dispatch with cell index `c`.
const CELL: &str = "let i = g.x; let j = g.y; let e = g.z; if (i >= NX) { return; } \
                    let c = (e * NY + j) * NX + i;";

fn grid_case(name: &'static str, body: &str) -> Case {
    Case {
        name,
        body: format!("{CELL} {body}"),
        workgroup: [64, 1, 1],
        groups: [NX.div_ceil(64), NY, NE],
    }
}

/// Thread (i, e) of a 2D dispatch that owns a whole column of ny cells.
fn column_case(name: &'static str, body: &str) -> Case {
    Case {
        name,
        body: format!("let i = g.x; let e = g.y; if (i >= NX) {{ return; }} {body}"),
        workgroup: [64, 1, 1],
        groups: [NX.div_ceil(64), NE, 1],
    }
}

fn cases() -> Vec<Case> {
    let stencil = "let l = select(c, c - 1u, i > 0u); let r = select(c, c + 1u, i + 1u < NX); \
                   let d = select(c, c - NX, j > 0u); let u = select(c, c + NX, j + 1u < NY);";
    let sixteen_gathers: String = (0..16)
        .map(|k| format!("s += a[(c + {}u) % CELLS];", k * 977))
        .collect();
    vec![
        grid_case("empty (bounds check only)", ""),
        grid_case("copy: 1 load, 1 store", "o[c] = a[c];"),
        Case {
            workgroup: [256, 1, 1],
            groups: [NX.div_ceil(256), NY, NE],
            ..grid_case("copy, workgroup 256", "o[c] = a[c];")
        },
        grid_case(
            "1 load, 2 stores",
            "let x = a[c]; o[c] = x; o2[c] = 2.0 * x;",
        ),
        grid_case(
            "5-point stencil: 5 loads, 1 store",
            &format!("{stencil} o[c] = a[c] + a[l] + a[r] + a[d] + a[u];"),
        ),
        grid_case(
            "two 5-point stencils, 2 stores",
            &format!(
                "{stencil} o[c] = a[c] + a[l] + a[r] + a[d] + a[u]; \
                 o2[c] = b[c] + b[l] + b[r] + b[d] + b[u];"
            ),
        ),
        grid_case(
            "data-dependent gather",
            "let k = u32(a[c] * 100.0) % CELLS; o[c] = b[k];",
        ),
        grid_case(
            "16 gathers",
            &format!("var s = 0.0; {sixteen_gathers} o[c] = s;"),
        ),
        grid_case(
            "16 gathers, only where i < 2",
            &format!(
                "if (i < 2u) {{ var s = 0.0; {sixteen_gathers} o[c] = s; }} else {{ o[c] = a[c]; }}"
            ),
        ),
        grid_case("vec4 copy, one per cell", "ov[c] = av[c];"),
        Case {
            groups: [(NX / 4).div_ceil(64), NY, NE],
            ..grid_case(
                "vec4 copy, 4 cells per thread",
                "if (i >= NX / 4u) { return; } let q = (e * NY + j) * (NX / 4u) + i; ov[q] = av[q];",
            )
        },
        column_case(
            "copy, a column of 20 per thread",
            "for (var j = 0u; j < NY; j++) { let c = (e * NY + j) * NX + i; o[c] = a[c]; }",
        ),
        grid_case(
            "40 dependent FMAs, loop",
            "var x = a[c]; for (var k = 0u; k < 40u; k++) { x = x * 0.999 + 0.001; } o[c] = x;",
        ),
        grid_case(
            "40 dependent FMAs, unrolled",
            &format!(
                "var x = a[c]; {} o[c] = x;",
                "x = x * 0.999 + 0.001; ".repeat(40)
            ),
        ),
        column_case(
            "20 x 20 column transform, private array",
            "var col: array<f32, 20>; \
             for (var j = 0u; j < NY; j++) { col[j] = a[(e * NY + j) * NX + i]; } \
             for (var j = 0u; j < NY; j++) { var s = 0.0; \
               for (var k = 0u; k < NY; k++) { s += col[k] * f32(j + k); } \
               o[(e * NY + j) * NX + i] = s; }",
        ),
        column_case(
            "20 x 20 column transform, workgroup array",
            "for (var j = 0u; j < NY; j++) { scratch[j * 64u + lid.x] = a[(e * NY + j) * NX + i]; } \
             for (var j = 0u; j < NY; j++) { var s = 0.0; \
               for (var k = 0u; k < NY; k++) { s += scratch[k * 64u + lid.x] * f32(j + k); } \
               o[(e * NY + j) * NX + i] = s; }",
        ),
    ]
}

fn shader(case: &Case) -> String {
    let [x, y, z] = case.workgroup;
    format!(
        "@group(0) @binding(0) var<storage, read_write> a: array<f32>;
@group(0) @binding(1) var<storage, read_write> b: array<f32>;
@group(0) @binding(2) var<storage, read_write> o: array<f32>;
@group(0) @binding(3) var<storage, read_write> o2: array<f32>;
@group(0) @binding(4) var<storage, read_write> av: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> ov: array<vec4<f32>>;
const NX: u32 = {NX}u;
const NY: u32 = {NY}u;
const CELLS: u32 = {CELLS}u;
var<workgroup> scratch: array<f32, 4096>;
@compute @workgroup_size({x}, {y}, {z})
fn main(@builtin(global_invocation_id) g: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {{
    // Every binding is used, so the derived layout matches the bind group.
    _ = &a; _ = &b; _ = &o; _ = &o2; _ = &av; _ = &ov;
    {}
}}",
        case.body
    )
}

/// Median seconds of one dispatch of `case` (REPS dispatches per submission, five submissions).
fn time(ctx: &GpuContext, case: &Case, buffers: &[wgpu::Buffer]) -> f64 {
    let module = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(case.name),
            source: wgpu::ShaderSource::Wgsl(shader(case).into()),
        });
    let pipeline = ctx
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(case.name),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupEntry {
            binding: k as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let mut seconds: Vec<f64> = (0..5)
        .map(|_| {
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind, &[]);
                for _ in 0..REPS {
                    let [x, y, z] = case.groups;
                    pass.dispatch_workgroups(x, y, z);
                }
            }
            let start = Instant::now();
            ctx.queue.submit([encoder.finish()]);
            ctx.wait().expect("adapter finishes");
            start.elapsed().as_secs_f64() / REPS as f64
        })
        .collect();
    seconds.sort_by(f64::total_cmp);
    seconds[2]
}

fn main() -> anyhow::Result<()> {
    let ctx = GpuContext::new(AdapterChoice::Auto)?;
    println!("{}", ctx.banner());
    let filters: Vec<String> = std::env::args().skip(1).collect();
    // Four floats per cell so that the vec4 arrays cover the grid too.
    let values: Vec<f32> = (0..4 * CELLS).map(|k| (k % 97) as f32 * 0.01).collect();
    let buffers: Vec<wgpu::Buffer> = (0..6)
        .map(|_| {
            ctx.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: None,
                    contents: bytemuck::cast_slice(&values),
                    usage: wgpu::BufferUsages::STORAGE,
                })
        })
        .collect();
    println!(
        "{:44} {:>12} {:>14}",
        "kernel (320,000 cells)", "ms/dispatch", "ns per cell"
    );
    for case in cases() {
        if !filters.is_empty() && !filters.iter().any(|f| case.name.contains(f.as_str())) {
            continue;
        }
        let s = time(&ctx, &case, &buffers);
        println!(
            "{:44} {:>12.3} {:>14.2}",
            case.name,
            s * 1e3,
            s * 1e9 / CELLS as f64
        );
    }
    Ok(())
}
