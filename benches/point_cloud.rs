//! Time of `point_cloud_node`'s work per frame at 1280x720: a DisparityImage, its left
//! image and the camera_infos in, the organized PointCloud2 out, in stereo_image_proc's
//! default layout (colour, padded to 32 bytes a point) and the tightest one.
// A benchmark on fixed inputs: an input that fails is a bug to see at once.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use stereocal::cli::synth_depth::rectified_pair;
use stereocal::convert::{Encoding, info_from_calibrated, msg_from_image};
use stereocal::depth::cloud::CloudLayout;
use stereocal::depth::point_cloud_node::cloud_msg;
use stereocal::depth::stage::{DepthStage, disparity_msg};
use stereocal_msgs::std_msgs::Header;
use stereocal_vision::stereo::SgmParams;
use stereocal_vision::synth::depth::{DepthRig, DepthScene, PairPhotometry};

fn point_cloud(c: &mut Criterion) {
    let rig = DepthRig::WEBCAMS.with_size(1280, 720);
    let pair = DepthScene::standard(rig, 1).render(&PairPhotometry::realistic(), 1);
    let [left_camera, right_camera] = rectified_pair(&rig);
    let left_info = info_from_calibrated(&left_camera, Header::default());
    let right_info = info_from_calibrated(&right_camera, Header::default());
    let left = msg_from_image(&pair.left, Encoding::Mono8, Header::default()).unwrap();
    let right = msg_from_image(&pair.right, Encoding::Mono8, Header::default()).unwrap();
    let frame = DepthStage::new(SgmParams::default())
        .disparity(&left, &left_info, &right, &right_info)
        .unwrap();
    let disparity = disparity_msg(&frame, Header::default());

    let mut group = c.benchmark_group("point_cloud_1280x720");
    for (name, layout) in [
        (
            "color_padded",
            CloudLayout {
                color: true,
                avoid_padding: false,
            },
        ),
        (
            "xyz_packed",
            CloudLayout {
                color: false,
                avoid_padding: true,
            },
        ),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                black_box(
                    cloud_msg(
                        black_box(&left),
                        &disparity,
                        &left_info,
                        &right_info,
                        layout,
                    )
                    .unwrap(),
                )
            });
        });
    }
    group.finish();
}

criterion_group!(benches, point_cloud);
criterion_main!(benches);
