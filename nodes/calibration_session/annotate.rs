//! The annotated image a calibration node publishes: the input in grey (as
//! camera_calibration shows it) as rgb8, the detected corners drawn as OpenCV's
//! `drawChessboardCorners` draws a found board, each camera's coverage bars, and the
//! verdict as a coloured frame.

use nalgebra::Point2;
use stereocal_vision::board::{Detection, Gray};
use stereocal_vision::image::{Image, Samples};

use super::{Progress, Verdict};

/// Row colours of `drawChessboardCorners` (its BGR table in RGB order), cycling.
const ROW_COLOURS: [[u8; 3]; 7] = [
    [255, 0, 0],
    [255, 128, 0],
    [200, 200, 0],
    [0, 255, 0],
    [0, 200, 200],
    [0, 0, 255],
    [255, 0, 255],
];
/// Radius of the circle and half-size of the cross at each corner (OpenCV's 4 px).
const CORNER_RADIUS: f64 = 4.0;
/// Width of the verdict frame, pixels.
const FRAME: usize = 4;
/// Colour of the frame of a frame kept as a sample.
const ADDED: [u8; 3] = [0, 220, 0];
/// Colour of the frame of a usable frame that adds no coverage.
const NOT_NEW: [u8; 3] = [230, 200, 0];
/// Colour of the frame of a refused frame.
const REFUSED: [u8; 3] = [230, 0, 0];

/// The annotated image the node publishes: the input as rgb8 with the detected corners
/// (ordered, coloured along rows as OpenCV's drawChessboardCorners), coverage bars and
/// the verdict.
///
/// The image is shown in grey, whatever its encoding. Corners are joined in id order
/// and drawn as a circle and a cross in the colour of their board row. At the top left, per camera of `progress`, four bars (X, Y, size, skew,
/// top to bottom) fill from red to green as camera_calibration's do. A frame around
/// the image shows the verdict: green added, yellow not new, red refused. An image that
/// is not well formed gives a black image of its size.
pub fn annotate(
    image: &Image,
    detection: Option<&Detection>,
    progress: &Progress,
    verdict: &Verdict,
) -> Image {
    let mut canvas = match Gray::from_image(image) {
        Ok(gray) => Canvas::from_gray(&gray),
        Err(_) => Canvas::black(image.width, image.height),
    };
    if let Some(detection) = detection {
        draw_corners(&mut canvas, detection);
    }
    draw_bars(&mut canvas, progress);
    let colour = match verdict {
        Verdict::Added => ADDED,
        Verdict::NotNew => NOT_NEW,
        Verdict::Refused(_) => REFUSED,
    };
    canvas.frame(FRAME, colour);
    canvas.into_image()
}

/// An rgb8 drawing surface.
struct Canvas {
    width: usize,
    height: usize,
    data: Vec<u8>,
}

impl Canvas {
    fn from_gray(gray: &Gray) -> Self {
        Self {
            width: gray.width,
            height: gray.height,
            data: gray.data.iter().flat_map(|&v| [v, v, v]).collect(),
        }
    }

    fn black(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![0; width * height * 3],
        }
    }

    fn into_image(self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            channels: 3,
            samples: Samples::U8(self.data),
        }
    }

    fn put(&mut self, x: i64, y: i64, colour: [u8; 3]) {
        if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
            return;
        }
        let at = (y as usize * self.width + x as usize) * 3;
        self.data[at..at + 3].copy_from_slice(&colour);
    }

    /// A one-pixel line from `a` to `b` (pixel centres at integer coordinates).
    fn line(&mut self, a: Point2<f64>, b: Point2<f64>, colour: [u8; 3]) {
        let steps = (b - a).abs().max().ceil().clamp(1.0, 1e5) as usize;
        for k in 0..=steps {
            let p = a + (b - a) * (k as f64 / steps as f64);
            self.put(p.x.round() as i64, p.y.round() as i64, colour);
        }
    }

    fn circle(&mut self, centre: Point2<f64>, radius: f64, colour: [u8; 3]) {
        let steps = (radius * 8.0).ceil().max(8.0) as usize;
        for k in 0..steps {
            let angle = k as f64 / steps as f64 * std::f64::consts::TAU;
            let p = centre + nalgebra::Vector2::new(angle.cos(), angle.sin()) * radius;
            self.put(p.x.round() as i64, p.y.round() as i64, colour);
        }
    }

    fn rectangle(&mut self, x0: usize, y0: usize, width: usize, height: usize, colour: [u8; 3]) {
        for y in y0..(y0 + height).min(self.height) {
            for x in x0..(x0 + width).min(self.width) {
                self.put(x as i64, y as i64, colour);
            }
        }
    }

    fn frame(&mut self, thickness: usize, colour: [u8; 3]) {
        let (w, h) = (self.width, self.height);
        let t = thickness.min(w / 2).min(h / 2);
        self.rectangle(0, 0, w, t, colour);
        self.rectangle(0, h.saturating_sub(t), w, t, colour);
        self.rectangle(0, 0, t, h, colour);
        self.rectangle(w.saturating_sub(t), 0, t, h, colour);
    }
}

/// The corners as OpenCV draws a found board: consecutive corners joined, each corner a
/// cross and a circle, in its row's colour. Corners come row after row; a new row
/// starts where the step to the next corner turns against the first row's direction
/// (the jump back to the next row's start), so the board's size is not needed.
fn draw_corners(canvas: &mut Canvas, detection: &Detection) {
    let r = nalgebra::Vector2::new(CORNER_RADIUS, CORNER_RADIUS);
    let flipped = nalgebra::Vector2::new(CORNER_RADIUS, -CORNER_RADIUS);
    let along = match detection.corners.as_slice() {
        [first, second, ..] => second - first,
        _ => nalgebra::Vector2::zeros(),
    };
    let mut row = 0;
    let mut previous: Option<Point2<f64>> = None;
    for &corner in &detection.corners {
        if let Some(previous) = previous
            && (corner - previous).dot(&along) < 0.0
        {
            row += 1;
        }
        let colour = ROW_COLOURS[row % ROW_COLOURS.len()];
        if let Some(previous) = previous {
            canvas.line(previous, corner, colour);
        }
        canvas.line(corner - r, corner + r, colour);
        canvas.line(corner - flipped, corner + flipped, colour);
        canvas.circle(corner, CORNER_RADIUS + 1.0, colour);
        previous = Some(corner);
    }
}

/// Per camera, four bars (X, Y, size, skew) at the top left.
fn draw_bars(canvas: &mut Canvas, progress: &Progress) {
    let length = (canvas.width / 5).max(20);
    let height = (canvas.height / 60).max(4);
    let gap = height / 2 + 1;
    let mut y = FRAME + gap;
    for camera in &progress.cameras {
        for value in [camera.x, camera.y, camera.size, camera.skew] {
            let x0 = FRAME + gap;
            canvas.rectangle(x0, y, length, height, [40, 40, 40]);
            let filled = (value.clamp(0.0, 1.0) * length as f64).round() as usize;
            canvas.rectangle(x0, y, filled, height, bar_colour(value));
            y += height + gap;
        }
        y += gap * 2;
    }
}

/// Red at no progress through yellow to green when full.
fn bar_colour(value: f64) -> [u8; 3] {
    let v = value.clamp(0.0, 1.0);
    if v >= 1.0 {
        [0, 200, 0]
    } else {
        [230, (200.0 * v) as u8, 0]
    }
}
