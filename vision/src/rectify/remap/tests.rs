use super::*;
use crate::rectify::map::INTER_TAB_SIZE;

fn mono8(width: usize, height: usize, f: impl Fn(usize, usize) -> u8) -> Image {
    let samples = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| f(x, y))
        .collect();
    Image::new(width, height, 1, Samples::U8(samples)).unwrap()
}

fn u8_samples(image: &Image) -> &[u8] {
    match &image.samples {
        Samples::U8(v) => v,
        Samples::U16(_) => panic!("expected 8-bit samples"),
    }
}

fn u16_samples(image: &Image) -> &[u16] {
    match &image.samples {
        Samples::U16(v) => v,
        Samples::U8(_) => panic!("expected 16-bit samples"),
    }
}

fn options(interpolation: Interpolation) -> RemapOptions {
    RemapOptions {
        interpolation,
        parallelism: Parallelism::Rayon,
    }
}

const ALL: [Interpolation; 3] = [
    Interpolation::Nearest,
    Interpolation::Bilinear,
    Interpolation::Bicubic,
];

/// A textured 8-bit image with every channel different.
fn texture(width: usize, height: usize, channels: usize) -> Image {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let samples = (0..width * height * channels)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 56) as u8
        })
        .collect();
    Image::new(width, height, channels, Samples::U8(samples)).unwrap()
}

/// A warp that moves, scales and shears the image and leaves part of the output
/// outside the source, so border pixels are exercised too.
fn warp_map(width: usize, height: usize) -> RectifyMap {
    RectifyMap::from_fn(width, height, |x, y| {
        let (x, y) = (x as f64, y as f64);
        (
            0.93 * x + 0.11 * y - 3.3 + 0.8 * (y * 0.05).sin(),
            -0.07 * x + 1.04 * y - 2.1 + 0.6 * (x * 0.04).cos(),
        )
    })
    .unwrap()
}

#[test]
fn identity_map_gives_the_input_back() {
    let map = RectifyMap::from_fn(37, 23, |x, y| (x as f64, y as f64)).unwrap();
    for channels in [1, 3, 4] {
        let src = texture(37, 23, channels);
        for interpolation in ALL {
            let out = remap(&src, &map, options(interpolation)).unwrap();
            assert_eq!(out, src, "{channels} channels, {interpolation:?}");
        }
    }
    let src16 = Image::new(
        37,
        23,
        1,
        Samples::U16((0..37 * 23).map(|i| (i * 71 % 65536) as u16).collect()),
    )
    .unwrap();
    for interpolation in ALL {
        assert_eq!(remap(&src16, &map, options(interpolation)).unwrap(), src16);
    }
}

/// On a linear ramp bilinear interpolation is exact: the output is the ramp at the
/// mapped position, rounded.
#[test]
fn bilinear_on_a_ramp_is_the_ramp_at_the_mapped_position() {
    let src = mono8(80, 60, |x, y| (2 * x + y + 5) as u8);
    let step = 1.0 / f64::from(INTER_TAB_SIZE);
    // Positions on the 1/32 grid, so the map stores them exactly.
    let position = |x: usize, y: usize| {
        (
            ((x * 17 % 32) as f64).mul_add(step, 2.0 + 0.75 * x as f64),
            ((y * 5 % 32) as f64).mul_add(step, 1.0 + 0.875 * y as f64),
        )
    };
    let map = RectifyMap::from_fn(90, 65, position).unwrap();
    let out = remap(&src, &map, RemapOptions::default()).unwrap();
    let mut inside = 0;
    for y in 0..65 {
        for x in 0..90 {
            let (u, v) = position(x, y);
            if u > 78.0 || v > 58.0 {
                continue;
            }
            let expected = 2.0 * u + v + 5.0;
            let got = f64::from(u8_samples(&out)[y * 90 + x]);
            assert!(
                (got - expected).abs() <= 0.5,
                "({x}, {y}): {got} vs {expected}"
            );
            inside += 1;
        }
    }
    assert!(inside > 3000);
}

