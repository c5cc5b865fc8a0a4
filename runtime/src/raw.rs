//! A message of any type as its CDR bytes, so that a recorded sample can be published
//! again without knowing its type (a bag replay).

use serde::ser::{Serialize, SerializeTuple, Serializer};

/// Length of the CDR encapsulation header that starts every serialized sample.
const HEADER_LEN: usize = 4;

/// The body of a little-endian CDR sample. Serialized as its bytes one after the other
/// (a tuple of octets has no length and no alignment in CDR), it puts exactly those
/// bytes on the wire behind the publisher's own encapsulation header.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RawCdr {
    body: Vec<u8>,
}

impl RawCdr {
    /// The body of `sample`, a serialized message with its encapsulation header; a
    /// sample that is not little-endian plain CDR is refused (its body could not be
    /// carried under a little-endian header without knowing its type).
    pub fn from_sample(sample: &[u8]) -> Result<Self, String> {
        match sample {
            [0x00, 0x01, _, _, body @ ..] => Ok(RawCdr {
                body: body.to_vec(),
            }),
            [a, b, _, _, ..] => Err(format!(
                "encapsulation {a:#04x}{b:02x} is not little-endian plain CDR (0x0001)"
            )),
            _ => Err(format!(
                "{} bytes is shorter than the {HEADER_LEN}-byte CDR header",
                sample.len()
            )),
        }
    }
}

impl Serialize for RawCdr {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut octets = serializer.serialize_tuple(self.body.len())?;
        for byte in &self.body {
            octets.serialize_element(byte)?;
        }
        octets.end()
    }
}

#[cfg(test)]
mod tests {
    use stereocal_msgs::cdr;
    use stereocal_msgs::std_msgs::{Header, String as RosString};

    use super::*;

    #[test]
    fn a_sample_is_serialized_again_byte_for_byte() -> Result<(), String> {
        for sample in [
            cdr::to_bytes(&RosString {
                data: "odd length".into(),
            }),
            cdr::to_bytes(&Header {
                frame_id: "cam".into(),
                ..Header::default()
            }),
        ] {
            let sample = sample.map_err(|e| e.to_string())?;
            let raw = RawCdr::from_sample(&sample)?;
            assert_eq!(cdr::to_bytes(&raw).map_err(|e| e.to_string())?, sample);
        }
        Ok(())
    }

    #[test]
    fn samples_it_cannot_carry_are_refused() {
        assert!(RawCdr::from_sample(&[0x00, 0x00, 0, 0, 1]).is_err_and(|e| e.contains("0x0000")));
        assert!(RawCdr::from_sample(&[0x00]).is_err_and(|e| e.contains("shorter")));
    }
}
