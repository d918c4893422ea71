//! The health of one environment after a control step (SPEC section 1's checks), mirroring
//! `shaders/diagnostics.wgsl`: the volume flux per unit depth through every cross-section
//! x = i dx (min, max, and at the inlet), max |div u| per cell, max |u|, |v| on any face, the
//! number of non-finite values among u, v, p and div u, and max |div u*| before the projection.
//! Shapes: u `[ny][nx+1]`, v `[ny+1][nx]`, p `[ny][nx]`, divstar `[nx]`.

use super::stencil::Dim;
use crate::sim::EnvHealth;

#[inline(always)] // into the step's vector-path instances (`super::simd`)
pub(crate) fn diagnostics(
    d: &Dim,
    u: &[f32],
    v: &[f32],
    pres: &[f32],
    divstar: &[f32],
) -> EnvHealth {
    let (nx, ny, p) = (d.nx, d.ny, &d.p);
    let (row, finite) = (nx + 1, |x: f32| x.is_finite());
    let mut h = EnvHealth {
        flux_min: f32::MAX,
        flux_max: f32::MIN,
        ..Default::default()
    };
    for i in 0..=nx {
        let (mut flux, mut bad) = (0.0f32, 0u32);
        for j in 0..ny {
            let uc = u[j * row + i];
            flux += uc * p.dy;
            h.max_speed = h.max_speed.max(uc.abs());
            bad += !finite(uc) as u32;
            if i < nx {
                let div =
                    (u[j * row + i + 1] - uc) / p.dx + (v[(j + 1) * nx + i] - v[j * nx + i]) / p.dy;
                h.max_div = h.max_div.max(div.abs());
                let vc = v[j * nx + i];
                h.max_speed = h.max_speed.max(vc.abs());
                let pc = pres[j * nx + i];
                bad += (!finite(vc) || !finite(pc) || !finite(div)) as u32;
            }
        }
        h.flux_min = h.flux_min.min(flux);
        h.flux_max = h.flux_max.max(flux);
        h.nonfinite += bad;
        if i == 0 {
            h.inlet_flux = flux;
        }
    }
    h.div_before = divstar.iter().copied().fold(0.0, f32::max);
    h
}
