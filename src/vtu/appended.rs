//! VTK's appended data section (`<AppendedData encoding="raw">`, the bytes
//! after a `_` marker), each DataArray a [`Block`] at its `offset` from the
//! byte after the marker, with `header_type="UInt64"`:
//!
//! - raw: the array's byte count, then its little-endian values;
//! - zlib (`compressor="vtkZLibDataCompressor"`): a header of the number of
//!   blocks, the uncompressed block size, the uncompressed size of a partial
//!   last block (0 when the last block is full) and each block's compressed
//!   size, then the blocks, each [`ZLIB_BLOCK`] bytes of the values
//!   compressed independently (zlib format), in parallel.

use std::borrow::Cow;
use std::io::{self, Write};

use flate2::write::ZlibEncoder;
use flate2::Compression;
use rayon::prelude::*;

use super::xml::Values;

/// Uncompressed bytes per zlib block.
const ZLIB_BLOCK: usize = 1 << 18;

/// The zlib level: 1, the fastest, leaves our fields about 3% larger than
/// the default level 6 in half its time (docs/output.md).
const ZLIB_LEVEL: u32 = 1;

/// One DataArray's bytes in the appended section: its header of `UInt64`s,
/// then its data.
#[derive(Debug)]
pub(super) struct Block<'a> {
    header: Vec<u64>,
    data: Vec<Cow<'a, [u8]>>,
}

impl<'a> Block<'a> {
    /// The uncompressed block of `values` (borrowing them on a
    /// little-endian machine).
    pub(super) fn raw(values: Values<'a>) -> Block<'a> {
        let bytes = values.le_bytes();
        Block {
            header: vec![bytes.len() as u64],
            data: vec![bytes],
        }
    }

    /// The zlib-compressed block of `values`.
    pub(super) fn zlib(values: Values<'a>) -> io::Result<Block<'a>> {
        let bytes = values.le_bytes();
        let compressed = bytes
            .par_chunks(ZLIB_BLOCK)
            .map(compress)
            .collect::<io::Result<Vec<_>>>()?;
        let mut header = vec![
            compressed.len() as u64,
            ZLIB_BLOCK as u64,
            (bytes.len() % ZLIB_BLOCK) as u64,
        ];
        header.extend(compressed.iter().map(|c| c.len() as u64));
        Ok(Block {
            header,
            data: compressed.into_iter().map(Cow::Owned).collect(),
        })
    }

    /// Bytes in the appended section, header included.
    pub(super) fn len(&self) -> usize {
        8 * self.header.len() + self.data.iter().map(|d| d.len()).sum::<usize>()
    }

    fn write_to(&self, w: &mut impl Write) -> io::Result<()> {
        for h in &self.header {
            w.write_all(&h.to_le_bytes())?;
        }
        for d in &self.data {
            w.write_all(d)?;
        }
        Ok(())
    }
}

/// One zlib stream of `bytes`.
fn compress(bytes: &[u8]) -> io::Result<Vec<u8>> {
    let out = Vec::with_capacity(bytes.len() / 2 + 64);
    let mut e = ZlibEncoder::new(out, Compression::new(ZLIB_LEVEL));
    e.write_all(bytes)?;
    e.finish()
}

/// Writes the appended section holding `blocks` in order (their offsets are
/// the running sums of [`Block::len`]).
pub(super) fn write_section(blocks: &[Block], w: &mut impl Write) -> io::Result<()> {
    w.write_all(b"  <AppendedData encoding=\"raw\">\n   _")?;
    for b in blocks {
        b.write_to(w)?;
    }
    w.write_all(b"\n  </AppendedData>\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::read::ZlibDecoder;
    use std::io::Read;

    #[test]
    fn zlib_header_counts_blocks_and_the_partial_last_one() {
        let values: Vec<f64> = (0..ZLIB_BLOCK / 8 * 2 + 3).map(|i| i as f64).collect();
        let block = Block::zlib(Values::F64(&values)).unwrap();
        assert_eq!(&block.header[..3], &[3, ZLIB_BLOCK as u64, 24]);
        let mut back = Vec::new();
        for (d, &size) in block.data.iter().zip(&block.header[3..]) {
            assert_eq!(d.len() as u64, size);
            ZlibDecoder::new(&d[..]).read_to_end(&mut back).unwrap();
        }
        assert_eq!(back, Values::F64(&values).le_bytes().into_owned());
        let sevens = vec![7; ZLIB_BLOCK];
        let full = Block::zlib(Values::U8(&sevens)).unwrap();
        assert_eq!(&full.header[..3], &[1, ZLIB_BLOCK as u64, 0]);
        let empty = Block::zlib(Values::I32(&[])).unwrap();
        assert_eq!(
            (empty.header.as_slice(), empty.len()),
            (&[0, ZLIB_BLOCK as u64, 0][..], 24)
        );
    }

    #[test]
    fn raw_block_is_the_byte_count_and_the_values() {
        let block = Block::raw(Values::I64(&[1, -1]));
        let mut out = Vec::new();
        block.write_to(&mut out).unwrap();
        assert_eq!(block.len(), 24);
        assert_eq!(&out[..8], &16u64.to_le_bytes());
        assert_eq!(&out[8..16], &1i64.to_le_bytes());
        assert_eq!(&out[16..], &(-1i64).to_le_bytes());
    }
}