/// On a smooth 16-bit image bilinear stays within its truncation bound
/// `(|f_xx| + |f_yy|) / 8` of the exact value, plus rounding.
#[test]
fn bilinear_on_a_smooth_image_is_within_the_interpolation_bound() {
    let (a, b, amplitude) = (0.05, 0.07, 20000.0);
    let f = |x: f64, y: f64| 32768.0 + amplitude * (a * x).sin() * (b * y).cos();
    let samples = (0..120)
        .flat_map(|y| (0..160).map(move |x| (x, y)))
        .map(|(x, y)| f(f64::from(x), f64::from(y)).round() as u16)
        .collect();
    let src = Image::new(160, 120, 1, Samples::U16(samples)).unwrap();
    let step = 1.0 / f64::from(INTER_TAB_SIZE);
    let position = |x: usize, y: usize| {
        (
            ((x * 13 % 32) as f64).mul_add(step, 0.90625 * x as f64),
            ((y * 7 % 32) as f64).mul_add(step, 0.9375 * y as f64),
        )
    };
    let map = RectifyMap::from_fn(150, 110, position).unwrap();
    let out = remap(&src, &map, RemapOptions::default()).unwrap();
    let bound = amplitude * (a * a + b * b) / 8.0 + 0.5 + 0.5;
    let mut worst: f64 = 0.0;
    for y in 0..110 {
        for x in 0..150 {
            let (u, v) = position(x, y);
            if u > 159.0 || v > 119.0 {
                continue;
            }
            let err = (f64::from(u16_samples(&out)[y * 150 + x]) - f(u, v)).abs();
            worst = worst.max(err);
        }
    }
    assert!(worst <= bound, "worst error {worst} > bound {bound}");
    // The bound is not vacuous: interpolation error is a sizeable part of it.
    assert!(worst > bound / 4.0, "worst error {worst}");
}

/// Bicubic matches the Keys convolution (a = -0.75) evaluated in double precision, up
/// to rounding and the 15-bit quantization of the weights.
#[test]
fn bicubic_matches_the_exact_cubic_convolution() {
    let src = texture(50, 40, 1);
    let s = u8_samples(&src);
    let map = warp_map(48, 38);
    let out = remap(&src, &map, options(Interpolation::Bicubic)).unwrap();
    let kernel = |t: f64| {
        let a = -0.75;
        let t = t.abs();
        if t <= 1.0 {
            ((a + 2.0) * t - (a + 3.0)) * t * t + 1.0
        } else if t < 2.0 {
            ((a * t - 5.0 * a) * t + 8.0 * a) * t - 4.0 * a
        } else {
            0.0
        }
    };
    let tolerance = 0.5 + 17.0 * 255.0 / 32768.0;
    for y in 0..38 {
        for x in 0..48 {
            let (u, v) = map.source_position(x, y).unwrap();
            let (x0, y0) = (u.floor() as i64, v.floor() as i64);
            let mut sum = 0.0;
            for j in -1..=2 {
                for i in -1..=2 {
                    let (sx, sy) = (x0 + i, y0 + j);
                    if (0..50).contains(&sx) && (0..40).contains(&sy) {
                        let p = f64::from(s[(sy * 50 + sx) as usize]);
                        sum += p * kernel(u - sx as f64) * kernel(v - sy as f64);
                    }
                }
            }
            let expected = sum.clamp(0.0, 255.0);
            let got = f64::from(u8_samples(&out)[y * 48 + x]);
            assert!(
                (got - expected).abs() <= tolerance,
                "({x}, {y}) at ({u}, {v}): {got} vs {expected}"
            );
        }
    }
}

#[test]
fn constant_border_is_zero_and_blends_at_the_edge() {
    let src = mono8(10, 8, |_, _| 200);
    let half = 0.5;
    let positions = [
        (-half, 3.0),  // halfway into the border
        (-0.53, 3.0),  // nearer the border pixel
        (4.0, 7.5),    // halfway below the last row
        (-40.0, 3.0),  // far outside
        (3.0, 1000.0), // far outside
        (4.25, 3.0),   // inside
    ];
    let map = RectifyMap::from_fn(positions.len(), 1, |x, _| positions[x]).unwrap();
    let run = |interpolation| remap(&src, &map, options(interpolation)).unwrap();
    assert_eq!(
        u8_samples(&run(Interpolation::Bilinear)),
        &[100, 94, 100, 0, 0, 200]
    );
    // Nearest rounds half up: -0.5 picks column 0, 7.5 picks row 8 (outside).
    assert_eq!(
        u8_samples(&run(Interpolation::Nearest)),
        &[200, 0, 0, 0, 0, 200]
    );
    let cubic = run(Interpolation::Bicubic);
    assert_eq!(&u8_samples(&cubic)[3..], &[0, 0, 200]);
    assert!(u8_samples(&cubic)[0] > 0 && u8_samples(&cubic)[0] < 200);
}

