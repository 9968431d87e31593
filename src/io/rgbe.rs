//! Radiance .hdr pixels, decoded and encoded a row per task. The image crate reads the header
//! (and stays the reader of anything this path does not take, for its error messages), but it
//! works one scanline at a time through an RGB f32 copy, with a log2 and divisions per texel
//! when writing: at 4K, half of a conversion's decode time and 100 MB of memory, and the
//! slowest encoder of all. Here the scanlines' starts are found first (a large file walked in
//! pieces in parallel, see `line_starts`), then rows decode in parallel, to the crate's values
//! bit for bit; rows encode in parallel to the same run-length scanlines any Radiance reader
//! takes.

#![warn(missing_docs)]

use super::{FileFormat, Meta, ReadOptions};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use ::image::codecs::hdr::HdrDecoder;
use ::image::ImageDecoder;
use glam::Vec4;
use rayon::prelude::*;
use std::io::Cursor;
use std::marker::PhantomData;
use std::path::Path;

/// The image, or None when the image crate should read this file instead (a header it
/// rejects, with its error message, or an empty image).
pub fn decode(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Option<Result<(Image, Meta)>> {
    let mut cursor = Cursor::new(bytes);
    // A header that panics the crate's reader (caught) goes to the image crate's path too,
    // which says why, caught likewise.
    let (w, h) = super::guard::caught(|| HdrDecoder::new(&mut cursor).ok().map(|d| d.dimensions()))
        .ok()??;
    let (w, h) = (w as usize, h as usize);
    if let Err(e) = opts.limits.check(path, w as u64, h as u64) {
        return Some(Err(e));
    }
    // The header reader stops right after the dimensions line: the pixels start there.
    let starts = match line_starts(bytes, cursor.position() as usize, w, h) {
        Ok(starts) => starts,
        // Said here, before any pixel memory: the crate's reader would allocate the whole
        // image first.
        Err(y) => {
            return Some(Err(Error::file(
                path,
                format!(
                    "cannot decode Radiance HDR: scanline {} of {h} is truncated or malformed",
                    y + 1
                ),
            )))
        }
    };
    let mut img = Image::new(w, h);
    img.pixels
        .par_chunks_mut(w)
        .zip(starts.par_iter())
        .for_each_init(
            || vec![0u8; 4 * w],
            |planes, (row, &start)| {
                let done = scanline(bytes, start, w, Some(planes));
                debug_assert!(done.is_some(), "a scanned line decodes");
                let (r, rest) = planes.split_at(w);
                let (g, rest) = rest.split_at(w);
                let (b, e) = rest.split_at(w);
                texels(r, g, b, e, row);
            },
        );
    let meta = Meta {
        file_format: FileFormat::Hdr,
        pixel_format: super::raster::pixel_format_name(::image::ColorType::Rgb32F, FileFormat::Hdr),
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
        stored_levels: 1,
    };
    Some(Ok((img, meta)))
}

/// Where each of the `h` scanlines of `w` texels starts, the first at `first`; Err(y) when
/// line y is truncated or malformed. Run-length lines have no index, so each start is found
/// by walking the line before: a large file is walked in pieces in parallel, each piece
/// from the first place in it that starts a line of this width (2, 2, width) and parses.
/// Walks are deterministic, so once the true walk reaches a start a piece's walk found, the
/// rest of that piece is the same; a piece whose walk it misses (a false start) is walked
/// again from the true start. The result is the one-piece walk's, always.
fn line_starts(
    data: &[u8],
    first: usize,
    w: usize,
    h: usize,
) -> std::result::Result<Vec<usize>, usize> {
    /// Candidate starts tried per piece before leaving the piece to the true walk: a file
    /// full of false starts costs at most this many line walks a piece.
    const TRIES: usize = 8;
    let key = [2, 2, (w >> 8) as u8, (w & 0xff) as u8];
    let rle = (8..0x8000).contains(&w) && data.get(first..first + 4) == Some(&key[..]);
    let len = data.len().saturating_sub(first);
    let pieces = if rle && len >= 1 << 20 {
        (4 * rayon::current_num_threads()).min(len >> 16)
    } else {
        1
    };
    let bound = |i: usize| first + len * i / pieces;
    // Each piece's walk: the starts it found (each line parsed), and where it left off.
    let walks: Vec<(Vec<usize>, usize)> = (1..pieces)
        .into_par_iter()
        .map(|i| {
            let (lo, hi) = (bound(i), bound(i + 1));
            let mut from = lo;
            for _ in 0..TRIES {
                let Some(at) = data[from..hi].windows(4).position(|k| k == key) else {
                    break;
                };
                let mut p = from + at;
                let mut found = Vec::new();
                while p < hi {
                    match scanline(data, p, w, None) {
                        Some(next) => {
                            found.push(p);
                            p = next;
                        }
                        None => break,
                    }
                }
                if !found.is_empty() {
                    return (found, p);
                }
                from += at + 1;
            }
            (Vec::new(), hi)
        })
        .collect();
    let mut starts = Vec::with_capacity(h);
    let mut p = first;
    // The true walk through piece `i`, from `p`, until it leaves the piece or has every line.
    let walk = |starts: &mut Vec<usize>, p: &mut usize, end: usize| {
        while *p < end && starts.len() < h {
            let next = scanline(data, *p, w, None).ok_or(starts.len())?;
            starts.push(*p);
            *p = next;
        }
        Ok::<(), usize>(())
    };
    walk(&mut starts, &mut p, bound(1))?;
    for (i, (found, left_off)) in walks.iter().enumerate() {
        if starts.len() == h {
            break;
        }
        match found.binary_search(&p) {
            Ok(k) => {
                let take = (found.len() - k).min(h - starts.len());
                starts.extend_from_slice(&found[k..k + take]);
                p = found.get(k + take).copied().unwrap_or(*left_off);
            }
            Err(_) => walk(&mut starts, &mut p, bound(i + 2))?,
        }
    }
    walk(&mut starts, &mut p, usize::MAX)?;
    Ok(starts)
}

/// The texels of one scanline from its four planes: `texel` for each, four at a time with
/// SSE2 on x86-64 (the same operations, so the same bits; the 4K bench photo decodes in
/// 35 ms instead of 40 on one core).
fn texels(r: &[u8], g: &[u8], b: &[u8], e: &[u8], row: &mut [Vec4]) {
    #[cfg(not(target_arch = "x86_64"))]
    let done = 0;
    #[cfg(target_arch = "x86_64")]
    let done = {
        use std::arch::x86_64::*;
        let quads = row.len() / 4;
        for (q, out) in row.chunks_exact_mut(4).enumerate() {
            let i = 4 * q;
            // SAFETY: SSE2 is part of x86-64; each plane holds row.len() >= i + 4 bytes, and
            // `out` is four Vec4s (16 bytes each, unaligned stores).
            unsafe {
                let zero = _mm_setzero_si128();
                let lanes = |p: &[u8]| {
                    let v =
                        _mm_cvtsi32_si128(i32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]));
                    _mm_unpacklo_epi16(_mm_unpacklo_epi8(v, zero), zero)
                };
                let ei = lanes(e);
                // 2^(e - 128) from its bits, as in `texel`.
                let normal = _mm_cmpgt_epi32(ei, _mm_set1_epi32(1));
                let hi = _mm_slli_epi32::<23>(_mm_sub_epi32(ei, _mm_set1_epi32(1)));
                let lo = _mm_slli_epi32::<22>(ei);
                let bits = _mm_or_si128(_mm_and_si128(normal, hi), _mm_andnot_si128(normal, lo));
                let scale = _mm_mul_ps(_mm_castsi128_ps(bits), _mm_set1_ps(0.003_906_25));
                let max = _mm_set1_ps(crate::image::MAX_RADIANCE);
                let channel =
                    |p: &[u8]| _mm_min_ps(_mm_mul_ps(scale, _mm_cvtepi32_ps(lanes(p))), max);
                let (rv, gv, bv) = (channel(r), channel(g), channel(b));
                let one = _mm_set1_ps(1.0);
                // Planes to texels: (r, g, b, 1) per lane.
                let (rg_lo, b1_lo) = (_mm_unpacklo_ps(rv, gv), _mm_unpacklo_ps(bv, one));
                let (rg_hi, b1_hi) = (_mm_unpackhi_ps(rv, gv), _mm_unpackhi_ps(bv, one));
                let dst = out.as_mut_ptr() as *mut f32;
                _mm_storeu_ps(dst, _mm_movelh_ps(rg_lo, b1_lo));
                _mm_storeu_ps(dst.add(4), _mm_movehl_ps(b1_lo, rg_lo));
                _mm_storeu_ps(dst.add(8), _mm_movelh_ps(rg_hi, b1_hi));
                _mm_storeu_ps(dst.add(12), _mm_movehl_ps(b1_hi, rg_hi));
            }
        }
        4 * quads
    };
    for (x, o) in row.iter_mut().enumerate().skip(done) {
        *o = texel([r[x], g[x], b[x], e[x]]);
    }
}

