//! PNG figures drawn with plotters into an RGB buffer and written with `image`, in DejaVu Sans
//! embedded in the binary (`assets/fonts/`), so they render headless with no system fonts.
//! A figure is a stack of panels sharing an x axis; each panel holds curves with optional
//! bands, horizontal reference bands, and optionally a waveform on a secondary y axis.

use std::path::Path;
use std::sync::OnceLock;

use super::error::{ReportError, Result};
use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use plotters::element::ComposedElement;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::stats::Band;

const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Figure width and the height of one panel (px).
pub const WIDTH: u32 = 1000;
/// Height of one panel (px).
pub const PANEL_HEIGHT: u32 = 380;

/// Colour: blue (matplotlib's tab:blue).
pub const BLUE: RGBColor = RGBColor(31, 119, 180);
/// Colour: orange (matplotlib's tab:orange).
pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// Colour: green (matplotlib's tab:green).
pub const GREEN: RGBColor = RGBColor(44, 160, 44);
/// Colour: purple (matplotlib's tab:purple).
pub const PURPLE: RGBColor = RGBColor(148, 103, 189);
/// Colour: brown (matplotlib's tab:brown).
pub const BROWN: RGBColor = RGBColor(140, 86, 75);
/// Colour: mid grey.
pub const GREY: RGBColor = RGBColor(120, 120, 120);
/// Colour: red (matplotlib's tab:red).
pub const RED: RGBColor = RGBColor(214, 39, 40);

/// A curve, with a shaded band when it has one.
pub struct Curve {
    /// Legend label.
    pub label: String,
    /// Line colour; the band is drawn in it, translucent.
    pub color: RGBColor,
    /// Draw the line dashed.
    pub dashed: bool,
    /// The points (x, mean) and the band lo..hi around them.
    pub band: Band,
}

impl Curve {
    /// A line without a band.
    pub fn line(label: impl Into<String>, color: RGBColor, points: &[(f64, f64)]) -> Self {
        let (x, y): (Vec<f64>, Vec<f64>) = points.iter().copied().unzip();
        Self {
            label: label.into(),
            color,
            dashed: false,
            band: Band {
                x,
                lo: y.clone(),
                hi: y.clone(),
                mean: y,
            },
        }
    }
}

/// A horizontal reference: a value with a band lo..hi across the whole x range.
pub struct Reference {
    /// Legend label.
    pub label: String,
    /// Colour of the line and its band.
    pub color: RGBColor,
    /// The reference value.
    pub mean: f64,
    /// Lower edge of the band.
    pub lo: f64,
    /// Upper edge of the band.
    pub hi: f64,
}

/// A secondary-axis line (the inlet waveform).
pub struct Secondary {
    /// Legend label.
    pub label: String,
    /// Description of the secondary y axis.
    pub y_desc: String,
    /// The points (x, y) on the secondary axis.
    pub points: Vec<(f64, f64)>,
}

/// One panel of a figure: its curves, references and optional secondary axis.
pub struct Panel {
    /// Panel title.
    pub title: String,
    /// Description of the x axis.
    pub x_desc: String,
    /// Description of the y axis.
    pub y_desc: String,
    /// The curves.
    pub curves: Vec<Curve>,
    /// The horizontal reference bands.
    pub references: Vec<Reference>,
    /// An optional line on a secondary y axis.
    pub secondary: Option<Secondary>,
    /// Draw the legend (a stack of panels showing the same series needs it once).
    pub legend: bool,
}

fn register_font() -> Result<()> {
    static OK: OnceLock<bool> = OnceLock::new();
    let ok = *OK.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok()
    });
    ok.then_some(()).ok_or_else(|| {
        ReportError::Invalid("the embedded font (assets/fonts/DejaVuSans.ttf) did not load".into())
    })
}

/// Padded (min, max) of finite values; a unit range around a single value.
fn range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    if span <= 1e-12 * hi.abs().max(1.0) {
        let h = 0.5 * hi.abs().max(1e-3);
        return (lo - h, hi + h);
    }
    (lo - pad * span, hi + pad * span)
}

type Segment = PathElement<(i32, i32)>;
type LegendLine<DB> = ComposedElement<(i32, i32), DB, Segment, Segment>;

/// A legend sample 24 px long, solid or dashed like its series.
fn legend_line<DB: DrawingBackend>(
    at: (i32, i32),
    dashed: bool,
    style: ShapeStyle,
) -> LegendLine<DB> {
    let gap = if dashed { 6 } else { 0 };
    EmptyElement::at(at)
        + PathElement::new(vec![(0, 0), (9, 0)], style)
        + PathElement::new(vec![(9 + gap, 0), (24, 0)], style)
}

/// Decimals that tell apart ticks about a tenth of `span` apart.
fn decimals(span: f64) -> usize {
    let step = span.abs() / 10.0;
    if step >= 1.0 || step <= 0.0 || !step.is_finite() {
        0
    } else {
        (-step.log10().floor()) as usize
    }
}

