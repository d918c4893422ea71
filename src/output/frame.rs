//! Frame of u_x over the analysis region: a perceptual colour map (viridis) of the
//! cell-centred field with a labelled colour bar in mm/s, the time and inlet velocity printed
//! on the image, x ticks in mm, and the height exaggerated so the profile is visible.
//! Colours follow a signed square root of the velocity, s(u) = sign(u) sqrt(|u| / u_ref), over
//! a fixed range, so that the 400 mm/s systole and the 10 mm/s diastole are both readable and
//! frames of one run compare; the colour bar's ticks carry the velocities themselves.

use std::path::Path;

use image::{Rgb, RgbImage};

use super::text::{draw_text, text_width};

const BLACK: Rgb<u8> = Rgb([0, 0, 0]);
const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
const GREY: Rgb<u8> = Rgb([90, 90, 90]);
const RED: Rgb<u8> = Rgb([230, 40, 40]);

/// A member drawn on a frame: its centre (m) and applied force as a fraction of F_max.
#[derive(Debug, Clone, Copy)]
pub struct MemberMark {
    /// Centre x (m).
    pub x_m: f64,
    /// Centre y (m).
    pub y_m: f64,
    /// Applied force x as a fraction of F_max.
    pub force_x: f64,
    /// Applied force y as a fraction of F_max.
    pub force_y: f64,
}

impl MemberMark {
    /// A member at `pos` (m) with applied force `force` (N), for a thrust bound `f_max` (N).
    pub fn new(pos: [f32; 2], force: [f32; 2], f_max: f64) -> Self {
        Self {
            x_m: pos[0] as f64,
            y_m: pos[1] as f64,
            force_x: force[0] as f64 / f_max,
            force_y: force[1] as f64 / f_max,
        }
    }
}

/// The fixed colour range (m/s) of a run's frames: the inlet waveform's extremes with headroom
/// (1.2 x the peak forward velocity, 1.5 x the strongest reversal, at least 1 % of the peak).
pub fn velocity_range(points: &[(f64, f64)]) -> (f64, f64) {
    let hi = points.iter().map(|p| p.1).fold(0.0, f64::max);
    let lo = points.iter().map(|p| p.1).fold(0.0, f64::min);
    (1.5 * lo.min(-0.01 * hi), 1.2 * hi.max(1e-6))
}

/// What a frame shows.
pub struct FrameSpec<'a> {
    /// u_x at cell centres, `[ny][nx]` (m/s).
    pub ux: &'a [f32],
    /// Cells in x.
    pub nx: usize,
    /// Cells in y.
    pub ny: usize,
    /// Channel length (m).
    pub length_m: f64,
    /// Channel height (m).
    pub height_m: f64,
    /// Shown x range (m).
    pub x_min_m: f64,
    /// Upper end of the shown x range (m).
    pub x_max_m: f64,
    /// Colour range (m/s).
    pub v_min: f64,
    /// Upper end of the colour range (m/s).
    pub v_max: f64,
    /// Simulated time printed on the frame (s).
    pub time_s: f64,
    /// Inlet centreline velocity printed on the frame (m/s).
    pub inlet_u_m_s: f64,
    /// Environment index printed on the frame.
    pub env: usize,
    /// Members (circles to scale, so ellipses under the y exaggeration), their centre of mass
    /// (a black dot) and their forces (arrows, 30 px at F_max).
    pub members: &'a [MemberMark],
    /// Member radius (m).
    pub radius_m: f64,
}

/// Field area width in pixels (at least one pixel per cell column).
const FIELD_WIDTH: u32 = 900;
const LEFT: u32 = 56;
const TOP: u32 = 34;
const BOTTOM: u32 = 44;
const RIGHT: u32 = 130;

