//! The gain map fitted to the light. Each texel starts as the log2 of its radiance over its SDR
//! value (offsets included); then rounds of encode, decode, rebuild as the chosen reader does,
//! and correct move each texel by the log2 of the light its neighbourhood should hold over the
//! light it rebuilt. The correction is smooth, which the JPEG keeps (a texel-by-texel one it
//! turns to noise), and the round whose light reads back closest is kept: a sun's few texels
//! hold much of a sky's flux, and their codes are what the rounds settle.
//!
//! The gain map is the picture's size: three.js stretches a smaller one with the canvas's own
//! filter, whose light came out 1-3% under a bilinear stretch's.

use super::{decode_jpeg, flux_error, inner, Gains, Light, Reader, OFFSET};
use crate::image::Image;
use rayon::prelude::*;

/// The neighbourhood radius of the corrections, in texels.
const BLUR: usize = 2;

/// The share of each round's correction taken: a whole one overshoots where the JPEG moved a
/// sun's few codes, and the rounds then swing instead of settling.
const DAMPING: f32 = 0.5;

/// The light read back this close to the source's (largest channel error) ends the rounds.
const GOOD_ENOUGH: f64 = 0.0025;

/// A gain map as written.
pub(super) struct Fitted {
    /// The JPEG of the gain map.
    pub jpeg: Vec<u8>,
    /// How its values become radiance.
    pub gains: Gains,
    /// Each channel's light as the reader rebuilds it against the source's, minus 1.
    pub flux_error: [f64; 3],
}

/// Each texel's sum of `value` over the texels within `BLUR` of it (the window cut at the
/// edges), per channel: a row pass, then a column pass.
fn window_sums(w: usize, h: usize, value: impl Fn(usize) -> [f32; 3] + Sync) -> Vec<[f32; 3]> {
    let add = |a: [f32; 3], b: [f32; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let mut rows = vec![[0.0f32; 3]; w * h];
    rows.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, out) in row.iter_mut().enumerate() {
            let (a, b) = (x.saturating_sub(BLUR), (x + BLUR + 1).min(w));
            *out = (a..b).fold([0.0; 3], |s, i| add(s, value(y * w + i)));
        }
    });
    let mut out = vec![[0.0f32; 3]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let (a, b) = (y.saturating_sub(BLUR), (y + BLUR + 1).min(h));
        for (x, o) in row.iter_mut().enumerate() {
            *o = (a..b).fold([0.0; 3], |s, j| add(s, rows[j * w + x]));
        }
    });
    out
}

/// Fits a gain map the size of `sdr` (the picture as a reader decodes it) that takes it to
/// `img` as `reader` rebuilds it, keeping the best of `rounds` + 1 tries (by the light `light`
/// measures; one within [`GOOD_ENOUGH`] ends them); `encode` makes the JPEG of RGB codes.
pub(super) fn fit(
    img: &Image,
    sdr: &Image,
    reader: Reader,
    light_of: &Light,
    rounds: usize,
    encode: impl Fn(&[u8]) -> Result<Vec<u8>, String>,
) -> Result<Fitted, String> {
    let (w, h) = (img.width, img.height);
    let light = |p: glam::Vec4| [p.x, p.y, p.z].map(|v| v.max(0.0) + OFFSET as f32);
    let ratio = |a: f32, b: f32| ((a.max(0.0) as f64 + OFFSET) / (b as f64 + OFFSET)).log2();
    let mut target: Vec<[f32; 3]> = img
        .pixels
        .par_iter()
        .zip(sdr.pixels.par_iter())
        .map(|(p, q)| [ratio(p.x, q.x), ratio(p.y, q.y), ratio(p.z, q.z)].map(|v| v as f32))
        .collect();
    let (lo, hi) = target
        .par_iter()
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .reduce(|| (0.0, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    let (lo, hi) = (lo as f64, hi as f64);
    // An SDR source still gets a range (the format needs max > min); corrections a margin.
    let hi = hi.max(lo + 1.0 / 16.0);
    let margin = (hi - lo) / 64.0;
    let gains = Gains {
        lo: [lo - margin; 3],
        hi: [hi + margin; 3],
        gamma: [1.0; 3],
        k_sdr: [OFFSET; 3],
        k_hdr: [OFFSET; 3],
    };
    let step = 255.0 / (gains.hi[0] - gains.lo[0]);
    // The light each neighbourhood should hold, the same every round.
    let wanted = window_sums(w, h, |i| light(img.pixels[i]));
    let mut best: Option<(f64, [f64; 3], Vec<u8>)> = None;
    for round in 0..=rounds {
        let codes: Vec<u8> = target
            .par_iter()
            .flat_map_iter(|t| {
                t.map(|v| ((v as f64 - gains.lo[0]) * step).round().clamp(0.0, 255.0) as u8)
            })
            .collect();
        let jpeg = encode(&codes)?;
        let map = decode_jpeg(&jpeg, true, &crate::io::Limits::default()).map_err(|e| inner(&e))?;
        let back = gains.apply(sdr, &map, reader);
        drop(map);
        let errors = flux_error(img, &back, light_of);
        let off = errors.iter().fold(0.0, |m: f64, e| m.max(e.abs()));
        if best.as_ref().is_none_or(|b| off < b.0) {
            best = Some((off, errors, jpeg));
        }
        if round == rounds || off < GOOD_ENOUGH {
            break;
        }
        let rebuilt = window_sums(w, h, |i| light(back.pixels[i]));
        drop(back);
        target
            .par_iter_mut()
            .zip(wanted.par_iter().zip(rebuilt.par_iter()))
            .for_each(|(t, (n, d))| {
                for c in 0..3 {
                    t[c] += DAMPING * (n[c] / d[c]).log2();
                }
            });
    }
    let (_, flux_error, jpeg) = best.expect("at least one round");
    Ok(Fitted {
        jpeg,
        gains,
        flux_error,
    })
}
