//! Hand-eye calibration of a recorded or live session: robot poses paired with target
//! poses by stamp (through [`crate::tf_buffer`]), every method of `vision::handeye` run
//! on the pairs, and
//! the result as one serializable report ([`report`]) that `stereocal handeye --json`
//! prints, `handeye.yaml` holds and `report.html` ([`page`]) shows; a live session's
//! samples are kept on disk the moment they are taken ([`store`]).

pub mod node;
pub mod page;
pub mod report;
pub mod robot;
pub mod session;
pub mod settings;
pub mod status;
pub mod store;
pub mod worker;
