//! `stereocal pose` on a rendered eye-in-hand bag: one record per image in stamp order
//! with poses near the truth and equal to the stage's, an output bag with every input
//! topic, `<ns>/target_pose` and the poses added to the bag's `/tf`, the camera_info
//! from a file instead of the bag, and clear refusals of bad arguments.

use indicatif::ProgressBar;
use nalgebra::Isometry3;
use stereocal::cli::pose::{PoseArgs, pose_bag};
use stereocal::cli::synth::ModelArg;
use stereocal::pose::record::{FrameRecord, isometry_of, seconds};
use stereocal_msgs::CameraInfoFile;
use stereocal_msgs::geometry_msgs::PoseStamped;
use stereocal_msgs::tf2_msgs::TFMessage;
use stereocal_rosbag::{BagReader, TopicFilter};

use super::{IMAGE_TOPIC, INFO_TOPIC, pose_error, session};

fn isometry(record: &FrameRecord) -> Option<Isometry3<f64>> {
    let FrameRecord::Pose {
        camera_from_target, ..
    } = record
    else {
        return None;
    };
    Some(isometry_of(camera_from_target))
}

#[test]
fn every_image_gets_a_record_and_the_bag_gets_poses_and_tf() {
    let session = session(61, 8, ModelArg::PlumbBob, 0.0, None);
    let board = &session.truth.board;
    let out = session.dir.path().join("poses");
    let args = PoseArgs::chessboard(
        session.bag(),
        out.clone(),
        board.cols,
        board.rows,
        board.square_size,
    );
    let report = pose_bag(&args, &ProgressBar::hidden()).unwrap();

    assert_eq!(report.frames.len(), 8);
    for (index, (record, (image, _))) in report.frames.iter().zip(&session.frames).enumerate() {
        assert_eq!(record.stamp(), seconds(&image.header.stamp));
        let pose = isometry(record).unwrap_or_else(|| panic!("frame {index}: {record:?}"));
        let (deg, mm) = pose_error(&pose, &session.truth_pose(index));
        assert!(deg < 0.05 && mm < 0.5, "frame {index}: {deg} deg, {mm} mm");
    }
    let json = serde_json::to_value(&report).unwrap();
    let first = &json["frames"][0];
    assert_eq!(
        first["camera_from_target"]["rotation"]
            .as_array()
            .unwrap()
            .len(),
        9
    );
    assert_eq!(first["covariance"].as_array().unwrap().len(), 36);
    assert!(first["rms"].as_f64().unwrap() < 0.1);

    let input = BagReader::open(session.bag()).unwrap();
    let output = BagReader::open(&out).unwrap();
    for topic in input.topics() {
        let copied = output.topic(&topic.name).unwrap();
        assert_eq!(copied.type_name, topic.type_name);
    }
    let poses: Vec<PoseStamped> = output
        .messages(&TopicFilter::only(["/camera/target_pose"]))
        .map(|m| m.unwrap().decode().unwrap())
        .collect();
    assert_eq!(poses.len(), 8);
    for (pose, (image, _)) in poses.iter().zip(&session.frames) {
        assert_eq!(pose.header, image.header);
    }
    let tf: Vec<TFMessage> = output
        .messages(&TopicFilter::only(["/tf"]))
        .map(|m| m.unwrap().decode().unwrap())
        .collect();
    let robot = input.topics_message_count(["/tf"]) as usize;
    assert_eq!(
        tf.len(),
        robot + 8,
        "the robot's transforms and the target's, on one /tf"
    );
    let target_tf: Vec<_> = tf
        .iter()
        .flat_map(|m| &m.transforms)
        .filter(|t| t.child_frame_id == "target")
        .collect();
    assert_eq!(target_tf.len(), 8);
    assert!(
        target_tf
            .iter()
            .all(|t| t.header.frame_id == session.frames[0].0.header.frame_id)
    );
    assert_eq!(
        output.topics_message_count([IMAGE_TOPIC, INFO_TOPIC]),
        input.topics_message_count([IMAGE_TOPIC, INFO_TOPIC])
    );
}

#[test]
fn a_camera_info_file_replaces_the_bags() {
    let session = session(62, 3, ModelArg::Equidistant, 0.0, None);
    let board = &session.truth.board;
    let file = session.dir.path().join("camera.yaml");
    CameraInfoFile {
        camera_name: "camera".to_owned(),
        info: session.frames[0].1.clone(),
    }
    .write(&file)
    .unwrap();
    let from_bag = pose_bag(
        &PoseArgs::chessboard(
            session.bag(),
            session.dir.path().join("a"),
            board.cols,
            board.rows,
            board.square_size,
        ),
        &ProgressBar::hidden(),
    )
    .unwrap();
    let from_file = pose_bag(
        &PoseArgs {
            camera_info: Some(file),
            ..PoseArgs::chessboard(
                session.bag(),
                session.dir.path().join("b"),
                board.cols,
                board.rows,
                board.square_size,
            )
        },
        &ProgressBar::hidden(),
    )
    .unwrap();
    assert_eq!(from_bag.frames, from_file.frames);
    assert!(from_bag.frames.iter().all(|f| isometry(f).is_some()));
}

#[test]
fn bad_arguments_are_refused_with_the_reason() {
    let session = session(63, 1, ModelArg::PlumbBob, 0.0, None);
    let board = &session.truth.board;
    let args = |out: &str| {
        PoseArgs::chessboard(
            session.bag(),
            session.dir.path().join(out),
            board.cols,
            board.rows,
            board.square_size,
        )
    };
    let refuse =
        |args: PoseArgs| format!("{:#}", pose_bag(&args, &ProgressBar::hidden()).unwrap_err());

    let e = refuse(PoseArgs {
        topic: Some("/nope".to_owned()),
        ..args("x")
    });
    assert!(
        e.contains("no image topic /nope") && e.contains(IMAGE_TOPIC),
        "{e}"
    );
    let e = refuse(PoseArgs {
        max_reprojection_error: -1.0,
        ..args("x")
    });
    assert!(e.contains("--max-reprojection-error"), "{e}");
    let e = refuse(PoseArgs {
        size: "9".to_owned(),
        ..args("x")
    });
    assert!(e.contains("size"), "{e}");
    pose_bag(&args("once"), &ProgressBar::hidden()).unwrap();
    let e = refuse(args("once"));
    assert!(e.contains("exists"), "{e}");
}
