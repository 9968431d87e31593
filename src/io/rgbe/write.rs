//! Writing a Radiance file: rows into shared-exponent texels, coded in parallel into one
//! buffer. The run-length coding of each channel is in `runs`.

use super::runs::run_length;
use crate::image::Image;
use glam::Vec4;
use rayon::prelude::*;
use std::marker::PhantomData;

/// A Radiance .hdr file: the standard header, then run-length scanlines (flat texels for
/// widths the run-length form cannot hold). Alpha is dropped; negative values and NaN become 0.
pub fn encode(img: &Image) -> Vec<u8> {
    let (w, h) = (img.width, img.height);
    let head = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    if w == 0 {
        return head;
    }
    let flat = !(8..0x8000).contains(&w);
    // Each row is coded into a slot of the output big enough for any row (4 start bytes, then
    // per channel its bytes, a count byte per 128 literals and one to spare: `run_length`
    // never writes more), then the rows are closed up. One buffer for the whole image: a
    // buffer per row made every worker's allocator arena grow page by page, each growth an
    // mprotect that stalls every other thread's page faults (2000 of them on six 1024 faces).
    let slot = if flat {
        4 * w
    } else {
        4 + 4 * (w + w.div_ceil(128) + 1)
    };
    let start = head.len();
    let mut out: Vec<u8> = crate::alloc::zeroed(start + slot * h);
    out[..start].copy_from_slice(&head);
    let lens: Vec<usize> = out[start..]
        .par_chunks_mut(slot)
        .zip(img.pixels.par_chunks(w))
        .map_init(
            || (vec![0u8; 4 * w], Vec::with_capacity(slot)),
            |(planes, line), (dst, row)| {
                line.clear();
                crate::simd::fast(EncodeRow((row, planes, flat, line), PhantomData));
                dst[..line.len()].copy_from_slice(line);
                line.len()
            },
        )
        .collect();
    let mut end = start;
    for (y, len) in lens.into_iter().enumerate() {
        let from = start + y * slot;
        out.copy_within(from..from + len, end);
        end += len;
    }
    out.truncate(end);
    out
}

crate::simd::kernel!(EncodeRow((&'k [Vec4], &'k mut [u8], bool, &'k mut Vec<u8>)) -> () = encode_row);

/// One scanline of `encode` appended to `line`, `planes` its scratch space (inlined into both
/// builds of `simd::fast`).
#[inline(always)]
fn encode_row((row, planes, flat, line): (&[Vec4], &mut [u8], bool, &mut Vec<u8>)) {
    let w = row.len();
    if flat {
        line.extend(row.iter().flat_map(|p| to_rgbe(*p)));
        return;
    }
    // The scanline's four channels side by side, then each run-length coded.
    let (r, rest) = planes.split_at_mut(w);
    let (g, rest) = rest.split_at_mut(w);
    let (b, e) = rest.split_at_mut(w);
    for x in 0..w {
        [r[x], g[x], b[x], e[x]] = to_rgbe(row[x]);
    }
    line.extend_from_slice(&[2, 2, (w >> 8) as u8, (w & 0xff) as u8]);
    for channel in planes.chunks(w) {
        run_length(channel, line);
    }
}

/// Shared-exponent form: the largest channel's exponent e (value = m 2^e, m in [0.5, 1)),
/// each channel rounded to 8 bits of that scale, floor(v 2^(8 - e) + 1/2), e one higher where
/// the largest channel would round to 256. Rounded, not truncated as Radiance's `setcolr`
/// does: cubeforge reads m 2^(e - 136) (as engines do), so a truncating writer lost half a
/// step, 0.3-0.8% of a real panorama's light, on every round trip (issue 48). Worked on the
/// floats' bits (a shift of each mantissa), without branches on the channels: no log2, no
/// division.
#[inline(always)]
pub(super) fn to_rgbe(p: Vec4) -> [u8; 4] {
    // NaN and negatives to 0, infinity to the largest float.
    let [r, g, b] = [p.x, p.y, p.z].map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
    let max = r.max(g).max(b);
    // The biased exponent of the largest channel: 0 for zero and subnormals (stored as 0).
    let top = max.to_bits() >> 23;
    // v = m 2^(ev - 150) with a 24-bit m, so v 2^(8 - e) = m 2^(ev - top - 16), e = top - 126;
    // rounded: (m + 2^(shift - 1)) >> shift, 0 from a shift of 25 on (under a half).
    // Selects, not branches, so that rows vectorize.
    let q = |v: f32, top: u32| {
        let bits = v.to_bits();
        let ev = bits >> 23;
        let m = (bits & 0x7f_ffff) | if ev > 0 { 0x80_0000 } else { 0 };
        let shift = (16 + top).wrapping_sub(ev.max(1));
        if shift <= 24 {
            (m + (1 << ((shift - 1) & 31))) >> (shift & 31)
        } else {
            0
        }
    };
    // The largest channel rounds to 256 from 255.5 up: one exponent higher, it is 128.
    let top = top + (q(max, top) > 255) as u32;
    let out = [
        q(r, top) as u8,
        q(g, top) as u8,
        q(b, top) as u8,
        (top + 2) as u8,
    ];
    if max.to_bits() >> 23 == 0 {
        [0; 4]
    } else if max >= 1.7e38 || top > 253 {
        // Past the largest exponent byte: the largest value RGBE holds.
        [255; 4]
    } else {
        out
    }
}
