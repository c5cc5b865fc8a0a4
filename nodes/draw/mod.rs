//! Drawing on annotated images: an rgb8 canvas with lines, circles, rectangles and
//! text in a built-in font.

pub mod font;

use nalgebra::Point2;
use stereocal_vision::board::Gray;
use stereocal_vision::image::{Image, Samples};

use font::{ADVANCE, GLYPH_WIDTH, glyph};

/// An rgb8 drawing surface.
pub struct Canvas {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    data: Vec<u8>,
}

impl Canvas {
    /// The grey image as rgb8.
    pub fn from_gray(gray: &Gray) -> Self {
        Self {
            width: gray.width,
            height: gray.height,
            data: gray.data.iter().flat_map(|&v| [v, v, v]).collect(),
        }
    }

    /// A black image.
    pub fn black(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![0; width * height * 3],
        }
    }

    /// The drawing as an rgb8 image.
    pub fn into_image(self) -> Image {
        Image {
            width: self.width,
            height: self.height,
            channels: 3,
            samples: Samples::U8(self.data),
        }
    }

    /// Sets one pixel; outside the image nothing is drawn.
    pub fn put(&mut self, x: i64, y: i64, colour: [u8; 3]) {
        if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
            return;
        }
        let at = (y as usize * self.width + x as usize) * 3;
        self.data[at..at + 3].copy_from_slice(&colour);
    }

    /// A one-pixel line from `a` to `b` (pixel centres at integer coordinates).
    pub fn line(&mut self, a: Point2<f64>, b: Point2<f64>, colour: [u8; 3]) {
        let steps = (b - a).abs().max().ceil().clamp(1.0, 1e5) as usize;
        for k in 0..=steps {
            let p = a + (b - a) * (k as f64 / steps as f64);
            self.put(p.x.round() as i64, p.y.round() as i64, colour);
        }
    }

    /// A one-pixel circle.
    pub fn circle(&mut self, centre: Point2<f64>, radius: f64, colour: [u8; 3]) {
        let steps = (radius * 8.0).ceil().max(8.0) as usize;
        for k in 0..steps {
            let angle = k as f64 / steps as f64 * std::f64::consts::TAU;
            let p = centre + nalgebra::Vector2::new(angle.cos(), angle.sin()) * radius;
            self.put(p.x.round() as i64, p.y.round() as i64, colour);
        }
    }

    /// A filled rectangle, clipped to the image.
    pub fn rectangle(
        &mut self,
        x0: usize,
        y0: usize,
        width: usize,
        height: usize,
        colour: [u8; 3],
    ) {
        for y in y0..(y0 + height).min(self.height) {
            for x in x0..(x0 + width).min(self.width) {
                self.put(x as i64, y as i64, colour);
            }
        }
    }

    /// Halves the brightness of a rectangle, so text and bars on it read on any image.
    pub fn darken(&mut self, x0: usize, y0: usize, width: usize, height: usize) {
        for y in y0..(y0 + height).min(self.height) {
            for x in x0..(x0 + width).min(self.width) {
                let at = (y * self.width + x) * 3;
                for v in &mut self.data[at..at + 3] {
                    *v /= 2;
                }
            }
        }
    }

    /// Writes `text` with its top-left at `(x0, y0)`, each font pixel `scale` pixels.
    pub fn text(&mut self, x0: usize, y0: usize, text: &str, scale: usize, colour: [u8; 3]) {
        for (k, c) in text.chars().enumerate() {
            let left = x0 + k * ADVANCE * scale;
            for (row, bits) in glyph(c).iter().enumerate() {
                for col in 0..GLYPH_WIDTH {
                    if bits & (1 << (GLYPH_WIDTH - 1 - col)) != 0 {
                        self.rectangle(left + col * scale, y0 + row * scale, scale, scale, colour);
                    }
                }
            }
        }
    }

    /// A frame of `thickness` pixels around the image.
    pub fn frame(&mut self, thickness: usize, colour: [u8; 3]) {
        let (w, h) = (self.width, self.height);
        let t = thickness.min(w / 2).min(h / 2);
        self.rectangle(0, 0, w, t, colour);
        self.rectangle(0, h.saturating_sub(t), w, t, colour);
        self.rectangle(0, 0, t, h, colour);
        self.rectangle(w.saturating_sub(t), 0, t, h, colour);
    }
}
