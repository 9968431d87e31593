//! The common OpenEXR layout (one scan-line part, R G B and maybe A as half or full floats)
//! decoded a block per task, straight into the image's rows. ZIP and RLE blocks are unpacked
//! here: libdeflate inflates (about 3x faster than the crate's inflater), then OpenEXR's byte
//! predictor is undone in place and the samples are read from the two halves the encoder
//! split each block's bytes into, with no copy of the block to interleave them. PIZ and ZSTD
//! have their own modules; the other compressions (PXR24, B44, DWAA, DWAB) go through the
//! crate's decompressor, a block per task likewise.

use super::checks::RawChunk;
use super::{guarded, Layout};
use crate::image::Image;
use exr::block::UncompressedBlock;
use exr::meta::MetaData;
use exr::prelude::*;
use glam::Vec4;
use rayon::prelude::*;

/// What each thread keeps between blocks: its inflater and buffers, grown to the largest
/// block it met.
pub(super) struct Scratch {
    pub unpack: Unpack,
    pub floats: Vec<f32>,
    pub halves: Vec<f16>,
}

/// A thread's decompressors and the buffers a block is unpacked into.
pub(super) struct Unpack {
    inflate: libdeflater::Decompressor,
    piz: super::piz::Scratch,
    zstd: Option<zstd::bulk::Decompressor<'static>>,
    inner: Vec<u8>,
    bytes: Vec<u8>,
}

impl Unpack {
    pub(super) fn new() -> Self {
        Unpack {
            inflate: libdeflater::Decompressor::new(),
            piz: Default::default(),
            zstd: None,
            inner: Vec::new(),
            bytes: Vec::new(),
        }
    }
}

/// A decompressed block's samples: as stored (for each line, each channel's samples in
/// little-endian order), or as ZIP and RLE leave them once the predictor is undone: the
/// bytes at even offsets of the stored form, then those at odd offsets.
#[derive(Clone, Copy)]
pub(super) enum Samples<'a> {
    Plain(&'a [u8]),
    Split(&'a [u8]),
}

/// The layer's texels from `chunks` (those `read_chunks` checked: each block of the layer
/// once), each block decompressed and converted in parallel into its own rows. With
/// `sanitize`, each line is then sanitized while it is in cache (see `Image::sanitize`), and
/// the count of values replaced comes back; the image is otherwise as stored. `zstd`: the
/// header says uncompressed, the chunks are ZSTD (see `read_meta`).
pub(super) fn decode_blocks(
    meta: &MetaData,
    layout: &Layout,
    chunks: Vec<RawChunk>,
    sanitize: bool,
    zstd: bool,
) -> std::result::Result<(Image, usize), String> {
    let header = &meta.headers[0];
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    // Blocks in row order, each with its rows.
    let mut blocks: Vec<(usize, usize, RawChunk)> = chunks
        .into_iter()
        .map(|c| (c.bounds.position.1 as usize, c.bounds.size.1, c))
        .collect();
    blocks.sort_by_key(|b| b.0);
    let mut next = 0;
    for (y, lines, _) in &blocks {
        if *y != next {
            return Err(format!("scan lines {next} to {y} are missing"));
        }
        next += lines;
    }
    if next != h {
        return Err(format!("scan lines {next} to {h} are missing"));
    }
    let block = Block::new(meta, layout, zstd);
    let mut img = Image::new(w, h);
    let mut rest = img.pixels.as_mut_slice();
    let mut jobs = Vec::with_capacity(blocks.len());
    for (y, lines, chunk) in blocks {
        let (rows, tail) = rest.split_at_mut(lines * w);
        rest = tail;
        jobs.push((y, chunk, rows));
    }
    let replaced = jobs
        .into_par_iter()
        .map_init(scratch(w), |s, (y, chunk, rows)| {
            block.decode(s, y, &chunk, rows, sanitize)
        })
        .try_reduce(|| 0, |a, b| Ok(a + b))?;
    Ok((img, replaced))
}

/// A thread's scratch for lines of `w` texels.
pub(super) fn scratch(w: usize) -> impl Fn() -> Scratch + Sync {
    move || Scratch {
        unpack: Unpack::new(),
        floats: vec![0.0; 4 * w],
        halves: vec![f16::ZERO; w],
    }
}

/// What decoding any block of the common layout needs to know.
pub(super) struct Block<'m> {
    meta: &'m MetaData,
    pub slots: &'m [(Option<usize>, SampleType)],
    pub alpha: bool,
    /// 16-bit words per sample of each channel, for PIZ.
    words: Vec<usize>,
    pub line_bytes: usize,
    zstd: bool,
}