/// Remapping an interleaved image equals remapping each channel on its own.
#[test]
fn channels_are_remapped_independently() {
    let map = warp_map(45, 33);
    for channels in [3, 4] {
        let src = texture(48, 36, channels);
        let wide = Image {
            samples: Samples::U16(
                u8_samples(&src)
                    .iter()
                    .map(|&v| u16::from(v) * 256 + 3)
                    .collect(),
            ),
            ..src.clone()
        };
        for interpolation in ALL {
            let out = remap(&src, &map, options(interpolation)).unwrap();
            let out16 = remap(&wide, &map, options(interpolation)).unwrap();
            for c in 0..channels {
                let plane = mono8(48, 36, |x, y| u8_samples(&src)[(y * 48 + x) * channels + c]);
                let plane16 = Image {
                    samples: Samples::U16(
                        u16_samples(&wide)
                            .iter()
                            .skip(c)
                            .step_by(channels)
                            .copied()
                            .collect(),
                    ),
                    ..plane.clone()
                };
                let expected = remap(&plane, &map, options(interpolation)).unwrap();
                let expected16 = remap(&plane16, &map, options(interpolation)).unwrap();
                let got: Vec<u8> = u8_samples(&out)
                    .iter()
                    .skip(c)
                    .step_by(channels)
                    .copied()
                    .collect();
                let got16: Vec<u16> = u16_samples(&out16)
                    .iter()
                    .skip(c)
                    .step_by(channels)
                    .copied()
                    .collect();
                assert_eq!(
                    got,
                    u8_samples(&expected),
                    "{channels} channels, channel {c}, {interpolation:?}"
                );
                assert_eq!(
                    got16,
                    u16_samples(&expected16),
                    "16-bit, channel {c}, {interpolation:?}"
                );
            }
        }
    }
}

/// 16-bit samples keep their full range: a 16-bit ramp remapped bilinearly is the ramp
/// at the mapped position, far beyond 8 bits.
#[test]
fn mono16_keeps_sixteen_bits() {
    let samples = (0..40 * 30)
        .map(|i| ((i % 40) * 1500 + (i / 40) * 100) as u16)
        .collect();
    let src = Image::new(40, 30, 1, Samples::U16(samples)).unwrap();
    let map = RectifyMap::from_fn(30, 20, |x, y| (x as f64 + 0.25, y as f64 + 0.5)).unwrap();
    let out = remap(&src, &map, RemapOptions::default()).unwrap();
    for y in 0..20 {
        for x in 0..30 {
            let expected = (x as f64 + 0.25) * 1500.0 + (y as f64 + 0.5) * 100.0;
            assert_eq!(f64::from(u16_samples(&out)[y * 30 + x]), expected);
        }
    }
}

#[test]
fn single_thread_and_all_threads_agree() {
    let map = warp_map(64, 48);
    for channels in [1, 3] {
        let src = texture(64, 48, channels);
        for interpolation in ALL {
            let single = remap(
                &src,
                &map,
                RemapOptions {
                    interpolation,
                    parallelism: Parallelism::Single,
                },
            )
            .unwrap();
            assert_eq!(single, remap(&src, &map, options(interpolation)).unwrap());
        }
    }
}

#[test]
fn mismatched_images_are_rejected() {
    let map = warp_map(20, 10);
    let src = texture(30, 20, 3);
    let mut wrong_size = Image::zeros_u8(20, 11, 3);
    assert!(matches!(
        remap_into(&src, &map, &mut wrong_size, RemapOptions::default()),
        Err(RemapError::DestinationShape { .. })
    ));
    let mut wrong_type = Image {
        width: 20,
        height: 10,
        channels: 3,
        samples: Samples::U16(vec![0; 600]),
    };
    assert!(matches!(
        remap_into(&src, &map, &mut wrong_type, RemapOptions::default()),
        Err(RemapError::DestinationShape { .. })
    ));
    let five = Image::zeros_u8(4, 4, 5);
    assert_eq!(
        remap(&five, &map, RemapOptions::default()),
        Err(RemapError::UnsupportedChannels(5))
    );
    let truncated = Image {
        samples: Samples::U8(vec![0; 10]),
        ..src
    };
    assert!(matches!(
        remap(&truncated, &map, RemapOptions::default()),
        Err(RemapError::SourceSize { actual: 10, .. })
    ));
    let mut dst = Image::zeros_u8(20, 10, 3);
    remap_into(&texture(30, 20, 3), &map, &mut dst, RemapOptions::default()).unwrap();
}

#[test]
fn ros_interpolation_parameter() {
    assert_eq!(
        Interpolation::from_ros_parameter(0),
        Some(Interpolation::Nearest)
    );
    assert_eq!(
        Interpolation::from_ros_parameter(1),
        Some(Interpolation::Bilinear)
    );
    assert_eq!(
        Interpolation::from_ros_parameter(2),
        Some(Interpolation::Bicubic)
    );
    assert_eq!(Interpolation::from_ros_parameter(3), None);
    assert_eq!(Interpolation::from_ros_parameter(-1), None);
}
