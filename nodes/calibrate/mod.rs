//! Calibration: the [`stage`] turns target corners into calibrated cameras and a stereo
//! pair; `stereocal calibrate` feeds it every frame of a bag, [`node`] (`calibrate_node`,
//! its [`settings`] and [`worker`]) a live [`session`] that keeps the samples adding
//! coverage. Both judge a frame's sharpness and motion with the same checks
//! (`stereocal_vision::calib::quality`; [`offline`] for every frame of a bag). The [`result`] is the one schema every output
//! reads (`--json`, the node's [`status`], the human summary, the report); [`advice`]
//! warns about a result not to trust blindly, and [`report`] writes `report.html`.

pub mod advice;
pub mod node;
pub mod offline;
pub mod report;
pub mod result;
pub mod session;
pub mod settings;
pub mod stage;
pub mod status;
pub mod worker;