/// A tick label with `d` decimals, never "-0".
fn tick(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Draws the panels stacked into `path` (WIDTH x panels * PANEL_HEIGHT px).
pub fn save(path: &Path, panels: &[Panel]) -> Result<()> {
    let (w, h) = (WIDTH, PANEL_HEIGHT * panels.len().max(1) as u32);
    save_rgb(path, (w, h), |buf| draw(buf, (w, h), panels))
}

/// Draws a `size` RGB figure with `draw` (the embedded font registered) and writes it as a PNG.
pub fn save_rgb(
    path: &Path,
    (w, h): (u32, u32),
    draw: impl FnOnce(&mut [u8]) -> Result<(), Box<dyn std::error::Error>>,
) -> Result<()> {
    register_font()?;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    draw(&mut buf).map_err(|e| ReportError::Draw {
        path: path.to_path_buf(),
        why: e.to_string(),
    })?;
    // Best compression: figures are committed and shown in READMEs.
    let file = std::fs::File::create(path).map_err(|cause| ReportError::Write {
        path: path.to_path_buf(),
        cause,
        hint: ": is the --out directory writable?".into(),
    })?;
    let encoder = PngEncoder::new_with_quality(
        std::io::BufWriter::new(file),
        CompressionType::Best,
        FilterType::Adaptive,
    );
    encoder
        .write_image(&buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| ReportError::Draw {
            path: path.to_path_buf(),
            why: format!("encoding the PNG: {e}"),
        })
}

fn draw(
    buf: &mut [u8],
    size: (u32, u32),
    panels: &[Panel],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (panel, area) in panels.iter().zip(&areas) {
        draw_panel(area, panel)?;
    }
    root.present()?;
    Ok(())
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    p: &Panel,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let xs = p.curves.iter().flat_map(|c| c.band.x.iter().copied());
    let xs = xs.chain(
        p.secondary
            .iter()
            .flat_map(|s| s.points.iter().map(|q| q.0)),
    );
    let (x0, x1) = range(xs, 0.0);
    let ys = p
        .curves
        .iter()
        .flat_map(|c| c.band.lo.iter().chain(&c.band.hi).copied())
        .chain(p.references.iter().flat_map(|r| [r.lo, r.hi]));
    let (y0, y1) = range(ys, 0.06);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&p.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78);
    if p.secondary.is_some() {
        builder.right_y_label_area_size(78);
    } else {
        // Room for the last x tick label.
        builder.margin_right(36);
    }
    let (s0, s1) = range(
        p.secondary
            .iter()
            .flat_map(|s| s.points.iter().map(|q| q.1)),
        0.06,
    );
    let mut chart = builder
        .build_cartesian_2d(x0..x1, y0..y1)?
        .set_secondary_coord(x0..x1, s0..s1);
    let (xd, yd) = (decimals(x1 - x0), decimals(y1 - y0));
    let x_fmt = move |v: &f64| tick(*v, xd);
    let y_fmt = move |v: &f64| tick(*v, yd);
    chart
        .configure_mesh()
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .x_desc(p.x_desc.as_str())
        .y_desc(p.y_desc.as_str())
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()?;
    for r in &p.references {
        let c = r.color;
        if r.hi > r.lo {
            chart.draw_series(std::iter::once(Polygon::new(
                vec![(x0, r.lo), (x1, r.lo), (x1, r.hi), (x0, r.hi)],
                c.mix(0.15).filled(),
            )))?;
        }
        chart
            .draw_series(DashedLineSeries::new(
                [(x0, r.mean), (x1, r.mean)],
                10,
                6,
                c.stroke_width(2),
            ))?
            .label(r.label.as_str())
            .legend(move |at| legend_line(at, true, c.stroke_width(2)));
    }
    for curve in &p.curves {
        let b = &curve.band;
        let c = curve.color;
        if b.lo.iter().zip(&b.hi).any(|(l, h)| h > l) {
            let mut poly: Vec<(f64, f64)> = b.x.iter().copied().zip(b.hi.iter().copied()).collect();
            poly.extend(b.x.iter().copied().zip(b.lo.iter().copied()).rev());
            chart.draw_series(std::iter::once(Polygon::new(poly, c.mix(0.2).filled())))?;
        }
        let pts: Vec<(f64, f64)> = b.x.iter().copied().zip(b.mean.iter().copied()).collect();
        let style = c.stroke_width(2);
        let dashed = curve.dashed;
        let anno = if dashed {
            chart.draw_series(DashedLineSeries::new(pts, 8, 5, style))?
        } else {
            chart.draw_series(LineSeries::new(pts, style))?
        };
        anno.label(curve.label.as_str())
            .legend(move |at| legend_line(at, dashed, style));
    }
    if let Some(s) = &p.secondary {
        let sd = decimals(s1 - s0);
        let s_fmt = move |v: &f64| tick(*v, sd);
        chart
            .configure_secondary_axes()
            .y_label_formatter(&s_fmt)
            .y_desc(s.y_desc.as_str())
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()?;
        let style = GREY.mix(0.7).stroke_width(1);
        chart
            .draw_secondary_series(LineSeries::new(s.points.iter().copied(), style))?
            .label(s.label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
    }
    if !p.legend {
        return Ok(());
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    Ok(())
}
