//! The annotated image a calibration node publishes: the input in grey (as
//! camera_calibration shows it) as rgb8, the detected corners drawn as OpenCV's
//! `drawChessboardCorners` draws a found board, each camera's coverage bars, and the
//! verdict as a coloured frame and a line of text.

use nalgebra::Point2;
use stereocal_vision::board::{Detection, Gray};
use stereocal_vision::image::Image;

use super::{Progress, Verdict};
use crate::draw::Canvas;
use crate::draw::font::{ADVANCE, GLYPH_HEIGHT};

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
/// Colour of text.
const TEXT: [u8; 3] = [255, 255, 255];
/// Colour of an empty bar.
const EMPTY_BAR: [u8; 3] = [60, 60, 60];
/// Lines of text the verdict may take at most.
const VERDICT_LINES: usize = 3;

/// The annotated image the node publishes: the input as rgb8 with the detected corners
/// (ordered, coloured along rows as OpenCV's drawChessboardCorners), coverage bars and
/// the verdict.
///
/// The image is shown in grey, whatever its encoding. Corners are joined in order and
/// drawn as a circle and a cross in the colour of their board row. At the top left, per
/// camera of `progress`, its name and four bars (X, Y, size, skew) that fill from red to
/// green as camera_calibration's do, on a darkened panel. A frame around the image shows
/// the verdict (green added, yellow not new, red refused), and a band at the bottom
/// says it in words with the number of samples. Text is scaled to the image (one font
/// pixel per 240 image rows). An image that is not well formed gives a black image of
/// its size.
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
    let scale = (canvas.height / 240).max(1);
    draw_bars(&mut canvas, progress, scale);
    let (colour, text) = match verdict {
        Verdict::Added => (ADDED, format!("added: {} samples", progress.samples)),
        Verdict::NotNew => (
            NOT_NEW,
            format!(
                "not new: move the board elsewhere or tilt it ({} samples)",
                progress.samples
            ),
        ),
        Verdict::Refused(reason) => (REFUSED, format!("refused: {reason}")),
    };
    draw_verdict(&mut canvas, &text, scale);
    // Corners go over the panels, so a board behind them stays visible.
    if let Some(detection) = detection {
        draw_corners(&mut canvas, detection);
    }
    canvas.frame(FRAME, colour);
    canvas.into_image()
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

/// Per camera, its name and four labelled bars (X, Y, size, skew) at the top left.
fn draw_bars(canvas: &mut Canvas, progress: &Progress, scale: usize) {
    let line = (GLYPH_HEIGHT + 3) * scale;
    let label = 5 * ADVANCE * scale;
    let length = (canvas.width / 5).max(20);
    let margin = FRAME + 2 * scale;
    let panel_width = label + length + 2 * margin;
    let panel_height = progress.cameras.len() * 5 * line + 2 * scale;
    canvas.darken(FRAME, FRAME, panel_width, panel_height);
    let mut y = margin;
    for camera in &progress.cameras {
        canvas.text(margin, y, &camera.name, scale, TEXT);
        y += line;
        for (name, value) in [
            ("x", camera.x),
            ("y", camera.y),
            ("size", camera.size),
            ("skew", camera.skew),
        ] {
            canvas.text(margin, y, name, scale, TEXT);
            let x0 = margin + label;
            let height = GLYPH_HEIGHT * scale;
            canvas.rectangle(x0, y, length, height, EMPTY_BAR);
            let filled = (value.clamp(0.0, 1.0) * length as f64).round() as usize;
            canvas.rectangle(x0, y, filled, height, bar_colour(value));
            y += line;
        }
    }
}

/// The verdict's text in a darkened band along the bottom, wrapped at spaces to the
/// image's width, at most [`VERDICT_LINES`] lines.
fn draw_verdict(canvas: &mut Canvas, text: &str, scale: usize) {
    let margin = FRAME + 2 * scale;
    let per_line = (canvas.width.saturating_sub(2 * margin) / (ADVANCE * scale)).max(1);
    let lines = wrap(text, per_line);
    let shown = &lines[..lines.len().min(VERDICT_LINES)];
    let line = (GLYPH_HEIGHT + 3) * scale;
    let band = shown.len() * line + 2 * scale;
    let top = canvas.height.saturating_sub(FRAME + band);
    canvas.darken(FRAME, top, canvas.width.saturating_sub(2 * FRAME), band);
    for (k, text) in shown.iter().enumerate() {
        canvas.text(margin, top + 2 * scale + k * line, text, scale, TEXT);
    }
}

/// `text` cut into lines of at most `width` characters, at spaces where possible.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut current = String::new();
    for word in text.split_whitespace() {
        let mut word: Vec<char> = word.chars().collect();
        while word.len() > width {
            if !current.is_empty() {
                lines.push(std::mem::take(&mut current));
            }
            lines.push(word.drain(..width).collect());
        }
        let word: String = word.into_iter().collect();
        let needed = if current.is_empty() {
            word.chars().count()
        } else {
            current.chars().count() + 1 + word.chars().count()
        };
        if needed > width && !current.is_empty() {
            lines.push(std::mem::take(&mut current));
        }
        if !current.is_empty() {
            current.push(' ');
        }
        current.push_str(&word);
    }
    if !current.is_empty() {
        lines.push(current);
    }
    lines
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

#[cfg(test)]
mod tests {
    use super::super::CameraCoverage;
    use super::*;
    use stereocal_vision::image::Samples;