/// Where a block's samples are once unpacked: the chunk's own bytes (a block stored as it
/// is), or the thread's buffer ([`Unpack`]) as stored or split.
#[derive(Clone, Copy)]
pub(super) enum Held {
    Chunk,
    Plain,
    Split,
}

impl Held {
    /// The samples of `chunk`, unpacked into `u` as this says, `len` bytes.
    pub(super) fn samples<'a>(self, chunk: &'a RawChunk, u: &'a Unpack, len: usize) -> Samples<'a> {
        match self {
            Held::Chunk => Samples::Plain(&chunk.data[..len]),
            Held::Plain => Samples::Plain(&u.bytes[..len]),
            Held::Split => Samples::Split(&u.bytes[..len]),
        }
    }
}

impl<'m> Block<'m> {
    /// The blocks of `meta`'s layer, laid out as `layout` says; `zstd`: the header says
    /// uncompressed, the chunks are ZSTD (see `read_meta`).
    pub(super) fn new(meta: &'m MetaData, (slots, alpha): &'m Layout, zstd: bool) -> Self {
        let w = meta.headers[0].layer_size.0;
        let line_bytes = slots.iter().map(|(_, t)| t.bytes_per_sample() * w).sum();
        let words = slots
            .iter()
            .map(|(_, t)| t.bytes_per_sample() / 2)
            .collect();
        Block {
            meta,
            slots,
            alpha: *alpha,
            words,
            line_bytes,
            zstd,
        }
    }

    /// Decompresses `chunk` (its first line `y`) and converts it into `rows`, sanitized with
    /// `sanitize`: the count of values replaced.
    pub(super) fn decode(
        &self,
        s: &mut Scratch,
        y: usize,
        chunk: &RawChunk,
        rows: &mut [Vec4],
        sanitize: bool,
    ) -> std::result::Result<usize, String> {
        let w = self.meta.headers[0].layer_size.0;
        let Scratch {
            unpack,
            floats,
            halves,
        } = s;
        let lines = rows.len() / w;
        let held = self.unpack(unpack, y, chunk, lines)?;
        let samples = held.samples(chunk, unpack, self.line_bytes * lines);
        let mut count = 0;
        for (line, row) in rows.chunks_exact_mut(w).enumerate() {
            let start = line * self.line_bytes;
            fill_row(samples, start, self.slots, self.alpha, row, floats, halves);
            if sanitize {
                count += row
                    .iter_mut()
                    .map(crate::image::sanitize_texel)
                    .sum::<usize>();
            }
        }
        Ok(count)
    }

    /// Decompresses `chunk` (its first line `y`, `lines` lines) into `u`: where its samples
    /// are ([`Held::samples`]).
    #[inline(always)]
    pub(super) fn unpack(
        &self,
        u: &mut Unpack,
        y: usize,
        chunk: &RawChunk,
        lines: usize,
    ) -> std::result::Result<Held, String> {
        let header = &self.meta.headers[0];
        let w = header.layer_size.0;
        let Unpack {
            inflate,
            piz,
            zstd: inflate_zstd,
            inner,
            bytes,
        } = u;
        let expected = self.line_bytes * lines;
        let held = match (header.compression, chunk.data) {
            // A block that would not shrink is stored as it is, whatever the compression.
            (_, data) if data.len() == expected => Held::Chunk,
            (_, data) if self.zstd => {
                super::zstd::unpack(data, header, &chunk.bounds, inflate_zstd, inner, bytes)
                    .map_err(|e| format!("{e} (block at line {y})"))?;
                Held::Plain
            }
            (Compression::ZIP1 | Compression::ZIP16, data) => {
                bytes.resize(expected, 0);
                let n = inflate.zlib_decompress(data, &mut bytes[..expected]);
                if n != Ok(expected) {
                    return Err(format!(
                        "the ZIP block at line {y} is corrupt (zlib: {})",
                        n.map_or_else(|e| e.to_string(), |n| format!("{n} bytes"))
                    ));
                }
                undo_differences(&mut bytes[..expected]);
                Held::Split
            }
            (Compression::RLE, data) => {
                bytes.resize(expected, 0);
                unpack_rle(data, &mut bytes[..expected])
                    .map_err(|e| format!("the RLE block at line {y} {e}"))?;
                undo_differences(&mut bytes[..expected]);
                Held::Split
            }
            (Compression::PIZ, data) => {
                super::piz::decompress(data, &self.words, w, lines, piz, bytes)
                    .map_err(|e| format!("{e} (block at line {y})"))?;
                Held::Plain
            }
            // Stored as it is, yet not of the size it should be: caught below.
            (Compression::Uncompressed, _) => Held::Chunk,
            _ => {
                let chunk = chunk.to_chunk();
                let owned =
                    guarded(|| UncompressedBlock::decompress_chunk(chunk, self.meta, false))?;
                *bytes = owned.data;
                Held::Plain
            }
        };
        let held_len = match held {
            Held::Chunk => chunk.data.len(),
            Held::Plain | Held::Split => bytes.len(),
        };
        if held_len != expected {
            return Err(format!(
                "the block at line {y} decompresses to the wrong size"
            ));
        }
        Ok(held)
    }
}

