//! Buffers of 16-bit values whose first value is 32-byte aligned, for the AVX2 kernels'
//! loads and stores.

/// Alignment of the first value, bytes.
const ALIGN: usize = 32;

/// A growable buffer of `u16` starting on a 32-byte boundary.
#[derive(Default)]
pub(crate) struct AlignedBuffer {
    storage: Vec<u16>,
    offset: usize,
    len: usize,
}

impl AlignedBuffer {
    /// Makes the buffer `len` values long. Values kept from before are unspecified.
    pub(crate) fn resize(&mut self, len: usize) {
        let spare = ALIGN / size_of::<u16>();
        if self.storage.len() < len + spare {
            self.storage = vec![0; len + spare];
        }
        self.offset = self.storage.as_ptr().align_offset(ALIGN).min(spare);
        self.len = len;
    }

    /// The values.
    pub(crate) fn as_slice(&self) -> &[u16] {
        &self.storage[self.offset..self.offset + self.len]
    }

    /// The values, mutably.
    pub(crate) fn as_mut_slice(&mut self) -> &mut [u16] {
        &mut self.storage[self.offset..self.offset + self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_value_is_aligned_at_every_size() {
        let mut buffer = AlignedBuffer::default();
        for len in [1, 17, 1000, 3, 4096] {
            buffer.resize(len);
            assert_eq!(buffer.as_slice().len(), len);
            assert_eq!(buffer.as_mut_slice().as_ptr() as usize % ALIGN, 0);
        }
    }
}