/// An RGBE texel in linear light: the mantissas times 2^(e - 136), e = 0 for black.
#[inline]
fn texel([r, g, b, e]: [u8; 4]) -> Vec4 {
    // 2^(e - 128) built from its bits (e = 1 needs the subnormal), then / 256.
    let scale = f32::from_bits(if e > 1 {
        ((e - 1) as u32) << 23
    } else {
        (e as u32) << 22
    }) * 0.003_906_25;
    // RGBE reaches 1.7e38: clamped like every input (see `MAX_RADIANCE`).
    let v = Vec4::new(scale * r as f32, scale * g as f32, scale * b as f32, 1.0);
    v.min(Vec4::splat(crate::image::MAX_RADIANCE))
}

/// Walks the scanline of `w` texels that starts at byte `p`, writing its texels to `out` when
/// given, as four planes of `w` bytes (R, G, B, E: a run-length channel's literals are then
/// one copy, its runs one fill); returns where the next one starts, or None if the line is
/// malformed. New-style lines hold four run-length-coded channels; anything else is old-style
/// texels (flat, or with (1, 1, 1, n) repeat markers).
fn scanline(data: &[u8], mut p: usize, w: usize, mut out: Option<&mut [u8]>) -> Option<usize> {
    let first: [u8; 4] = data.get(p..p + 4)?.try_into().ok()?;
    p += 4;
    if first[0] == 2 && first[1] == 2 && first[2] < 128 {
        for c in 0..4 {
            let mut x = 0;
            while x < w {
                let code = *data.get(p)? as usize;
                p += 1;
                if code <= 128 {
                    let values = data.get(p..p + code)?;
                    if x + code > w {
                        return None;
                    }
                    if let Some(o) = out.as_deref_mut() {
                        o[c * w + x..c * w + x + code].copy_from_slice(values);
                    }
                    p += code;
                    x += code;
                } else {
                    let n = code - 128;
                    let v = *data.get(p)?;
                    p += 1;
                    if x + n > w {
                        return None;
                    }
                    if let Some(o) = out.as_deref_mut() {
                        o[c * w + x..c * w + x + n].fill(v);
                    }
                    x += n;
                }
            }
        }
        return Some(p);
    }
    let marker = |t: &[u8; 4]| t[0] == 1 && t[1] == 1 && t[2] == 1;
    if marker(&first) {
        return None;
    }
    let put = |o: &mut [u8], x: usize, t: [u8; 4]| {
        for (c, v) in t.into_iter().enumerate() {
            o[c * w + x] = v;
        }
    };
    if let Some(o) = out.as_deref_mut() {
        put(o, 0, first);
    }
    let (mut x, mut shift, mut prev) = (1, 0u32, first);
    while x < w {
        let t: [u8; 4] = data.get(p..p + 4)?.try_into().ok()?;
        p += 4;
        if marker(&t) {
            // Consecutive markers count in base 256, least significant first.
            let n = (t[3] as usize).checked_shl(shift).filter(|_| shift < 32)?;
            shift += 8;
            if x + n > w {
                return None;
            }
            if let Some(o) = out.as_deref_mut() {
                for (c, v) in prev.into_iter().enumerate() {
                    o[c * w + x..c * w + x + n].fill(v);
                }
            }
            x += n;
        } else {
            shift = 0;
            prev = t;
            if let Some(o) = out.as_deref_mut() {
                put(o, x, t);
            }
            x += 1;
        }
    }
    Some(p)
}

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
/// each channel truncated to 8 bits of that scale, floor(v 2^(8 - e)). Worked on the floats'
/// bits (a shift of each mantissa), without branches on the channels: no log2, no division.
#[inline(always)]
fn to_rgbe(p: Vec4) -> [u8; 4] {
    // NaN and negatives to 0, infinity to the largest float.
    let [r, g, b] = [p.x, p.y, p.z].map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
    let max = r.max(g).max(b);
    // The biased exponent of the largest channel: 0 for zero and subnormals (stored as 0).
    let top = max.to_bits() >> 23;
    // v = m 2^(ev - 150) with a 24-bit m, so v 2^(8 - e) = m 2^(ev - top - 16), e = top - 126.
    // Selects, not branches, so that rows vectorize.
    let q = |v: f32| {
        let bits = v.to_bits();
        let ev = bits >> 23;
        let m = (bits & 0x7f_ffff) | if ev > 0 { 0x80_0000 } else { 0 };
        let shift = (16 + top).wrapping_sub(ev.max(1));
        (if shift < 24 { m >> (shift & 31) } else { 0 }) as u8
    };
    let out = [q(r), q(g), q(b), (top + 2) as u8];
    if top == 0 {
        [0; 4]
    } else if max >= 1.7e38 {
        [255; 4]
    } else {
        out
    }
}

