//! Containment of the detector libraries we build on: a panic inside one of them (a
//! bug met on some unusual image) reads as "no target found in this image", so one
//! strange frame never stops a node or a whole calibration.

use std::panic::{AssertUnwindSafe, catch_unwind};

/// Runs `search`; its result, or `None` when it panics.
pub(crate) fn contained<T>(search: impl FnOnce() -> Option<T>) -> Option<T> {
    // Nothing `search` borrows is used again after a panic but to return `None`.
    catch_unwind(AssertUnwindSafe(search)).ok().flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panicking_search_finds_nothing() {
        assert_eq!(contained(|| Some(3)), Some(3));
        assert_eq!(contained::<u8>(|| None), None);
        let indices: Vec<usize> = Vec::new();
        assert_eq!(contained(|| Some(indices[1])), None);
    }
}
