//! Shared pieces of the charts: plotters' SVG made fit to inline in HTML, the mapping
//! from data to SVG coordinates for the marks drawn beside plotters', and colours.

use std::fmt::{Display, Write};
use std::ops::Range;

use super::ReportError;

/// Maps plotters errors of `chart` to [`ReportError::Chart`].
pub(crate) fn chart_error<E: Display>(chart: &'static str) -> impl Fn(E) -> ReportError {
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