/// Converts the line starting at byte `start` of the stored form into texels: each R G B A
/// channel's samples, half or full floats, to its slot; others skipped; alpha 1 if absent.
/// Each channel goes to its own plane of `floats` (4 x the row's width) and the texels are
/// made in one pass: a channel at a time into the texels' lanes was 40% of a 16K decode.
fn fill_row(
    samples: Samples,
    start: usize,
    slots: &[(Option<usize>, SampleType)],
    alpha: bool,
    row: &mut [Vec4],
    floats: &mut [f32],
    halves: &mut [f16],
) {
    let w = row.len();
    let planes = &mut floats[..4 * w];
    let written = line_planes(samples, start, slots, alpha, planes, halves);
    let (r, rest) = planes.split_at(w);
    let (g, rest) = rest.split_at(w);
    let (b, a) = rest.split_at(w);
    if written == [true; 4] {
        for ((((t, &r), &g), &b), &a) in row.iter_mut().zip(r).zip(g).zip(b).zip(a) {
            *t = Vec4::new(r, g, b, a);
        }
        return;
    }
    // A slot no channel fills keeps what the row held.
    for (k, plane) in [r, g, b, a].into_iter().enumerate() {
        if written[k] {
            for (t, &v) in row.iter_mut().zip(plane) {
                t[k] = v;
            }
        }
    }
}

/// The line starting at byte `start` of the stored form as four planes of `planes` (R, G,
/// B, A, a quarter each): each channel's samples to its slot's plane, alpha 1 if absent;
/// which planes were written.
#[inline(always)]
pub(super) fn line_planes(
    samples: Samples,
    start: usize,
    slots: &[(Option<usize>, SampleType)],
    alpha: bool,
    planes: &mut [f32],
    halves: &mut [f16],
) -> [bool; 4] {
    let w = planes.len() / 4;
    let mut written = [false; 4];
    let mut at = start;
    for &(slot, kind) in slots {
        let size = kind.bytes_per_sample() * w;
        let from = at;
        at += size;
        let Some(k) = slot else { continue };
        channel(
            samples,
            kind,
            from,
            size,
            &mut planes[k * w..(k + 1) * w],
            halves,
        );
        written[k] = true;
    }
    if !alpha {
        planes[3 * w..].fill(1.0);
        written[3] = true;
    }
    written
}

