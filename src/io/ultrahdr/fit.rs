//! The gain map fitted to the light. Each gain texel starts as the log2 of the radiance over
//! the SDR value (offsets included); then rounds of encode, decode, rebuild as the chosen reader
//! does, and correct move each texel by the log2 of the light its neighbourhood should hold
//! over the light it rebuilt. The correction is smooth, which the JPEG keeps (a texel-by-texel
//! one it turns to noise), and the round whose light reads back closest is kept: a sun's few
//! texels hold much of a sky's flux, and their codes are what the rounds settle.

use super::{decode_jpeg, flux_error, Gains, Reader, OFFSET};
use crate::image::Image;
use rayon::prelude::*;

/// The neighbourhood radius of the corrections, in texels.
const BLUR: isize = 2;

/// A gain map as written.
pub(super) struct Fitted {
    /// The JPEG of the gain map.
    pub jpeg: Vec<u8>,
    /// How its values become radiance.
    pub gains: Gains,
}

/// Fits a gain map of texels `scale` picture texels a side that takes `sdr` (the picture as a
/// reader decodes it) to
/// `img` as `reader` rebuilds it, keeping the best of `rounds` + 1 tries (by the light,
/// weighed as an equirect's where `equirect`); `encode` makes the JPEG of RGB codes.
pub(super) fn fit(
    img: &Image,
    sdr: &Image,
    reader: Reader,
    equirect: bool,
    scale: usize,
    rounds: usize,
    encode: impl Fn(&[u8], usize, usize) -> Result<Vec<u8>, String>,
) -> Result<Fitted, String> {
    let (w, h) = (img.width, img.height);
    let (gw, gh) = (w.div_ceil(scale), h.div_ceil(scale));
    // The light of the picture texels [x0, x1) x [y0, y1) wanted and rebuilt (`back`), per
    // channel, offsets included.
    let window = |back: &Image, x0: isize, x1: isize, y0: isize, y1: isize| {
        let (mut num, mut den) = ([0.0f64; 3], [0.0f64; 3]);
        for y in y0.max(0)..y1.min(h as isize) {
            for x in x0.max(0)..x1.min(w as isize) {
                let i = y as usize * w + x as usize;
                let (p, q) = (img.pixels[i], back.pixels[i]);
                let (p, q) = ([p.x, p.y, p.z], [q.x, q.y, q.z]);
                for c in 0..3 {
                    num[c] += p[c].max(0.0) as f64 + OFFSET;
                    den[c] += q[c] as f64 + OFFSET;
                }
            }
        }
        [0, 1, 2].map(|c| (num[c] / den[c]).log2())
    };
    // Each texel starts as its block's light over its block's SDR light.
    let s = scale as isize;
    let mut target: Vec<[f32; 3]> = (0..gh as isize)
        .into_par_iter()
        .flat_map_iter(|j| {
            (0..gw as isize)
                .map(move |i| window(sdr, i * s, i * s + s, j * s, j * s + s).map(|v| v as f32))
        })
        .collect();
    // The range from single texels: the stretch asks more of a sun's texel than its block's.
    let ratio = |a: f32, b: f32| ((a.max(0.0) as f64 + OFFSET) / (b as f64 + OFFSET)).log2();
    let (lo, hi) = img
        .pixels
        .par_iter()
        .zip(sdr.pixels.par_iter())
        .map(|(p, q)| {
            let t = [ratio(p.x, q.x), ratio(p.y, q.y), ratio(p.z, q.z)];
            (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
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
    let mut best: Option<(f64, Vec<u8>)> = None;
    for round in 0..=rounds {
        let codes: Vec<u8> = target
            .par_iter()
            .flat_map_iter(|t| {
                t.map(|v| ((v as f64 - gains.lo[0]) * step).round().clamp(0.0, 255.0) as u8)
            })
            .collect();
        let jpeg = encode(&codes, gw, gh)?;
        let map = decode_jpeg(&jpeg, true, &crate::io::Limits::default())?;
        let back = gains.apply(sdr, &map, reader);
        let off = flux_error(img, &back, equirect)
            .iter()
            .fold(0.0, |m: f64, e| m.max(e.abs()));
        if best.as_ref().is_none_or(|b| off < b.0) {
            best = Some((off, jpeg));
        }
        if round == rounds {
            break;
        }
        // In place: a texel's correction reads the light, never the other texels' targets.
        target.par_chunks_mut(gw).enumerate().for_each(|(j, row)| {
            let j = j as isize;
            for (i, t) in row.iter_mut().enumerate() {
                let i = i as isize;
                let (x0, y0) = ((i - BLUR) * s, (j - BLUR) * s);
                let (x1, y1) = ((i + BLUR + 1) * s, (j + BLUR + 1) * s);
                let d = window(&back, x0, x1, y0, y1);
                for c in 0..3 {
                    t[c] += d[c] as f32;
                }
            }
        });
    }
    let (_, jpeg) = best.expect("at least one round");
    Ok(Fitted { jpeg, gains })
}
