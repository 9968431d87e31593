//! The shape of a file decoded in bands (`io::bands`), from its header alone, and the rows of
//! a band as planes: apart from `bands`, so the band readers of each format (`exr::stream`,
//! `rgbe::stream`) name them without importing the module that names them.

/// What decoding a file in bands takes, from its header alone: jobs plan their memory with it
/// before the file is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// The most lines one block holds: bands are a multiple of it (1 for .hdr's scanlines).
    pub block_lines: usize,
    /// The file's size: it is read whole before its bands are decoded.
    pub file_bytes: u64,
}

impl Shape {
    /// The band of rows for folds that want at least `lines` rows: a power of two, a
    /// multiple of the blocks.
    pub fn band_lines(&self, lines: usize) -> usize {
        self.block_lines.next_power_of_two().max(lines)
    }

    /// Bytes in use while its bands of `lines` rows are decoded on every thread: the file,
    /// and for each thread a band's texels and its decompressed samples (at most as many
    /// bytes again).
    pub fn decode_bytes(&self, lines: usize) -> u64 {
        let band = (lines * self.width) as u64 * 32;
        let threads = rayon::current_num_threads() as u64;
        self.file_bytes.saturating_add(threads.saturating_mul(band))
    }
}

/// A band's rows decoded one at a time, each as four planes (R, G, B, A: alpha 1 where the
/// file has none), for a fold that reduces each row while it is in cache.
pub trait Rows {
    /// Decodes the band's next row into `planes` (four times the width, a plane after
    /// another); zeros after a decoding error, which the map then returns.
    fn next_into(&mut self, planes: &mut [f32]);
}
