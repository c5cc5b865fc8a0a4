//! Hand-eye calibration of a recorded or live session: robot poses paired with target
//! poses by stamp (through [`crate::tf_buffer`]; live, [`robot`]), every method of
//! `vision::handeye` and the joint refinement run on the pairs ([`session`]), and the
//! result as one serializable report ([`report`]) that `stereocal handeye --json`
//! prints, `handeye.yaml` holds and `report.html` ([`page`]) shows. The live session is
//! `handeye_node` ([`node`], its [`settings`], [`worker`] and [`status`]), whose samples
//! are kept on disk the moment they are taken ([`store`]).

pub mod node;
pub mod page;
pub mod report;
pub mod robot;
pub mod session;
pub mod settings;
pub mod status;
pub mod store;
pub mod worker;
