//! The 8-bit grey plane detection works on, made from any [`Image`], and its
//! half-resolution copies.

use crate::image::{Image, Samples};

use super::BoardError;

/// A tightly packed 8-bit grey image. Pixel `(x, y)` is sampled at its centre, the
/// integer coordinates `(x, y)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Gray {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` samples, row after row.
    pub data: Vec<u8>,
}

impl Gray {
    /// The grey plane of `image`: mono as is, 16-bit scaled to 8 bits, colour as
    /// `(c0 + 2 c1 + c2) / 4`, which is the same for RGB and BGR order; a fourth
    /// (alpha) channel is ignored.
    pub fn from_image(image: &Image) -> Result<Self, BoardError> {
        let pixels = image.width * image.height;
        let expected = pixels * image.channels;
        let actual = match &image.samples {
            Samples::U8(v) => v.len(),
            Samples::U16(v) => v.len(),
        };
        if image.width == 0 || image.height == 0 || expected != actual {
            return Err(BoardError::BadImage {
                width: image.width,
                height: image.height,
                channels: image.channels,
                samples: actual,
            });
        }
        let data = match (&image.samples, image.channels) {
            (Samples::U8(v), 1) => v.clone(),
            (Samples::U16(v), 1) => v.iter().map(|&s| (s >> 8) as u8).collect(),
            (Samples::U8(v), c @ (3 | 4)) => {
                v.chunks_exact(c).map(|p| luma(p[0], p[1], p[2])).collect()
            }
            (Samples::U16(v), c @ (3 | 4)) => v
                .chunks_exact(c)
                .map(|p| luma((p[0] >> 8) as u8, (p[1] >> 8) as u8, (p[2] >> 8) as u8))
                .collect(),
            _ => {
                return Err(BoardError::UnsupportedChannels(image.channels));
            }
        };
        Ok(Self {
            width: image.width,
            height: image.height,
            data,
        })
    }

    /// Half-resolution copy: each pixel the mean of a 2x2 block. Pixel `(x, y)` of the
    /// copy is centred on `(2x + 0.5, 2y + 0.5)` of this image.
    pub fn half(&self) -> Self {
        let width = self.width / 2;
        let height = self.height / 2;
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            let top = &self.data[2 * y * self.width..][..2 * width];
            let bottom = &self.data[(2 * y + 1) * self.width..][..2 * width];
            data.extend(
                top.chunks_exact(2)
                    .zip(bottom.chunks_exact(2))
                    .map(|(t, b)| {
                        ((t[0] as u16 + t[1] as u16 + b[0] as u16 + b[1] as u16 + 2) / 4) as u8
                    }),
            );
        }
        Self {
            width,
            height,
            data,
        }
    }

    /// Bilinear sample at `(x, y)` (pixel centres at integer coordinates), `None`
    /// outside the area between the outermost pixel centres.
    pub fn sample(&self, x: f64, y: f64) -> Option<f64> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        if x0 + 1 >= self.width || y0 + 1 >= self.height {
            return None;
        }
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        let at = |xx: usize, yy: usize| self.data[yy * self.width + xx] as f64;
        let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
        let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }
}

fn luma(c0: u8, c1: u8, c2: u8) -> u8 {
    ((c0 as u16 + 2 * c1 as u16 + c2 as u16 + 2) / 4) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_planes_average_symmetrically() {
        let image = Image::new(2, 1, 3, Samples::U8(vec![200, 100, 0, 0, 100, 200])).unwrap();
        let gray = Gray::from_image(&image).unwrap();
        assert_eq!(gray.data, vec![100, 100]);
    }

    #[test]
    fn malformed_images_are_refused() {
        let image = Image {
            width: 4,
            height: 4,
            channels: 1,
            samples: Samples::U8(vec![0; 15]),
        };
        assert!(matches!(
            Gray::from_image(&image),
            Err(BoardError::BadImage { .. })
        ));
        let two = Image::zeros_u8(4, 4, 2);
        assert_eq!(
            Gray::from_image(&two),
            Err(BoardError::UnsupportedChannels(2))
        );
    }

    #[test]
    fn half_resolution_keeps_pixel_centres() {
        // A horizontal ramp v = 10 x: the half image samples it at 2x + 0.5.
        let data: Vec<u8> = (0..8).flat_map(|_| (0..8).map(|x| 10 * x as u8)).collect();
        let gray = Gray {
            width: 8,
            height: 8,
            data,
        };
        let half = gray.half();
        assert_eq!((half.width, half.height), (4, 4));
        assert_eq!(half.data[..4], [5, 25, 45, 65]);
        assert_eq!(gray.sample(2.5, 3.0), Some(25.0));
        assert_eq!(gray.sample(7.5, 3.0), None);
    }
}
