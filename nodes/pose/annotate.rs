//! The annotated image `pose_node` publishes: the input in grey as rgb8, the target's
//! axes as OpenCV's `drawFrameAxes` draws them (x red, y green, z blue), the corners
//! found and where the pose reprojects them, and a line of text with the verdict.

use nalgebra::{Point2, Point3, Vector2};
use stereocal_vision::board::{Gray, Target};
use stereocal_vision::image::Image;

use super::stage::{FramePose, PoseRejection};
use crate::draw::Canvas;

/// Colour of a corner as detected.
const DETECTED: [u8; 3] = [255, 200, 0];
/// Colour of a corner as the pose reprojects it.
const REPROJECTED: [u8; 3] = [0, 255, 0];
/// Axis colours, x, y, z.
const AXES: [[u8; 3]; 3] = [[255, 0, 0], [0, 255, 0], [0, 0, 255]];
/// Colour of the text of a pose.
const GOOD: [u8; 3] = [0, 230, 0];
/// Colour of the text of a rejection.
const REFUSED: [u8; 3] = [230, 0, 0];

/// The annotated image of one frame: axes three squares long from the target's origin,
/// each detected corner as a cross and its reprojection as a circle, and at the bottom
/// the RMS error and distance, or the reason there is no pose. An image that is not
/// well formed gives a black image of its size.
pub fn annotate(
    image: &Image,
    target: &Target,
    outcome: &Result<FramePose, PoseRejection>,
) -> Image {
    let mut canvas = match Gray::from_image(image) {
        Ok(gray) => Canvas::from_gray(&gray),
        Err(_) => Canvas::black(image.width, image.height),
    };
    let scale = (canvas.height / 240).max(1);
    let text = match outcome {
        Ok(pose) => {
            draw_pose(&mut canvas, target, pose);
            let t = pose.estimate.camera_from_target.translation.vector;
            (
                GOOD,
                format!(
                    "pose: rms {:.3} px, distance {:.3} m",
                    pose.estimate.rms_px,
                    t.norm()
                ),
            )
        }
        Err(reason) => (REFUSED, format!("no pose: {reason}")),
    };
    let band = 9 * scale;
    let y0 = canvas.height.saturating_sub(band);
    canvas.darken(0, y0, canvas.width, band);
    canvas.text(scale, y0 + scale, &text.1, scale, text.0);
    canvas.into_image()
}

fn draw_pose(canvas: &mut Canvas, target: &Target, pose: &FramePose) {
    let camera_from_target = &pose.estimate.camera_from_target;
    let project = |p: &Point3<f64>| pose.camera.project(&(camera_from_target * p));
    let r = Vector2::new(3.0, 3.0);
    let flipped = Vector2::new(3.0, -3.0);
    for (corner, point) in pose.detection.corners.iter().zip(&pose.target_points) {
        canvas.line(corner - r, corner + r, DETECTED);
        canvas.line(corner - flipped, corner + flipped, DETECTED);
        if let Some(reprojected) = project(point) {
            canvas.circle(reprojected, 4.0, REPROJECTED);
        }
    }
    let length = 3.0 * target.square_size();
    let Some(origin) = project(&Point3::origin()) else {
        return;
    };
    for (axis, colour) in AXES.iter().enumerate() {
        let mut end = Point3::origin();
        end[axis] = length;
        if let Some(tip) = project(&end) {
            thick_line(canvas, origin, tip, *colour);
        }
    }
}

/// A line three pixels wide.
fn thick_line(canvas: &mut Canvas, a: Point2<f64>, b: Point2<f64>, colour: [u8; 3]) {
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
        let d = Vector2::new(dx, dy);
        canvas.line(a + d, b + d, colour);
    }
}
