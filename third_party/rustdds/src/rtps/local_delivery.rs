//! Readers that the application hands a writer's samples itself, inside the process
//! (see PATCHES.md): a writer of this process never sends them its samples over the
//! network. The application installs one predicate for the whole process.

use std::sync::OnceLock;

use crate::GUID;

type Predicate = dyn Fn(GUID, GUID) -> bool + Send + Sync;

static DELIVERED_LOCALLY: OnceLock<Box<Predicate>> = OnceLock::new();

/// Installs `delivered_locally(writer, reader)`: true when the application delivers
/// the samples of the local writer `writer` to the reader `reader` itself. Such a
/// reader is not matched with the writer (and unmatched if it was), so the writer
/// sends it nothing. Only the first call installs; later calls return false.
pub fn set_local_delivery(
  delivered_locally: impl Fn(GUID, GUID) -> bool + Send + Sync + 'static,
) -> bool {
  DELIVERED_LOCALLY.set(Box::new(delivered_locally)).is_ok()
}

/// Whether the application delivers `writer`'s samples to `reader` itself.
pub(crate) fn delivered_locally(writer: GUID, reader: GUID) -> bool {
  DELIVERED_LOCALLY
    .get()
    .is_some_and(|predicate| predicate(writer, reader))
}