/// Appends one channel of a scanline in the run-length form: runs of 4 to 127 equal bytes as
/// (128 + n, byte), everything else as literals of up to 128 bytes (n, bytes...).
fn run_length(data: &[u8], out: &mut Vec<u8>) {
    let n = data.len();
    let mut i = 0;
    while i < n {
        // Literals up to the next run of four (or the end), at most 128 at a time.
        let run_start = next_run(data, i).unwrap_or(n);
        while i < run_start {
            let k = (run_start - i).min(128);
            out.push(k as u8);
            out.extend_from_slice(&data[i..i + k]);
            i += k;
        }
        if run_start < n {
            let byte = data[run_start];
            let len = equal_bytes(data, run_start, n.min(run_start + 127));
            out.extend_from_slice(&[128 + len as u8, byte]);
            i = run_start + len;
        }
    }
}

/// How many bytes from `start` (before `end`) equal the byte at `start`: sixteen at a time
/// with SSE2 on x86-64.
#[inline]
fn equal_bytes(data: &[u8], start: usize, end: usize) -> usize {
    let byte = data[start];
    let mut i = start;
    #[cfg(target_arch = "x86_64")]
    while i + 16 <= end {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; the load ends at i + 16 <= end <= data.len().
        let same = unsafe {
            let v = _mm_loadu_si128(data.as_ptr().add(i) as *const __m128i);
            _mm_movemask_epi8(_mm_cmpeq_epi8(v, _mm_set1_epi8(byte as i8))) as u32
        };
        if same != 0xffff {
            return i + (!same).trailing_zeros() as usize - start;
        }
        i += 16;
    }
    while i < end && data[i] == byte {
        i += 1;
    }
    i - start
}

