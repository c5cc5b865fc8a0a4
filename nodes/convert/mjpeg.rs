//! MJPEG frames without Huffman tables. Many UVC cameras leave the DHT segments out of
//! their MJPEG frames: motion JPEG uses the standard tables of JPEG's Annex K, which
//! the decoder must supply. zune-jpeg supplies them for a frame marked as motion JPEG
//! (an APP0 segment `AVI1`); a frame with neither tables nor that mark gets the mark.

use std::borrow::Cow;

/// APP0 segment of motion JPEG: marker, length 7, `AVI1\0`.
const AVI1_SEGMENT: [u8; 9] = [0xff, 0xe0, 0x00, 0x07, b'A', b'V', b'I', b'1', 0x00];

/// What the segments before the scan hold.
#[derive(Default)]
struct Header {
    huffman_tables: bool,
    avi1: bool,
}

/// Reads the marker segments of `jpeg` up to its first scan (or where they stop making
/// sense: the decoder then reports the damage).
fn header(jpeg: &[u8]) -> Header {
    let mut found = Header::default();
    let mut at = 2;
    while let (Some(&0xff), Some(&marker)) = (jpeg.get(at), jpeg.get(at + 1)) {
        // Start of scan, or a marker without a length (SOI, EOI, RST, fill bytes).
        if marker == 0xda || marker == 0xd8 || marker == 0xd9 || marker == 0xff {
            break;
        }
        let Some(length) = jpeg
            .get(at + 2..at + 4)
            .map(|b| usize::from(u16::from_be_bytes([b[0], b[1]])))
        else {
            break;
        };
        match marker {
            0xc4 => found.huffman_tables = true,
            0xe0 => found.avi1 |= jpeg.get(at + 4..at + 8) == Some(b"AVI1"),
            _ => {}
        }
        at += 2 + length;
    }
    found
}

/// `jpeg` as it is when it has Huffman tables or the motion JPEG mark; otherwise a copy
/// with the mark after its start-of-image marker, so that it decodes with the
/// standard tables.
pub fn with_standard_tables_marked(jpeg: &[u8]) -> Cow<'_, [u8]> {
    let found = header(jpeg);
    if found.huffman_tables || found.avi1 || !jpeg.starts_with(&[0xff, 0xd8]) {
        return Cow::Borrowed(jpeg);
    }
    let mut marked = Vec::with_capacity(jpeg.len() + AVI1_SEGMENT.len());
    marked.extend_from_slice(&jpeg[..2]);
    marked.extend_from_slice(&AVI1_SEGMENT);
    marked.extend_from_slice(&jpeg[2..]);
    Cow::Owned(marked)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_frames_without_tables_or_mark_are_marked() {
        // SOI, a DQT segment of length 4, SOS.
        let bare = [0xff, 0xd8, 0xff, 0xdb, 0x00, 0x04, 0x00, 0x00, 0xff, 0xda];
        let marked = with_standard_tables_marked(&bare);
        assert_eq!(&marked[2..11], &AVI1_SEGMENT);
        assert_eq!(&marked[11..], &bare[2..]);
        assert!(matches!(
            with_standard_tables_marked(&marked),
            Cow::Borrowed(_)
        ));
        let with_tables = [0xff, 0xd8, 0xff, 0xc4, 0x00, 0x02, 0xff, 0xda];
        assert!(matches!(
            with_standard_tables_marked(&with_tables),
            Cow::Borrowed(_)
        ));
        assert!(matches!(
            with_standard_tables_marked(b"not a jpeg"),
            Cow::Borrowed(_)
        ));
    }
}
