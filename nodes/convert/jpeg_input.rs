//! The input zune-jpeg reads a JPEG from: the message's bytes, as a slice.
//!
//! zune-jpeg reads through its `ZByteReaderTrait`. Its own `ZCursor` reaches that trait
//! through the blanket implementation for `std::io::BufRead + Seek`, so each 4-byte
//! refill of the Huffman decoder's bit buffer is a `read` loop around a `memcpy` call,
//! and the bit buffer goes through memory around it. Reading the slice directly keeps
//! the refill a bounds check and a 4-byte load. The positions and errors are those of
//! `ZCursor`, so the decoder behaves the same on every input, damaged ones included.

use zune_jpeg::zune_core::bytestream::{ZByteIoError, ZByteReaderTrait, ZSeekFrom};

/// A byte slice and a read position, which may lie past the end (reads there find
/// nothing, as `ZCursor`'s do).
pub struct JpegInput<'a> {
    data: &'a [u8],
    position: usize,
}

impl<'a> JpegInput<'a> {
    /// Reading `data` from its start.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data, position: 0 }
    }

    /// The bytes from the position on (none when it is past the end).
    #[inline(always)]
    fn rest(&self) -> &'a [u8] {
        self.data.get(self.position..).unwrap_or_default()
    }
}

impl ZByteReaderTrait for JpegInput<'_> {
    #[inline(always)]
    fn read_byte_no_error(&mut self) -> u8 {
        match self.data.get(self.position) {
            Some(&byte) => {
                self.position += 1;
                byte
            }
            None => 0,
        }
    }

    #[inline(always)]
    fn read_exact_bytes(&mut self, buf: &mut [u8]) -> Result<(), ZByteIoError> {
        self.peek_exact_bytes(buf)?;
        self.position += buf.len();
        Ok(())
    }

    #[inline(always)]
    fn read_bytes(&mut self, buf: &mut [u8]) -> Result<usize, ZByteIoError> {
        let read = self.peek_bytes(buf)?;
        self.position += read;
        Ok(read)
    }

    #[inline(always)]
    fn peek_bytes(&mut self, buf: &mut [u8]) -> Result<usize, ZByteIoError> {
        let rest = self.rest();
        let read = rest.len().min(buf.len());
        buf[..read].copy_from_slice(&rest[..read]);
        Ok(read)
    }

    #[inline(always)]
    fn peek_exact_bytes(&mut self, buf: &mut [u8]) -> Result<(), ZByteIoError> {
        let rest = self.rest();
        let bytes = rest
            .get(..buf.len())
            .ok_or(ZByteIoError::NotEnoughBytes(rest.len(), buf.len()))?;
        buf.copy_from_slice(bytes);
        Ok(())
    }

    fn z_seek(&mut self, from: ZSeekFrom) -> Result<u64, ZByteIoError> {
        let (base, offset) = match from {
            ZSeekFrom::Start(position) => {
                self.position = usize::try_from(position)?;
                return Ok(position);
            }
            ZSeekFrom::End(offset) => (self.data.len(), offset),
            ZSeekFrom::Current(offset) => (self.position, offset),
        };
        let position = isize::try_from(offset)
            .ok()
            .and_then(|offset| base.checked_add_signed(offset))
            .ok_or_else(|| ZByteIoError::from(std::io::Error::other("Negative seek")))?;
        self.position = position;
        Ok(position as u64)
    }

    #[inline(always)]
    fn is_eof(&mut self) -> Result<bool, ZByteIoError> {
        Ok(self.position >= self.data.len())
    }

    fn z_position(&mut self) -> Result<u64, ZByteIoError> {
        Ok(self.position as u64)
    }

    fn read_remaining(&mut self, sink: &mut Vec<u8>) -> Result<usize, ZByteIoError> {
        let rest = self.rest();
        sink.extend_from_slice(rest);
        self.position += rest.len();
        Ok(rest.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use zune_jpeg::zune_core::bytestream::ZCursor;

    /// Every read, peek and seek of the trait, from every position (past the end
    /// included), gives the same bytes, position and outcome as `ZCursor`.
    #[test]
    fn reads_as_zcursor_does() {
        let data: Vec<u8> = (0..23u8).collect();
        // The bytes a read gives; after an error, only the error counts.
        let outcome = |reader: &mut dyn FnMut(&mut [u8]) -> String| {
            let mut buf = [0u8; 9];
            let said = reader(&mut buf);
            if said.starts_with("Err") {
                said
            } else {
                format!("{said} {buf:?}")
            }
        };
        for start in 0..30u64 {
            for len in [0usize, 1, 4, 9] {
                let mut ours = JpegInput::new(&data);
                let mut theirs = ZCursor::new(&data[..]);
                let mut seen = Vec::new();
                for reader in [
                    &mut ours as &mut dyn ZByteReaderTrait,
                    &mut theirs as &mut dyn ZByteReaderTrait,
                ] {
                    let mut log = vec![format!("{:?}", reader.z_seek(ZSeekFrom::Start(start)))];
                    log.push(outcome(&mut |buf| {
                        format!("{:?}", reader.read_exact_bytes(&mut buf[..len]))
                    }));
                    log.push(format!("{:?}", reader.z_position()));
                    log.push(outcome(&mut |buf| {
                        format!("{:?}", reader.peek_exact_bytes(&mut buf[..len]))
                    }));
                    log.push(outcome(&mut |buf| {
                        format!("{:?}", reader.peek_bytes(&mut buf[..len]))
                    }));
                    log.push(outcome(&mut |buf| {
                        format!("{:?}", reader.read_bytes(&mut buf[..len]))
                    }));
                    log.push(format!("{}", reader.read_byte_no_error()));
                    log.push(format!("{:?}", reader.is_eof()));
                    log.push(format!("{:?}", reader.z_seek(ZSeekFrom::Current(-5))));
                    log.push(format!("{:?}", reader.z_seek(ZSeekFrom::End(-3))));
                    log.push(format!("{:?}", reader.z_seek(ZSeekFrom::Current(-40))));
                    let mut rest = Vec::new();
                    let read = reader.read_remaining(&mut rest);
                    log.push(format!("{read:?} {rest:?}"));
                    log.push(format!("{:?}", reader.z_position()));
                    seen.push(log);
                }
                assert_eq!(seen[0], seen[1], "from {start}, {len} bytes");
            }
        }
    }
}