/// The first position at or after `from` where four equal bytes start. Sixteen at a time
/// with SSE2 on x86-64; elsewhere (and for the last bytes) eight positions are
/// compared with their successors at once (a word and the word one byte on: a zero byte of
/// their xor marks an equal pair), six starts tested per word.
fn next_run(data: &[u8], from: usize) -> Option<usize> {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    let n = data.len();
    let word = |at: usize| u64::from_le_bytes(data[at..at + 8].try_into().expect("8 bytes"));
    let mut j = from;
    // Sixteen starts at once with SSE2: each byte against the next three.
    #[cfg(target_arch = "x86_64")]
    while j + 19 <= n {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; the four 16-byte loads end at j + 19 <= n.
        let starts = unsafe {
            let at = |k: usize| _mm_loadu_si128(data.as_ptr().add(j + k) as *const __m128i);
            let a = at(0);
            let eq = |k: usize| _mm_cmpeq_epi8(a, at(k));
            _mm_movemask_epi8(_mm_and_si128(_mm_and_si128(eq(1), eq(2)), eq(3))) as u32
        };
        if starts != 0 {
            return Some(j + starts.trailing_zeros() as usize);
        }
        j += 16;
    }
    while j + 9 <= n {
        let t = word(j) ^ word(j + 1);
        // High bit of each byte set exactly where that byte of t is zero.
        let equal = !(((t & LOW7) + LOW7) | t | LOW7);
        let starts = equal & (equal >> 8) & (equal >> 16) & 0x0000_8080_8080_8080;
        if starts != 0 {
            return Some(j + starts.trailing_zeros() as usize / 8);
        }
        j += 6;
    }
    (j..n.saturating_sub(3)).find(|&p| {
        let v = data[p];
        data[p + 1] == v && data[p + 2] == v && data[p + 3] == v
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The starts one walk from the first line finds, or the line it fails at.
    fn serial(
        data: &[u8],
        first: usize,
        w: usize,
        h: usize,
    ) -> std::result::Result<Vec<usize>, usize> {
        let mut starts = Vec::with_capacity(h);
        let mut p = first;
        for y in 0..h {
            starts.push(p);
            p = scanline(data, p, w, None).ok_or(y)?;
        }
        Ok(starts)
    }

    /// The walk in pieces finds the one walk's starts, or fails at its line: for a file,
    /// the file with false starts planted in every piece, and cut short or corrupted.
    #[test]
    fn pieces_find_the_starts_of_one_walk() {
        let (w, h) = (700, 600);
        let img = Image::from_fn(w, h, |x, y| {
            let n = ((x * 7919 + y * 104_729) % 1009) as f32;
            Vec4::new(
                n / 100.0,
                (x % 13) as f32,
                if y % 50 < 5 { 3.0 } else { n },
                1.0,
            )
        });
        let file = encode(&img);
        let first = file.iter().position(|&b| b == b'\n').unwrap();
        let first = first + file[first..].windows(2).position(|p| p == b"\n-").unwrap();
        let first = first + 1 + file[first + 1..].iter().position(|&b| b == b'\n').unwrap() + 1;
        assert!(file.len() - first > 1 << 20);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(5)
            .build()
            .unwrap();
        let both = |data: &[u8], what: &str| {
            let want = serial(data, first, w, h);
            assert_eq!(
                pool.install(|| line_starts(data, first, w, h)),
                want,
                "{what}"
            );
            want
        };
        assert!(both(&file, "file").is_ok());
        // False starts planted in literal runs (any bytes go there: the file stays valid)
        // all through the file: a whole line of runs (so a piece's walk takes it for a
        // start, and the true walk must walk that piece again), or just the line's key.
        let line = serial(&file, first, w, h).unwrap();
        let mut fake = vec![2, 2, (w >> 8) as u8, w as u8];
        for _ in 0..4 {
            for n in [127; 5].into_iter().chain([w - 5 * 127]) {
                fake.extend([128 + n as u8, 9]);
            }
        }
        for plant in [&fake[..], &fake[..4]] {
            let mut planted = file.clone();
            for &s in line.iter().step_by(5) {
                // The first literal run long enough in the line.
                let mut q = s + 4;
                while file[q] > 128 || (file[q] as usize) < plant.len() {
                    q += if file[q] > 128 {
                        2
                    } else {
                        1 + file[q] as usize
                    };
                }
                planted[q + 1..q + 1 + plant.len()].copy_from_slice(plant);
            }
            assert_eq!(both(&planted, "planted"), Ok(line.clone()));
        }
        for cut in [first + 5, file.len() / 2, file.len() - 1] {
            assert!(both(&file[..cut], &format!("cut at {cut}")).is_err());
        }
        for at in [first + 4, file.len() / 3, file.len() - 200] {
            let mut bad = file.clone();
            bad[at] = 0;
            let _ = both(&bad, &format!("zero at {at}"));
        }
    }
}

#[cfg(test)]
mod encode_tests {
    use super::*;

    /// Runs and their lengths found sixteen bytes at a time are the plain loops': every start
    /// and end of lines of runs and literals of many lengths.
    #[test]
    fn runs_found_at_once_match_the_plain_scan() {
        let mut data = Vec::new();
        for k in 0..300usize {
            let len = 1 + (k * 37) % 41;
            let v = (k % 7) as u8;
            data.extend(std::iter::repeat_n(v, len));
            data.extend((0..k % 5).map(|i| (100 + i) as u8));
        }
        let n = data.len();
        for from in 0..n {
            let plain = (from..n.saturating_sub(3))
                .find(|&p| data[p + 1..p + 4].iter().all(|&v| v == data[p]));
            assert_eq!(next_run(&data, from), plain, "from {from}");
            for end in [from + 1, (from + 127).min(n), n] {
                let count = data[from..end]
                    .iter()
                    .take_while(|&&v| v == data[from])
                    .count();
                assert_eq!(equal_bytes(&data, from, end), count, "{from}..{end}");
            }
        }
    }

    /// The four-at-a-time texels are `texel`'s, bit for bit: every exponent, mantissas
    /// from 0 to 255, a line whose width is not a multiple of four.
    #[test]
    fn texels_match_texel() {
        let w = 256 * 3 + 5;
        let plane = |k: usize| -> Vec<u8> {
            (0..w)
                .map(|x| ((x * (7 + 2 * k) + k) % 256) as u8)
                .collect()
        };
        let (r, g, b) = (plane(0), plane(1), plane(2));
        let e: Vec<u8> = (0..w).map(|x| (x % 256) as u8).collect();
        let mut row = vec![Vec4::ZERO; w];
        texels(&r, &g, &b, &e, &mut row);
        for x in 0..w {
            let want = texel([r[x], g[x], b[x], e[x]]);
            assert_eq!(
                row[x].to_array().map(f32::to_bits),
                want.to_array().map(f32::to_bits),
                "texel {x}"
            );
        }
    }

    /// Every line form decodes into the planes as it should: old-style flat texels and
    /// (1, 1, 1, n) repeats, and run-length lines of literals and runs (round trip).
    #[test]
    fn every_line_form_decodes() {
        let t = [
            [10u8, 20, 30, 129],
            [40, 50, 60, 130],
            [70, 80, 90, 128],
            [1, 2, 3, 140],
        ];
        let mut file = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 5\n".to_vec();
        // Line 0 flat; line 1: one texel, three repeats of it, then another.
        for k in [0, 1, 2, 3, 0] {
            file.extend_from_slice(&t[k]);
        }
        file.extend_from_slice(&t[1]);
        file.extend_from_slice(&[1, 1, 1, 3]);
        file.extend_from_slice(&t[3]);
        let opts = crate::io::ReadOptions::default();
        let (img, _) = decode(&file, Path::new("old.hdr"), &opts).unwrap().unwrap();
        let want = [0, 1, 2, 3, 0, 1, 1, 1, 1, 3].map(|k| texel(t[k]));
        assert_eq!(img.pixels, want);
        // Run-length lines: literals and runs in every channel.
        let src = Image::from_fn(40, 3, |x, y| {
            let v = if x % 10 < 5 {
                1.5
            } else {
                (x * 7 + y) as f32 * 0.25
            };
            Vec4::new(v, 2.0 * v, 0.5, 1.0)
        });
        let file = encode(&src);
        let (img, _) = decode(&file, Path::new("rle.hdr"), &opts).unwrap().unwrap();
        for (a, b) in img.pixels.iter().zip(&src.pixels) {
            assert!(
                (*a - *b).abs().max_element() <= b.max_element() / 128.0,
                "{a} vs {b}"
            );
        }
    }

    /// No channel's run-length form is longer than the slot `encode` gives it: its bytes, a
    /// count per 128 literals and one more, for the shapes that cost most (literals cut by
    /// short runs, runs just too short, runs cut at 127) and for noise.
    #[test]
    fn run_length_fits_its_slot() {
        let mut seed = 12345u32;
        let mut noise = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 24) as u8
        };
        for w in [8usize, 9, 127, 128, 129, 255, 256, 1000, 1024, 4097] {
            let shapes: Vec<Vec<u8>> = vec![
                (0..w).map(|i| if i % 5 == 4 { 1 } else { 0 }).collect(),
                (0..w).map(|i| (i / 3) as u8).collect(),
                (0..w)
                    .map(|i| if i % 6 < 4 { 7 } else { i as u8 })
                    .collect(),
                (0..w)
                    .map(|i| if i % 132 < 128 { 9 } else { (i % 256) as u8 })
                    .collect(),
                (0..w).map(|i| i as u8).collect(),
                vec![3; w],
                (0..w).map(|_| noise() & 3).collect(),
                (0..w).map(|_| noise()).collect(),
            ];
            for data in shapes {
                let mut out = Vec::new();
                run_length(&data, &mut out);
                assert!(out.len() <= w + w.div_ceil(128) + 1, "{w}: {}", out.len());
            }
        }
    }

    /// The shared exponent the plain way: frexp, then a multiply in f64 and truncation.
    fn reference(p: Vec4) -> [u8; 4] {
        let [r, g, b] = [p.x, p.y, p.z].map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
        let max = r.max(g).max(b);
        if max < f32::MIN_POSITIVE {
            return [0; 4];
        }
        if max >= 1.7e38 {
            return [255; 4];
        }
        let e = (max as f64).log2().floor() as i32 + 1;
        let scale = 2f64.powi(8 - e);
        let q = |v: f32| (v as f64 * scale) as u8;
        [q(r), q(g), q(b), (e + 128) as u8]
    }

    /// The run-length form by its definition: the first run of four or more, greedily.
    fn naive(data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut i = 0;
        while i < data.len() {
            let run = (i..data.len())
                .find(|&p| p + 4 <= data.len() && data[p..p + 4].iter().all(|&v| v == data[p]))
                .unwrap_or(data.len());
            for chunk in data[i..run].chunks(128) {
                out.push(chunk.len() as u8);
                out.extend_from_slice(chunk);
            }
            i = run;
            if run < data.len() {
                let len = data[run..]
                    .iter()
                    .take(127)
                    .take_while(|&&v| v == data[run])
                    .count();
                out.extend_from_slice(&[128 + len as u8, data[run]]);
                i += len;
            }
        }
        out
    }

    #[test]
    fn shared_exponents_match_the_plain_formula() {
        // Every binade, subnormals, exact powers of two, channels far apart, specials.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let specials = [
            0.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            f32::MIN_POSITIVE,
            1e-40,
            0.5,
            1.0,
            255.0 / 256.0,
            1.7e38,
            f32::MAX,
        ];
        for i in 0..200_000 {
            let mut v = [0.0f32; 3];
            for c in &mut v {
                let bits = next();
                *c = if bits % 7 == 0 {
                    specials[(bits >> 8) as usize % specials.len()]
                } else {
                    f32::from_bits((bits >> 32) as u32 & 0x7fff_ffff)
                };
            }
            let p = Vec4::new(v[0], v[1], v[2], 1.0);
            assert_eq!(to_rgbe(p), reference(p), "{i}: {p}");
        }
    }

    #[test]
    fn runs_are_coded_as_the_definition_says() {
        let mut state = 7u32;
        for len in [
            0, 1, 3, 4, 5, 8, 9, 15, 16, 17, 100, 127, 128, 129, 300, 1024,
        ] {
            for density in [2u32, 4, 16, 256] {
                // Few distinct values make runs of every length, up to past 127.
                let data: Vec<u8> = (0..len)
                    .map(|_| {
                        state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
                        let v = (state >> 16) % density;
                        if v < density / 2 {
                            0
                        } else {
                            v as u8
                        }
                    })
                    .collect();
                let mut out = Vec::new();
                run_length(&data, &mut out);
                assert_eq!(out, naive(&data), "length {len}, {density} values");
            }
        }
        let long = vec![9u8; 300];
        let mut out = Vec::new();
        run_length(&long, &mut out);
        assert_eq!(out, [255, 9, 255, 9, 128 + 46, 9]);
    }
}
