//! The CDR codec of recorded messages: ROS 2 messages to and from CDR
//! behind the encapsulation header.

use byteorder::LittleEndian;
use serde::Serialize;

/// CDR little endian, plain (XCDR1) encapsulation, no options.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// `data` in CDR (little endian) behind the encapsulation header, appended
/// to `buf`.
pub fn to_cdr_into<T: Serialize>(buf: &mut Vec<u8>, msg: &T) -> Result<(), String> {
    buf.extend_from_slice(&CDR_LE_HEADER);
    // alignment counts from the first byte after the header
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut *buf, msg)
        .map_err(|e| format!("CDR serialization: {e}"))
}

/// A message in CDR (little endian) with the encapsulation header.
pub fn to_cdr<T: Serialize>(msg: &T) -> Result<Vec<u8>, String> {
    let mut buf = Vec::with_capacity(64);
    to_cdr_into(&mut buf, msg)?;
    Ok(buf)
}

/// A message from CDR with the encapsulation header (little or big endian).
pub fn from_cdr<T: serde::de::DeserializeOwned>(data: &[u8]) -> Result<T, String> {
    let (head, body) = data
        .split_at_checked(4)
        .ok_or("CDR: shorter than the encapsulation header")?;
    let r = match head[..2] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        _ => return Err(format!("CDR: unsupported encapsulation {head:02x?}")),
    };
    r.map(|(v, _)| v).map_err(|e| format!("CDR: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc_msgs::{Header, JointState, PointCloud2, Time};

    #[test]
    fn joint_state_cdr_is_byte_exact() {
        let js = JointState {
            header: Header {
                stamp: Time {
                    sec: 1_700_000_000,
                    nanosec: 5,
                },
                frame_id: String::new(),
            },
            name: vec!["joint1".into(), "j2".into()],
            position: vec![0.25, -1.0],
            velocity: vec![],
            effort: vec![],
        };
        #[rustfmt::skip]
        let want: Vec<u8> = vec![
            0x00, 0x01, 0x00, 0x00,                   // encapsulation: CDR_LE
            0x00, 0xf1, 0x53, 0x65,                   //  0 stamp.sec 1_700_000_000
            0x05, 0x00, 0x00, 0x00,                   //  4 stamp.nanosec
            0x01, 0x00, 0x00, 0x00, 0x00,             //  8 frame_id "" (length 1: the NUL)
            0x00, 0x00, 0x00,                         // 13 padding to 16
            0x02, 0x00, 0x00, 0x00,                   // 16 name: 2 strings
            0x07, 0x00, 0x00, 0x00,                   // 20 "joint1" length 7
            b'j', b'o', b'i', b'n', b't', b'1', 0x00, // 24
            0x00,                                     // 31 padding to 32
            0x03, 0x00, 0x00, 0x00,                   // 32 "j2" length 3
            b'j', b'2', 0x00,                         // 36
            0x00,                                     // 39 padding to 40
            0x02, 0x00, 0x00, 0x00,                   // 40 position: 2 doubles
            0x00, 0x00, 0x00, 0x00,                   // 44 padding to 48 (8-byte alignment
                                                      //    counts from the body, not the file)
            0, 0, 0, 0, 0, 0, 0xd0, 0x3f,             // 48 0.25
            0, 0, 0, 0, 0, 0, 0xf0, 0xbf,             // 56 -1.0
            0x00, 0x00, 0x00, 0x00,                   // 64 velocity: empty
            0x00, 0x00, 0x00, 0x00,                   // 68 effort: empty
        ];
        assert_eq!(to_cdr(&js).unwrap(), want);
        assert_eq!(from_cdr::<JointState>(&want).unwrap(), js);
    }

    #[test]
    fn bool_then_u32_is_aligned() {
        #[derive(Serialize)]
        struct S {
            a: bool,
            b: u32,
            c: u8,
            d: f64,
        }
        let got = to_cdr(&S {
            a: true,
            b: 7,
            c: 3,
            d: 2.0,
        })
        .unwrap();
        #[rustfmt::skip]
        let want = [
            0x00, 0x01, 0x00, 0x00,
            0x01, 0x00, 0x00, 0x00,  // 0 bool, padding to 4
            0x07, 0x00, 0x00, 0x00,  // 4 u32
            0x03, 0, 0, 0, 0, 0, 0, 0, // 8 u8, padding to 16
            0, 0, 0, 0, 0, 0, 0x00, 0x40, // 16 2.0
        ];
        assert_eq!(got, want);
        // the real case: PointCloud2's `bool is_bigendian` then `uint32 point_step`
        let pc = PointCloud2 {
            is_bigendian: false,
            point_step: 12,
            ..Default::default()
        };
        let b = to_cdr(&pc).unwrap();
        // header (8 + 4 + 1 → 16 with padding), height, width, fields count → 28,
        // bool at 28, point_step at 32
        assert_eq!(&b[4 + 28..4 + 36], &[0, 0, 0, 0, 12, 0, 0, 0]);
    }
}