/// One channel's samples (stored bytes `from..from + size`) as floats into `out`.
fn channel(
    samples: Samples,
    kind: SampleType,
    from: usize,
    size: usize,
    out: &mut [f32],
    halves: &mut [f16],
) {
    use half::slice::HalfFloatSliceExt;
    let w = out.len();
    match (samples, kind) {
        (Samples::Plain(d), SampleType::F16) => {
            for (h, b) in halves.iter_mut().zip(d[from..from + size].chunks_exact(2)) {
                *h = f16::from_le_bytes([b[0], b[1]]);
            }
            halves[..w].convert_to_f32_slice(out);
        }
        (Samples::Plain(d), _) => {
            for (f, b) in out.iter_mut().zip(d[from..from + size].chunks_exact(4)) {
                *f = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        // Stored byte i is at i / 2 of the even or the odd half (every offset is even).
        (Samples::Split(d), SampleType::F16) => {
            let (even, odd) = split_range(d, from, size);
            for ((h, &a), &b) in halves.iter_mut().zip(even).zip(odd) {
                *h = f16::from_le_bytes([a, b]);
            }
            halves[..w].convert_to_f32_slice(out);
        }
        (Samples::Split(d), _) => {
            let (even, odd) = split_range(d, from, size);
            let pairs = even.chunks_exact(2).zip(odd.chunks_exact(2));
            for (f, (a, b)) in out.iter_mut().zip(pairs) {
                *f = f32::from_le_bytes([a[0], b[0], a[1], b[1]]);
            }
        }
    }
}

/// The even-offset and odd-offset bytes of the stored bytes `from..from + size` (`from`
/// and `size` even) of a split block `d`.
fn split_range(d: &[u8], from: usize, size: usize) -> (&[u8], &[u8]) {
    let (even, odd) = d.split_at(d.len() / 2);
    let range = from / 2..(from + size) / 2;
    (&even[range.clone()], &odd[range])
}

/// Undoes OpenEXR's byte predictor in place: after the first, each byte was stored as its
/// difference from the one before, plus 128. A running sum, 16 bytes at a time with SSE2.
pub(super) fn undo_differences(bytes: &mut [u8]) {
    let Some((&mut first, rest)) = bytes.split_first_mut() else {
        return;
    };
    let mut prev = first;
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of every x86-64 processor.
    let rest = unsafe { sums_sse2(rest, &mut prev) };
    for b in rest {
        prev = prev.wrapping_add(*b).wrapping_sub(128);
        *b = prev;
    }
}

/// `undo_differences` of `bytes` after `prev` in whole 16-byte pieces; `prev` becomes the
/// last sum, and the bytes left over come back.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
fn sums_sse2<'a>(bytes: &'a mut [u8], prev: &mut u8) -> &'a mut [u8] {
    use std::arch::x86_64::*;
    let mut sixteens = bytes.chunks_exact_mut(16);
    let mut carry = _mm_set1_epi8(*prev as i8);
    let bias = _mm_set1_epi8(i8::MIN);
    for chunk in &mut sixteens {
        let d: __m128i = bytemuck::pod_read_unaligned(chunk);
        // Byte i + 128 (mod 256) is byte i - 128; then the sums of 1, 2, 4, 8, 16.
        let mut x = _mm_xor_si128(d, bias);
        x = _mm_add_epi8(x, _mm_slli_si128::<1>(x));
        x = _mm_add_epi8(x, _mm_slli_si128::<2>(x));
        x = _mm_add_epi8(x, _mm_slli_si128::<4>(x));
        x = _mm_add_epi8(x, _mm_slli_si128::<8>(x));
        // The piece's total in every byte, found apart from the carry: the carry's chain
        // is one addition per 16 bytes.
        let t = _mm_unpackhi_epi8(x, x);
        let t = _mm_unpackhi_epi16(t, t);
        let total = _mm_shuffle_epi32::<0xff>(t);
        chunk.copy_from_slice(bytemuck::bytes_of(&_mm_add_epi8(x, carry)));
        carry = _mm_add_epi8(carry, total);
    }
    *prev = (_mm_cvtsi128_si32(carry) & 0xff) as u8;
    sixteens.into_remainder()
}

/// Expands OpenEXR's run-length tokens (a signed count byte: -n, then n bytes as they are;
/// n >= 0, then one byte n + 1 times) into `out`, which they must fill exactly. Tokens past
/// that are ignored, as the crate ignores them.
pub(super) fn unpack_rle(data: &[u8], out: &mut [u8]) -> std::result::Result<(), &'static str> {
    let overrun = "is corrupt (its runs overrun the block)";
    let short = "is corrupt (a run is cut short)";
    let (mut i, mut o) = (0, 0);
    while i < data.len() && o < out.len() {
        let count = data[i] as i8;
        i += 1;
        if count < 0 {
            let n = count.unsigned_abs() as usize;
            let from = data.get(i..i + n).ok_or(short)?;
            out.get_mut(o..o + n).ok_or(overrun)?.copy_from_slice(from);
            i += n;
            o += n;
        } else {
            let n = count as usize + 1;
            let v = *data.get(i).ok_or(short)?;
            out.get_mut(o..o + n).ok_or(overrun)?.fill(v);
            i += 1;
            o += n;
        }
    }
    if o == out.len() {
        Ok(())
    } else {
        Err("is corrupt (too short)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SSE2 running sum gives the byte-at-a-time one, for every length and start.
    #[test]
    fn predictor_matches_the_plain_loop() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let data: Vec<u8> = (0..300)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect();
        for len in 0..data.len() {
            let mut fast = data[..len].to_vec();
            undo_differences(&mut fast);
            let mut plain = data[..len].to_vec();
            for i in 1..len {
                plain[i] = plain[i - 1].wrapping_add(plain[i]).wrapping_sub(128);
            }
            assert_eq!(fast, plain, "{len}");
        }
    }

    /// Runs fill the block exactly, or are refused.
    #[test]
    fn rle_runs() {
        let mut out = [0u8; 6];
        unpack_rle(&[2, 7, 0xfd, 1, 2, 3], &mut out).unwrap();
        assert_eq!(out, [7, 7, 7, 1, 2, 3]);
        assert!(unpack_rle(&[2, 7, 0xfd, 1, 2], &mut out).is_err());
        assert!(unpack_rle(&[3, 7, 0xfd, 1, 2, 3], &mut out).is_err());
        assert!(unpack_rle(&[2, 7], &mut out).is_err());
        // What follows a full block is ignored.
        unpack_rle(&[5, 9, 0xff], &mut out).unwrap();
        assert_eq!(out, [9; 6]);
    }
}