/// Renders the frame.
pub fn render(spec: &FrameSpec) -> RgbImage {
    let dx = spec.length_m / spec.nx as f64;
    let i0 = ((spec.x_min_m / dx).floor().max(0.0) as usize).min(spec.nx - 1);
    let i1 = ((spec.x_max_m / dx).ceil() as usize).clamp(i0 + 1, spec.nx);
    let cols = i1 - i0;
    let width = FIELD_WIDTH.max(cols as u32);
    let height = (spec.ny as u32 * 10).clamp(120, 240);
    let shown_len = cols as f64 * dx;
    let exaggeration = (height as f64 / spec.height_m) / (width as f64 / shown_len);

    let mut img = RgbImage::from_pixel(LEFT + width + RIGHT, TOP + height + BOTTOM, WHITE);
    let scale = ColourScale::new(spec.v_min, spec.v_max);
    let colour = |v: f64| {
        let c = colorous::VIRIDIS.eval_continuous(scale.position(v));
        Rgb([c.r, c.g, c.b])
    };
    // Field: bilinear in the cell-centred values.
    for py in 0..height {
        let y = (height - 1 - py) as f64 + 0.5; // pixel centre, 0 at the bottom
        let fy = (y / height as f64 * spec.ny as f64 - 0.5).clamp(0.0, (spec.ny - 1) as f64);
        let j0 = (fy.floor() as usize).min(spec.ny.saturating_sub(2));
        let ty = fy - j0 as f64;
        let j1 = (j0 + 1).min(spec.ny - 1);
        for px in 0..width {
            let x = (px as f64 + 0.5) / width as f64 * cols as f64 + i0 as f64 - 0.5;
            let fx = x.clamp(0.0, (spec.nx - 1) as f64);
            let a = (fx.floor() as usize).min(spec.nx.saturating_sub(2));
            let tx = fx - a as f64;
            let b = (a + 1).min(spec.nx - 1);
            let at = |i: usize, j: usize| spec.ux[j * spec.nx + i] as f64;
            let lo = at(a, j0) * (1.0 - tx) + at(b, j0) * tx;
            let hi = at(a, j1) * (1.0 - tx) + at(b, j1) * tx;
            img.put_pixel(LEFT + px, TOP + py, colour(lo * (1.0 - ty) + hi * ty));
        }
    }
    // Members, their centre of mass and their forces.
    let to_px = |x: f64, y: f64| {
        let px = LEFT as f64 + (x / dx - i0 as f64) / cols as f64 * width as f64;
        let py = TOP as f64 + (1.0 - y / spec.height_m) * height as f64;
        (px, py)
    };
    let (rx, ry) = (
        spec.radius_m / dx / cols as f64 * width as f64,
        spec.radius_m / spec.height_m * height as f64,
    );
    let clip = |img: &mut RgbImage, x: f64, y: f64, c: Rgb<u8>| {
        let (xi, yi) = (x.round() as i64, y.round() as i64);
        if xi >= LEFT as i64
            && xi < (LEFT + width) as i64
            && yi >= TOP as i64
            && yi < (TOP + height) as i64
        {
            img.put_pixel(xi as u32, yi as u32, c);
        }
    };
    for m in spec.members {
        let (cx, cy) = to_px(m.x_m, m.y_m);
        for k in 0..360 {
            let t = k as f64 * std::f64::consts::PI / 180.0;
            clip(&mut img, cx + rx * t.cos(), cy + ry * t.sin(), WHITE);
            clip(
                &mut img,
                cx + (rx + 1.0) * t.cos(),
                cy + (ry + 1.0) * t.sin(),
                BLACK,
            );
        }
        let (fx, fy) = (m.force_x * 30.0, -m.force_y * 30.0);
        let len = fx.hypot(fy);
        if len > 0.5 {
            let steps = (len * 2.0) as usize + 1;
            for s in 0..=steps {
                let t = s as f64 / steps as f64;
                clip(&mut img, cx + fx * t, cy + fy * t, RED);
            }
            let (ux, uy) = (fx / len, fy / len);
            for s in 0..=8 {
                let t = s as f64 * 0.6;
                for side in [-1.0, 1.0] {
                    let (hx, hy) = (-ux * 0.8 + side * -uy * 0.6, -uy * 0.8 + side * ux * 0.6);
                    clip(&mut img, cx + fx + hx * t, cy + fy + hy * t, RED);
                }
            }
        }
    }
    if !spec.members.is_empty() {
        let n = spec.members.len() as f64;
        let (mx, my) = spec
            .members
            .iter()
            .fold((0.0, 0.0), |a, m| (a.0 + m.x_m / n, a.1 + m.y_m / n));
        let (cx, cy) = to_px(mx, my);
        for ddx in -2..=2 {
            for ddy in -2..=2 {
                if ddx * ddx + ddy * ddy <= 5 {
                    clip(&mut img, cx + ddx as f64, cy + ddy as f64, BLACK);
                }
            }
        }
    }
    // Frame, x ticks every 10 mm (5 mm for short spans), y labels.
    rect(&mut img, LEFT - 1, TOP - 1, width + 2, height + 2, BLACK);
    let x_lo = i0 as f64 * dx * 1e3;
    let x_hi = i1 as f64 * dx * 1e3;
    let step = nice_step(x_hi - x_lo, 8);
    let mut tick = (x_lo / step).ceil() * step;
    while tick <= x_hi + 1e-9 {
        let px = LEFT as f64 + (tick - x_lo) / (x_hi - x_lo) * width as f64;
        let px = (px.round() as u32).min(LEFT + width - 1);
        vline(&mut img, px, TOP + height, 5, BLACK);
        let label = format_tick(tick, step);
        draw_text(
            &mut img,
            px as i64 - text_width(&label, 1) as i64 / 2,
            (TOP + height + 8) as i64,
            &label,
            1,
            BLACK,
        );
        tick += step;
    }
    let xlabel = format!("x (mm)    y exaggerated {exaggeration:.0}x");
    draw_text(
        &mut img,
        (LEFT + width / 2) as i64 - text_width(&xlabel, 1) as i64 / 2,
        (TOP + height + 24) as i64,
        &xlabel,
        1,
        BLACK,
    );
    let h_mm = format!("{:.1}", spec.height_m * 1e3);
    draw_text(
        &mut img,
        (LEFT - 8 - text_width(&h_mm, 1)) as i64,
        TOP as i64,
        &h_mm,
        1,
        BLACK,
    );
    draw_text(
        &mut img,
        (LEFT - 16) as i64,
        (TOP + height - 8) as i64,
        "0",
        1,
        BLACK,
    );
    draw_text(
        &mut img,
        4,
        (TOP + height / 2 - 4) as i64,
        "y(mm)",
        1,
        BLACK,
    );
    // Title: time, inlet velocity.
    let title = format!(
        "u_x  env {}   t = {:.3} s   inlet U = {:.1} mm/s",
        spec.env,
        spec.time_s,
        spec.inlet_u_m_s * 1e3
    );
    draw_text(&mut img, LEFT as i64, 8, &title, 2, BLACK);
    // Colour bar with ticks in mm/s.
    let bar_x = LEFT + width + 16;
    let bar_w = 18;
    for py in 0..height {
        let t = 1.0 - (py as f64 + 0.5) / height as f64;
        let c = colorous::VIRIDIS.eval_continuous(t);
        for px in 0..bar_w {
            img.put_pixel(bar_x + px, TOP + py, Rgb([c.r, c.g, c.b]));
        }
    }
    rect(&mut img, bar_x - 1, TOP - 1, bar_w + 2, height + 2, BLACK);
    let mut placed: Vec<u32> = Vec::new();
    for tick_mm_s in scale.ticks_mm_s() {
        let t = scale.position(tick_mm_s as f64 * 1e-3);
        let py = TOP as f64 + (1.0 - t) * height as f64;
        let py = (py.round() as u32).clamp(TOP, TOP + height - 1);
        if placed.iter().any(|&q| q.abs_diff(py) < 11) {
            continue;
        }
        placed.push(py);
        hline(&mut img, bar_x + bar_w, py, 4, BLACK);
        let label = tick_mm_s.to_string();
        draw_text(
            &mut img,
            (bar_x + bar_w + 6) as i64,
            py as i64 - 4,
            &label,
            1,
            BLACK,
        );
    }
    let (lx, ly) = (bar_x as i64 - 10, (TOP + height) as i64);
    draw_text(&mut img, lx, ly + 12, "u_x (mm/s)", 1, GREY);
    draw_text(&mut img, lx, ly + 24, "sqrt scale", 1, GREY);
    img
}

