//! The attachment rmw_zenoh puts on every publication and service call: sequence number,
//! source timestamp and the sender's GID, in Zenoh's own serialization (`zenoh-ext`).

use zenoh::bytes::ZBytes;
use zenoh_ext::{z_deserialize, z_serialize};

/// A GID: 16 bytes naming a publisher, subscription or client.
pub type Gid = [u8; 16];

/// What rmw_zenoh attaches to a message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    pub sequence_number: i64,
    /// Nanoseconds since the Unix epoch.
    pub source_timestamp: i64,
    pub source_gid: Gid,
}

impl Attachment {
    pub fn to_zbytes(&self) -> ZBytes {
        z_serialize(&(self.sequence_number, self.source_timestamp, self.source_gid))
    }

    /// `None` when the bytes are not an rmw_zenoh attachment.
    pub fn from_zbytes(bytes: &ZBytes) -> Option<Self> {
        let (sequence_number, source_timestamp, source_gid) = z_deserialize::<(i64, i64, Gid)>(bytes).ok()?;
        Some(Attachment { sequence_number, source_timestamp, source_gid })
    }
}

/// A fresh random GID.
pub fn new_gid() -> Gid {
    rand::random()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_33_bytes_rmw_zenoh_expects() {
        let a = Attachment { sequence_number: 7, source_timestamp: 1_700_000_000_000_000_000, source_gid: [9; 16] };
        let z = a.to_zbytes();
        let bytes = z.to_bytes();
        assert_eq!(bytes.len(), 8 + 8 + 1 + 16);
        assert_eq!(&bytes[..8], &7i64.to_le_bytes());
        assert_eq!(bytes[16], 16, "the GID's length, as a varint");
        assert_eq!(Attachment::from_zbytes(&z), Some(a));
        assert_eq!(Attachment::from_zbytes(&ZBytes::from(vec![1u8, 2, 3])), None);
    }
}
