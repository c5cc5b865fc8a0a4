//! Target pose: the pose `camera_from_target` of a calibration target in each image,
//! as `pose_node` publishes it and `stereocal pose` computes it for a whole bag, with the
//! same [`stage`].

pub mod annotate;
pub mod node;
pub mod record;
pub mod stage;
pub mod status;