/// Signed square-root colour scale over [v_min, v_max] (m/s).
pub struct ColourScale {
    lo: f64,
    hi: f64,
    reference: f64,
}

impl ColourScale {
    /// The scale over [v_min, v_max] (m/s), referenced to the larger magnitude of the two.
    pub fn new(v_min: f64, v_max: f64) -> Self {
        let reference = v_min.abs().max(v_max.abs()).max(1e-12);
        let s = |v: f64| v.signum() * (v.abs() / reference).sqrt();
        Self {
            lo: s(v_min),
            hi: s(v_max).max(s(v_min) + 1e-12),
            reference,
        }
    }

    /// Position in [0, 1] of velocity v (m/s) on the colour map.
    pub fn position(&self, v: f64) -> f64 {
        let s = v.signum() * (v.abs() / self.reference).sqrt();
        ((s - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
    }

    /// Tick values (mm/s) inside the range: 0 and 1..5 x 10^k of both signs.
    pub fn ticks_mm_s(&self) -> Vec<i64> {
        let lo = -(self.lo.min(0.0).powi(2)) * self.reference * 1e3;
        let hi = self.hi.max(0.0).powi(2) * self.reference * 1e3;
        let mut ticks = vec![0i64];
        for mag in [1i64, 10, 100, 1000, 10000] {
            for m in [1, 2, 3, 4, 5] {
                let v = m * mag;
                if (v as f64) <= hi + 1e-9 {
                    ticks.push(v);
                }
                if (-v as f64) >= lo - 1e-9 {
                    ticks.push(-v);
                }
            }
        }
        // Largest magnitudes first so they win the spacing check.
        ticks.sort_by_key(|v| std::cmp::Reverse(v.abs()));
        ticks
    }
}

/// Renders and writes a PNG.
pub fn write(path: &Path, spec: &FrameSpec) -> image::ImageResult<()> {
    render(spec).save(path)
}

/// A 1, 2 or 5 x 10^k step giving about `count` ticks over `span`.
pub fn nice_step(span: f64, count: u32) -> f64 {
    let raw = (span.abs() / count.max(1) as f64).max(1e-12);
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let m = if norm <= 1.0 {
        1.0
    } else if norm <= 2.0 {
        2.0
    } else if norm <= 5.0 {
        5.0
    } else {
        10.0
    };
    m * mag
}

fn format_tick(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let v = if v.abs() < step * 1e-6 { 0.0 } else { v };
    format!("{v:.decimals$}")
}

fn hline(img: &mut RgbImage, x: u32, y: u32, len: u32, c: Rgb<u8>) {
    for px in x..(x + len).min(img.width()) {
        img.put_pixel(px, y, c);
    }
}

fn vline(img: &mut RgbImage, x: u32, y: u32, len: u32, c: Rgb<u8>) {
    for py in y..(y + len).min(img.height()) {
        img.put_pixel(x, py, c);
    }
}

fn rect(img: &mut RgbImage, x: u32, y: u32, w: u32, h: u32, c: Rgb<u8>) {
    hline(img, x, y, w, c);
    hline(img, x, y + h - 1, w, c);
    vline(img, x, y, h, c);
    vline(img, x + w - 1, y, h, c);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_scale_is_monotone_and_signed_sqrt() {
        let s = ColourScale::new(-0.0225, 0.48);
        assert_eq!(s.position(-0.0225), 0.0);
        assert_eq!(s.position(0.48), 1.0);
        let z = s.position(0.0);
        // sqrt scale: 0 sits at sqrt(0.0225/0.48) / (1 + sqrt(0.0225/0.48)) of the bar.
        let r = (0.0225f64 / 0.48).sqrt();
        assert!((z - r / (1.0 + r)).abs() < 1e-12);
        assert!((s.position(0.12) - z - 0.5 * (1.0 - z)).abs() < 1e-12);
        let mut prev = -1.0;
        for k in 0..100 {
            let p = s.position(-0.0225 + k as f64 * 0.005);
            assert!(p >= prev);
            prev = p;
        }
        let t = s.ticks_mm_s();
        assert!(
            t.contains(&400) && t.contains(&-20) && t.contains(&0) && !t.contains(&500),
            "{t:?}"
        );
    }

    #[test]
    fn nice_steps() {
        assert_eq!(nice_step(60.0, 8), 10.0);
        assert_eq!(nice_step(480.0, 6), 100.0);
        assert!((nice_step(0.9, 6) - 0.2).abs() < 1e-12);
    }

    #[test]
    fn renders_expected_size_and_colours() {
        let (nx, ny) = (100, 20);
        let ux: Vec<f32> = (0..nx * ny).map(|k| (k / nx) as f32 * 0.01).collect();
        let img = render(&FrameSpec {
            ux: &ux,
            nx,
            ny,
            length_m: 0.1,
            height_m: 0.002,
            x_min_m: 0.02,
            x_max_m: 0.08,
            v_min: 0.0,
            v_max: 0.2,
            time_s: 0.1,
            inlet_u_m_s: 0.4,
            env: 0,
            members: &[MemberMark {
                x_m: 0.05,
                y_m: 0.001,
                force_x: -1.0,
                force_y: 0.0,
            }],
            radius_m: 250e-6,
        });
        // The member's outline is drawn at its radius, to scale in x.
        let cx = LEFT as f64 + (0.05 / 1e-3 - 20.0) / 60.0 * FIELD_WIDTH as f64;
        let rx = 0.25 / 60.0 * FIELD_WIDTH as f64;
        let edge = img.get_pixel((cx + rx).round() as u32, TOP + 100);
        assert!(
            edge == &WHITE || edge == &BLACK,
            "outline at the radius: {edge:?}"
        );
        assert_eq!(img.width(), LEFT + FIELD_WIDTH + RIGHT);
        // Bottom row of the field is dark (low), top row bright (high) in viridis.
        let low = img.get_pixel(LEFT + 10, TOP + img.height() - TOP - BOTTOM - 1);
        let high = img.get_pixel(LEFT + 10, TOP);
        let lum = |p: &Rgb<u8>| p.0.iter().map(|&c| c as u32).sum::<u32>();
        assert!(lum(high) > lum(low) + 200);
    }
}
