//! The one checksum: CRC-32/ISO-HDLC (the zlib / Ethernet CRC). Wire frames, model chunks and
//! model blobs are checked with it; it lives apart from both so neither reaches into the other.

use crc::{CRC_32_ISO_HDLC, Crc};

/// CRC-32/ISO-HDLC, table-driven. A `static` so that its 1 KiB table exists once, in flash.
pub static CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`: the frame check, the model chunks' and the model blob's.
#[must_use]
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_check_value_of_the_standard() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }
}
