//! The GLB container (glTF 2.0 specification, "Binary glTF Layout"): a 12-byte header
//! (magic, version, total length), then chunks of a length, a type and data. The first chunk
//! is the JSON, padded with spaces to a multiple of 4 bytes; the second, optional, is the
//! binary buffer, padded with zeros. Every length is a little-endian `u32` and includes the
//! padding, so that each chunk starts 4-byte aligned.

use std::io::Write;

use super::GltfError;

/// `glTF` in ASCII, read as a little-endian `u32`.
pub const MAGIC: u32 = 0x4654_6C67;
/// The GLB container version of glTF 2.0.
pub const VERSION: u32 = 2;
/// The JSON chunk's type, `JSON` in ASCII.
pub const CHUNK_JSON: u32 = 0x4E4F_534A;
/// The binary chunk's type, `BIN\0` in ASCII.
pub const CHUNK_BIN: u32 = 0x004E_4942;

const HEADER: u64 = 12;
const CHUNK_HEADER: u64 = 8;

/// `n` rounded up to a multiple of 4.
pub(super) fn padded(n: u64) -> u64 {
    n.div_ceil(4).saturating_mul(4)
}

/// The file's total length for a JSON of `json` bytes and a buffer of `bin` bytes (no BIN
/// chunk when empty), if it fits the header's `u32`.
pub(super) fn length(json: u64, bin: u64) -> Result<u32, GltfError> {
    let bin_chunk = if bin == 0 { 0 } else { CHUNK_HEADER.saturating_add(padded(bin)) };
    let bytes = (HEADER + CHUNK_HEADER).saturating_add(padded(json)).saturating_add(bin_chunk);
    u32::try_from(bytes).map_err(|_| GltfError::TooLarge { bytes, limit: u32::MAX as u64 })
}

/// Writes the container: header, JSON chunk, BIN chunk when `bin` is not empty.
pub(super) fn write<W: Write>(w: &mut W, json: &[u8], bin: &[u8]) -> Result<(), GltfError> {
    let total = length(json.len() as u64, bin.len() as u64)?;
    w.write_all(&MAGIC.to_le_bytes())?;
    w.write_all(&VERSION.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    chunk(w, CHUNK_JSON, json, b' ')?;
    if !bin.is_empty() {
        chunk(w, CHUNK_BIN, bin, 0)?;
    }
    Ok(())
}

/// One chunk; its length fits `u32` as the total did.
fn chunk<W: Write>(w: &mut W, kind: u32, data: &[u8], pad: u8) -> Result<(), GltfError> {
    let len = padded(data.len() as u64);
    w.write_all(&(len as u32).to_le_bytes())?;
    w.write_all(&kind.to_le_bytes())?;
    w.write_all(data)?;
    w.write_all(&[pad; 3][..(len - data.len() as u64) as usize])?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u32_at(b: &[u8], at: usize) -> u32 {
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
    }

    #[test]
    fn chunks_are_padded_and_lengths_count_the_padding() {
        let mut out = Vec::new();
        write(&mut out, b"{\"a\":1}", &[1, 2, 3, 4, 5]).unwrap();
        assert_eq!(&out[..4], b"glTF");
        assert_eq!(u32_at(&out, 4), 2);
        assert_eq!(u32_at(&out, 8) as usize, out.len());
        assert_eq!(u32_at(&out, 12), 8, "7 bytes of JSON padded to 8");
        assert_eq!(&out[16..20], b"JSON");
        assert_eq!(&out[20..28], b"{\"a\":1} ");
        assert_eq!(u32_at(&out, 28), 8, "5 bytes of buffer padded to 8");
        assert_eq!(&out[32..36], b"BIN\0");
        assert_eq!(&out[36..44], &[1, 2, 3, 4, 5, 0, 0, 0]);
        assert_eq!(out.len(), 44);
    }

    #[test]
    fn an_empty_buffer_has_no_bin_chunk() {
        let mut out = Vec::new();
        write(&mut out, b"{}", &[]).unwrap();
        assert_eq!(out.len(), 24);
        assert_eq!(u32_at(&out, 8), 24);
        assert_eq!(&out[20..24], b"{}  ");
    }

    #[test]
    fn files_over_4_gib_are_refused() {
        let max = u32::MAX as u64;
        // Header, two chunk headers and a 4-byte JSON leave this much for the buffer.
        let room = (max - 12 - 8 - 4 - 8) & !3;
        assert_eq!(length(4, room).unwrap() as u64, 12 + 8 + 4 + 8 + room);
        assert!(matches!(length(4, room + 1), Err(GltfError::TooLarge { .. })));
        assert!(matches!(length(max, 0), Err(GltfError::TooLarge { .. })));
        assert!(matches!(length(0, u64::MAX), Err(GltfError::TooLarge { .. })), "no overflow");
    }
}
