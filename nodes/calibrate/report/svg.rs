//! Shared pieces of the charts: plotters' SVG made fit to inline in HTML, the mapping
//! from data to SVG coordinates for the marks drawn beside plotters', and colours.

use std::fmt::{Display, Write};
use std::ops::Range;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use super::ReportError;

/// A plotters chart with `f64` axes drawn into an SVG string.
pub(crate) type SvgChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The plotters error of drawing into an SVG string.
pub(crate) type SvgError = DrawingAreaErrorKind<std::io::Error>;

/// Draws the frame of a chart of `size` SVG pixels on white: margins and label areas
/// the same for every chart of the report, data ranges `x` and `y` (either may run
/// backwards), then `draw` configures the mesh and draws any plotters series. Returns
/// plotters' SVG document and the map from data to its plotting area; errors name
/// `name`.
pub(crate) fn draw_chart(
    name: &'static str,
    size: (u32, u32),
    x: Range<f64>,
    y: Range<f64>,
    draw: impl FnOnce(&mut SvgChart<'_, '_>) -> Result<(), SvgError>,
) -> Result<(String, PlotMap), ReportError> {
    let error = chart_error(name);
    let mut document = String::new();
    let map;
    {
        let root = SVGBackend::with_string(&mut document, size).into_drawing_area();
        root.fill(&WHITE).map_err(&error)?;
        let mut chart = ChartBuilder::on(&root)
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(52)
            .build_cartesian_2d(x.clone(), y.clone())
            .map_err(&error)?;
        draw(&mut chart).map_err(&error)?;
        map = PlotMap::new(x, y, chart.plotting_area().get_pixel_range());
        root.present().map_err(&error)?;
    }
    Ok((document, map))
}

/// A chart over an image of `width` x `height` pixels, `chart_width` SVG pixels wide:
/// pixel axes without grid lines, the image's edges at `-0.5` and `size - 0.5` (pixel
/// centres at integer coordinates), rows downwards.
pub(crate) fn image_chart(
    name: &'static str,
    chart_width: u32,
    (width, height): (f64, f64),
) -> Result<(String, PlotMap), ReportError> {
    let plot_height = (f64::from(chart_width - 70) * height / width).round() as u32 + 60;
    draw_chart(
        name,
        (chart_width, plot_height),
        -0.5..width - 0.5,
        height - 0.5..-0.5,
        |chart| {
            chart
                .configure_mesh()
                .disable_mesh()
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_label_formatter(&|y| format!("{y:.0}"))
                .x_desc("x (px)")
                .y_desc("y (px)")
                .draw()
        },
    )
}

/// Maps plotters errors of `chart` to [`ReportError::Chart`].
fn chart_error<E: Display>(chart: &'static str) -> impl Fn(E) -> ReportError {
    move |e| ReportError::Chart {
        chart,
        message: e.to_string(),
    }
}

/// plotters' SVG document as an inline `<svg>` element: without the XML namespace (an
/// HTML parser gives inline SVG its namespace), scaled to the page's width, with
/// `marks` (SVG elements drawn in the same coordinates) appended on top.
pub(crate) fn inline(document: &str, marks: &str) -> String {
    let document = document
        .replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1)
        .replacen("<svg ", "<svg class=\"chart\" ", 1);
    match document.rfind("</svg>") {
        Some(end) => format!("{}{marks}</svg>", &document[..end]),
        None => document,
    }
}

/// A linear map from data coordinates to the SVG coordinates of a chart's plotting
/// area (either data range may run backwards, e.g. image rows downwards).
#[derive(Clone, Debug)]
pub(crate) struct PlotMap {
    x: Range<f64>,
    y: Range<f64>,
    px: Range<f64>,
    py: Range<f64>,
}

impl PlotMap {
    /// Data ranges `x`, `y` shown over the plotting area's pixels `(px, py)` (plotters'
    /// `get_pixel_range`: the x range left to right, the y range top to bottom).
    pub fn new(x: Range<f64>, y: Range<f64>, pixels: (Range<i32>, Range<i32>)) -> Self {
        let (px, py) = pixels;
        Self {
            x,
            // plotters puts the start of the y range at the bottom.
            y: y.end..y.start,
            px: f64::from(px.start)..f64::from(px.end),
            py: f64::from(py.start)..f64::from(py.end),
        }
    }

    /// SVG x of data x.
    pub fn x(&self, x: f64) -> f64 {
        self.px.start
            + (x - self.x.start) / (self.x.end - self.x.start) * (self.px.end - self.px.start)
    }

    /// SVG y of data y.
    pub fn y(&self, y: f64) -> f64 {
        self.py.start
            + (y - self.y.start) / (self.y.end - self.y.start) * (self.py.end - self.py.start)
    }

    /// SVG pixels per data unit along x.
    pub fn x_scale(&self) -> f64 {
        ((self.px.end - self.px.start) / (self.x.end - self.x.start)).abs()
    }
}

/// Appends a rectangle between two SVG corners with the class, fill and tooltip given
/// (`extra` holds further attributes, already escaped).
pub(crate) fn rect(
    out: &mut String,
    (x0, y0): (f64, f64),
    (x1, y1): (f64, f64),
    class: &str,
    fill: &str,
    extra: &str,
    title: &str,
) {
    let _ = write!(
        out,
        "<rect class=\"{class}\" x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"{fill}\"{extra}><title>{}</title></rect>",
        x0.min(x1),
        y0.min(y1),
        (x1 - x0).abs(),
        (y1 - y0).abs(),
        super::html::escape(title)
    );
}

/// A colour of a ramp from pale yellow (0) through orange to dark red (1), as CSS.
pub(crate) fn heat(t: f64) -> String {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let stops = [
        (255.0, 247.0, 188.0),
        (254.0, 196.0, 79.0),
        (236.0, 112.0, 20.0),
        (153.0, 52.0, 4.0),
    ];
    let scaled = t * (stops.len() - 1) as f64;
    let i = (scaled.floor() as usize).min(stops.len() - 2);
    let f = scaled - i as f64;
    let (a, b) = (stops[i], stops[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        mix(a.0, b.0),
        mix(a.1, b.1),
        mix(a.2, b.2)
    )
}