    fn pixel(image: &Image, x: usize, y: usize) -> [u8; 3] {
        let Samples::U8(data) = &image.samples else {
            panic!("not 8-bit");
        };
        let at = (y * image.width + x) * 3;
        [data[at], data[at + 1], data[at + 2]]
    }

    fn progress(x: f64) -> Progress {
        Progress {
            cameras: vec![CameraCoverage {
                name: "left".to_owned(),
                x,
                y: 0.0,
                size: 0.5,
                skew: 1.0,
            }],
            samples: 3,
            ready: false,
        }
    }

    #[test]
    fn corners_are_drawn_in_row_colours_with_frame_bars_and_verdict() {
        let image = Image::new(480, 360, 1, Samples::U8(vec![128; 480 * 360])).unwrap();
        // A 3x2 board: rows at y = 200 and 240.
        let corners: Vec<Point2<f64>> = [(200.0, 200.0), (240.0, 200.0), (280.0, 200.0)]
            .into_iter()
            .chain([(200.0, 240.0), (240.0, 240.0), (280.0, 240.0)])
            .map(|(x, y)| Point2::new(x, y))
            .collect();
        let detection = Detection {
            corners,
            ids: (0..6).collect(),
            square_px: 40.0,
        };
        let out = annotate(&image, Some(&detection), &progress(1.0), &Verdict::Added);
        assert_eq!((out.width, out.height, out.channels), (480, 360, 3));
        // The crosses: first row red, second orange, as drawChessboardCorners.
        assert_eq!(pixel(&out, 202, 202), [255, 0, 0]);
        assert_eq!(pixel(&out, 242, 198), [255, 0, 0]);
        assert_eq!(pixel(&out, 202, 242), [255, 128, 0]);
        // Joined along the row; untouched grey away from the board.
        assert_eq!(pixel(&out, 220, 200), [255, 0, 0]);
        assert_eq!(pixel(&out, 400, 150), [128, 128, 128]);
        // Added: a green frame.
        assert_eq!(pixel(&out, 0, 0), ADDED);
        assert_eq!(pixel(&out, 479, 359), ADDED);
        let refused = annotate(
            &image,
            None,
            &progress(0.0),
            &Verdict::Refused("board moving".to_owned()),
        );
        assert_eq!(pixel(&refused, 0, 180), REFUSED);
        assert_eq!(pixel(&refused, 202, 202), [128, 128, 128]);
        let not_new = annotate(&image, None, &progress(0.0), &Verdict::NotNew);
        assert_eq!(pixel(&not_new, 240, 2), NOT_NEW);
    }

    #[test]
    fn bars_fill_with_progress_and_text_is_written() {
        let image = Image::new(480, 360, 3, Samples::U8(vec![200; 480 * 360 * 3])).unwrap();
        let out = annotate(&image, None, &progress(1.0), &Verdict::Added);
        // Scale 1 at 360 rows: the X bar is the second line of the panel, after the
        // camera's name; it starts after five characters of label.
        let (margin, line, label) = (FRAME + 2, GLYPH_HEIGHT + 3, 5 * ADVANCE);
        let bar_x = margin + label;
        let x_bar_y = margin + line + 2;
        assert_eq!(pixel(&out, bar_x + 2, x_bar_y), [0, 200, 0]);
        // The Y bar is empty; size half full: red-yellow at its start, empty at its end.
        let y_bar_y = x_bar_y + line;
        assert_eq!(pixel(&out, bar_x + 2, y_bar_y), EMPTY_BAR);
        let size_bar_y = y_bar_y + line;
        let length = 480 / 5;
        assert_eq!(pixel(&out, bar_x + 2, size_bar_y), bar_colour(0.5));
        assert_eq!(pixel(&out, bar_x + length - 2, size_bar_y), EMPTY_BAR);
        // White text in the darkened panel (the camera's name) and in the verdict band.
        let white_in = |x0: usize, y0: usize, w: usize, h: usize| {
            (y0..y0 + h).any(|y| (x0..x0 + w).any(|x| pixel(&out, x, y) == TEXT))
        };
        assert!(white_in(margin, margin, 4 * ADVANCE, GLYPH_HEIGHT));
        assert!(white_in(margin, 360 - FRAME - line - 2, 200, line));
        // The panel is darkened: 200 becomes 100 between the label and the bars.
        assert_eq!(pixel(&out, bar_x - 2, x_bar_y), [100, 100, 100]);
    }

    #[test]
    fn text_wraps_at_spaces_and_cuts_long_words() {
        assert_eq!(
            wrap("refused: hold the board still", 12),
            ["refused:", "hold the", "board still"]
        );
        assert_eq!(wrap("abcdefghij xy", 4), ["abcd", "efgh", "ij", "xy"]);
        assert!(wrap("", 10).is_empty());
    }

    #[test]
    fn sixteen_bit_images_are_shown_and_malformed_ones_give_a_black_image() {
        let image = Image {
            width: 40,
            height: 30,
            channels: 1,
            samples: Samples::U8(vec![0; 10]),
        };
        let out = annotate(&image, None, &progress(0.0), &Verdict::NotNew);
        assert_eq!((out.width, out.height, out.channels), (40, 30, 3));
        let sixteen = Image::new(640, 480, 1, Samples::U16(vec![40_000; 640 * 480])).unwrap();
        let out = annotate(&sixteen, None, &progress(0.0), &Verdict::NotNew);
        assert_eq!(pixel(&out, 600, 240), [156, 156, 156]);
    }
}
