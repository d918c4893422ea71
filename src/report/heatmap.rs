//! Heatmaps on categorical axes (the controllability map): a figure is a grid of panels, each
//! a nx x ny grid of coloured cells with a label in each, drawn with plotters and written as a
//! PNG like the other figures (`plot::save_rgb`).

use std::path::Path;

use plotters::coord::ranged1d::SegmentValue;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One panel: cells (column i, row j) with a value in [lo, hi] of the colour scale and a label.
pub struct HeatPanel {
    /// Panel title.
    pub title: String,
    /// (column i, row j, value on the colour scale, label) of each cell.
    pub cells: Vec<(usize, usize, f64, String)>,
}

/// The shared axes of a heatmap figure.
pub struct HeatAxes<'a> {
    /// Column labels, one per column i (left to right).
    pub x_labels: &'a [String],
    /// Row labels, one per row j (row 0 at the bottom).
    pub y_labels: &'a [String],
    /// Description of the x axis.
    pub x_desc: &'a str,
    /// Description of the y axis.
    pub y_desc: &'a str,
}

/// Colour scales: value in [0, 1] (sequential, white to blue) or [-1, 1] (diverging, red to
/// white to green).
#[derive(Debug, Clone, Copy)]
pub enum Scale {
    /// Value in [0, 1], white to blue.
    Sequential,
    /// Value in [-1, 1], red through white to green.
    Diverging,
}

fn lerp(a: RGBColor, b: RGBColor, t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    let f = |x: u8, y: u8| (x as f64 + (y as f64 - x as f64) * t).round() as u8;
    RGBColor(f(a.0, b.0), f(a.1, b.1), f(a.2, b.2))
}

impl Scale {
    /// The cell colour of value `v`; light grey for a non-finite value.
    pub fn colour(&self, v: f64) -> RGBColor {
        let blue = RGBColor(8, 69, 148);
        let green = RGBColor(0, 109, 44);
        let red = RGBColor(165, 15, 21);
        if !v.is_finite() {
            return RGBColor(220, 220, 220);
        }
        match self {
            Scale::Sequential => lerp(WHITE, blue, v),
            Scale::Diverging if v >= 0.0 => lerp(WHITE, green, v),
            Scale::Diverging => lerp(WHITE, red, -v),
        }
    }

    /// Black text on light cells, white on dark ones.
    fn text_colour(&self, v: f64) -> RGBColor {
        if v.is_finite() && v.abs() > 0.55 {
            WHITE
        } else {
            BLACK
        }
    }
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// A white figure of `size` with `caption` in a 40 px strip at the bottom: (whole, body).
fn captioned<'a>(
    buf: &'a mut [u8],
    size: (u32, u32),
    caption: &str,
) -> Result<(Area<'a>, Area<'a>), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let (body, foot) = root.split_vertically(size.1 - 40);
    foot.draw(&Text::new(
        caption.to_string(),
        (10, 10),
        ("sans-serif", 15).into_font(),
    ))?;
    Ok((root, body))
}

/// Writes `panels` in a grid of `columns` columns to `path`.
pub fn save(
    path: &Path,
    axes: &HeatAxes,
    panels: &[HeatPanel],
    columns: usize,
    scale: Scale,
    caption: &str,
) -> super::error::Result<()> {
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let (w, h) = (420 * columns as u32, 340 * rows as u32 + 40);
    super::plot::save_rgb(path, (w, h), |buf| {
        draw(buf, (w, h), axes, panels, columns, rows, scale, caption)
    })
}

