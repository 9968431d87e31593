//! Radiance .hdr pixels, decoded and encoded a row per task. The image crate reads the header
//! (and stays the reader of anything this path does not take, for its error messages), but it
//! works one scanline at a time through an RGB f32 copy, with a log2 and divisions per texel
//! when writing: at 4K, half of a conversion's decode time and 100 MB of memory, and the
//! slowest encoder of all. Here one pass finds where each scanline starts, then rows decode in
//! parallel, to the crate's values bit for bit; rows encode in parallel to the same run-length
//! scanlines any Radiance reader takes.

#![warn(missing_docs)]

use super::{FileFormat, Meta, ReadOptions};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use ::image::codecs::hdr::HdrDecoder;
use ::image::ImageDecoder;
use glam::Vec4;
use rayon::prelude::*;
use std::io::Cursor;
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
    let mut starts = Vec::with_capacity(h);
    let mut p = cursor.position() as usize;
    for y in 0..h {
        starts.push(p);
        match scanline(bytes, p, w, None) {
            Some(next) => p = next,
            // Said here, before any pixel memory: the crate's reader would allocate the whole
            // image first.
            None => {
                return Some(Err(Error::file(
                    path,
                    format!(
                        "cannot decode Radiance HDR: scanline {} of {h} is truncated or malformed",
                        y + 1
                    ),
                )))
            }
        }
    }
    let mut img = Image::new(w, h);
    img.pixels
        .par_chunks_mut(w)
        .zip(starts.par_iter())
        .for_each_init(
            || vec![[0u8; 4]; w],
            |rgbe, (row, &start)| {
                let done = scanline(bytes, start, w, Some(rgbe));
                debug_assert!(done.is_some(), "a scanned line decodes");
                for (o, t) in row.iter_mut().zip(rgbe.iter()) {
                    *o = texel(*t);
                }
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
/// given; returns where the next one starts, or None if the line is malformed. New-style lines
/// hold four run-length-coded channels; anything else is old-style texels (flat, or with
/// (1, 1, 1, n) repeat markers).
fn scanline(
    data: &[u8],
    mut p: usize,
    w: usize,
    mut out: Option<&mut Vec<[u8; 4]>>,
) -> Option<usize> {
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
                        for (t, &v) in o[x..x + code].iter_mut().zip(values) {
                            t[c] = v;
                        }
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
                        for t in &mut o[x..x + n] {
                            t[c] = v;
                        }
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
    if let Some(o) = out.as_deref_mut() {
        o[0] = first;
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
                o[x..x + n].fill(prev);
            }
            x += n;
        } else {
            shift = 0;
            prev = t;
            if let Some(o) = out.as_deref_mut() {
                o[x] = t;
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
    let mut out = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    if w == 0 {
        return out;
    }
    let rows: Vec<Vec<u8>> = img
        .pixels
        .par_chunks(w)
        .map(|row| {
            let texels: Vec<[u8; 4]> = row.iter().map(|p| to_rgbe(*p)).collect();
            if !(8..0x8000).contains(&w) {
                return texels.concat();
            }
            let mut line = Vec::with_capacity(w * 4 + 4);
            line.extend_from_slice(&[2, 2, (w >> 8) as u8, (w & 0xff) as u8]);
            let mut channel = vec![0u8; w];
            for c in 0..4 {
                for (v, t) in channel.iter_mut().zip(&texels) {
                    *v = t[c];
                }
                run_length(&channel, &mut line);
            }
            line
        })
        .collect();
    out.reserve(rows.iter().map(Vec::len).sum());
    for r in rows {
        out.extend_from_slice(&r);
    }
    out
}

/// Shared-exponent form: the largest channel's exponent e (value = m 2^e, m in [0.5, 1)),
/// each channel truncated to 8 bits of that scale. Read from the float's bits: no log2.
fn to_rgbe(p: Vec4) -> [u8; 4] {
    // NaN and negatives to 0, infinity to the largest RGBE value.
    let [r, g, b] = [p.x, p.y, p.z].map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
    let max = r.max(g).max(b);
    if max < f32::MIN_POSITIVE {
        return [0; 4];
    }
    if max >= 1.7e38 {
        return [255, 255, 255, 255];
    }
    // max = m 2^e with m in [0.5, 1): e is the float's unbiased exponent plus one.
    let e = ((max.to_bits() >> 23) & 0xff) as i32 - 126;
    // 2^(8 - e), exact in f64 for every e here (-125..=127).
    let scale = f64::from_bits(((1023 + 8 - e) as u64) << 52);
    let q = |v: f32| (v as f64 * scale) as u8;
    [q(r), q(g), q(b), (e + 128) as u8]
}

/// Appends one channel of a scanline in the run-length form: runs of 4 to 127 equal bytes as
/// (128 + n, byte), everything else as literals of up to 128 bytes (n, bytes...).
fn run_length(data: &[u8], out: &mut Vec<u8>) {
    const MIN_RUN: usize = 4;
    let n = data.len();
    let mut i = 0;
    while i < n {
        // The next run of at least MIN_RUN equal bytes, if any, starting at or after i.
        let mut run_start = i;
        let mut run_len = 0;
        while run_start < n {
            run_len = 1;
            while run_start + run_len < n
                && run_len < 127
                && data[run_start + run_len] == data[run_start]
            {
                run_len += 1;
            }
            if run_len >= MIN_RUN {
                break;
            }
            run_start += run_len;
        }
        // Literals up to the run (or the end), at most 128 at a time.
        let literal_end = if run_len >= MIN_RUN { run_start } else { n };
        while i < literal_end {
            let k = (literal_end - i).min(128);
            out.push(k as u8);
            out.extend_from_slice(&data[i..i + k]);
            i += k;
        }
        if run_len >= MIN_RUN && run_start < n {
            out.push(128 + run_len as u8);
            out.push(data[run_start]);
            i = run_start + run_len;
        }
    }
}