#[allow(clippy::too_many_arguments)]
fn draw(
    buf: &mut [u8],
    size: (u32, u32),
    axes: &HeatAxes,
    panels: &[HeatPanel],
    columns: usize,
    rows: usize,
    scale: Scale,
    caption: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let (root, body) = captioned(buf, size, caption)?;
    let areas = body.split_evenly((rows, columns));
    let (nx, ny) = (axes.x_labels.len(), axes.y_labels.len());
    for (panel, area) in panels.iter().zip(&areas) {
        let mut chart = ChartBuilder::on(area)
            .caption(panel.title.as_str(), ("sans-serif", 17))
            .margin(8)
            .x_label_area_size(42)
            .y_label_area_size(62)
            .build_cartesian_2d((0..nx).into_segmented(), (0..ny).into_segmented())?;
        let label = |labels: &[String], v: &SegmentValue<usize>| match v {
            SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
            _ => String::new(),
        };
        let x_fmt = |v: &SegmentValue<usize>| label(axes.x_labels, v);
        let y_fmt = |v: &SegmentValue<usize>| label(axes.y_labels, v);
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(nx)
            .y_labels(ny)
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .x_desc(axes.x_desc)
            .y_desc(axes.y_desc)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .draw()?;
        let exact = SegmentValue::Exact;
        chart.draw_series(panel.cells.iter().map(|(i, j, v, _)| {
            Rectangle::new(
                [(exact(*i), exact(*j)), (exact(i + 1), exact(j + 1))],
                scale.colour(*v).filled(),
            )
        }))?;
        let centre = Pos::new(HPos::Center, VPos::Center);
        chart.draw_series(panel.cells.iter().map(|(i, j, v, text)| {
            let style = ("sans-serif", 13)
                .into_font()
                .color(&scale.text_colour(*v))
                .pos(centre);
            Text::new(
                text.clone(),
                (SegmentValue::CenterOf(*i), SegmentValue::CenterOf(*j)),
                style,
            )
        }))?;
    }
    root.present()?;
    Ok(())
}

/// One scatter panel: points (x, y, value on the colour scale, label), x on a log axis.
pub struct ScatterPanel {
    /// Panel title.
    pub title: String,
    /// (x, y, value on the colour scale, label) of each point.
    pub points: Vec<(f64, f64, f64, String)>,
}

/// Writes scatter panels side by side (log x, linear y, shared ranges) to `path`.
pub fn save_scatter(
    path: &Path,
    panels: &[ScatterPanel],
    (x_desc, y_desc): (&str, &str),
    scale: Scale,
    caption: &str,
) -> super::error::Result<()> {
    let (w, h) = (520 * panels.len().max(1) as u32, 460);
    super::plot::save_rgb(path, (w, h), |buf| {
        draw_scatter(buf, (w, h), panels, (x_desc, y_desc), scale, caption)
    })
}

fn draw_scatter(
    buf: &mut [u8],
    size: (u32, u32),
    panels: &[ScatterPanel],
    (x_desc, y_desc): (&str, &str),
    scale: Scale,
    caption: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let (root, body) = captioned(buf, size, caption)?;
    let xs = panels.iter().flat_map(|p| p.points.iter().map(|q| q.0));
    let (lo, hi) = xs
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    let (lo, hi) = if lo.is_finite() {
        (lo / 1.5, hi * 1.5)
    } else {
        (0.01, 1.0)
    };
    let areas = body.split_evenly((1, panels.len().max(1)));
    for (panel, area) in panels.iter().zip(&areas) {
        let mut chart = ChartBuilder::on(area)
            .caption(panel.title.as_str(), ("sans-serif", 17))
            .margin(10)
            .x_label_area_size(42)
            .y_label_area_size(52)
            .build_cartesian_2d((lo..hi).log_scale(), -0.05f64..1.05)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .draw()?;
        chart.draw_series(panel.points.iter().map(|(x, y, v, _)| {
            EmptyElement::at((*x, *y))
                + Circle::new((0, 0), 9, scale.colour(*v).filled())
                + Circle::new((0, 0), 9, BLACK.mix(0.6).stroke_width(1))
        }))?;
        chart.draw_series(panel.points.iter().map(|(x, y, _, text)| {
            EmptyElement::at((*x, *y))
                + Text::new(text.clone(), (11, -6), ("sans-serif", 11).into_font())
        }))?;
    }
    root.present()?;
    Ok(())
}
