//! Resizing a plane of values to the output size: box filter down, bilinear up, one axis at a
//! time, so an image source of any size fits the map.

#![warn(missing_docs)]

use rayon::prelude::*;

/// Resizes a plane: each axis on its own, with an area (box) filter when it shrinks and
/// bilinear interpolation between texel centres (edges clamped) when it grows.
pub fn resize(src: &[f32], sw: usize, sh: usize, dw: usize, dh: usize) -> Vec<f32> {
    if sw == dw && sh == dh {
        return src.to_vec();
    }
    // Horizontal pass: sh rows of dw.
    let taps_x = taps(sw, dw);
    let mut mid = vec![0.0f32; dw * sh];
    if dw > 0 {
        mid.par_chunks_mut(dw).enumerate().for_each(|(y, row)| {
            let s = &src[y * sw..(y + 1) * sw];
            for (x, out) in row.iter_mut().enumerate() {
                *out = taps_x[x]
                    .iter()
                    .map(|&(i, wt)| s[i] as f64 * wt)
                    .sum::<f64>() as f32;
            }
        });
    }
    // Vertical pass: dh rows of dw.
    let taps_y = taps(sh, dh);
    let mut out = vec![0.0f32; dw * dh];
    if dw > 0 {
        out.par_chunks_mut(dw).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                *o = taps_y[y]
                    .iter()
                    .map(|&(j, wt)| mid[j * dw + x] as f64 * wt)
                    .sum::<f64>() as f32;
            }
        });
    }
    out
}

/// For each output index along an axis, the source indices and their weights.
fn taps(src: usize, dst: usize) -> Vec<Vec<(usize, f64)>> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|i| {
            if dst == src {
                vec![(i, 1.0)]
            } else if dst < src {
                // The source interval [i * scale, (i + 1) * scale), each texel by its overlap.
                let (a, b) = (i as f64 * scale, (i + 1) as f64 * scale);
                let first = a.floor() as usize;
                let last = (b.ceil() as usize).min(src);
                (first..last)
                    .filter_map(|j| {
                        let overlap = (b.min(j as f64 + 1.0) - a.max(j as f64)) / scale;
                        (overlap > 0.0).then_some((j, overlap))
                    })
                    .collect()
            } else {
                let x = (i as f64 + 0.5) * scale - 0.5;
                let x0 = x.floor();
                let f = x - x0;
                let clamp = |j: f64| j.clamp(0.0, src as f64 - 1.0) as usize;
                vec![(clamp(x0), 1.0 - f), (clamp(x0 + 1.0), f)]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_sum_to_one() {
        for (s, d) in [(7, 3), (3, 7), (512, 100), (5, 4), (1, 9), (9, 1)] {
            for t in taps(s, d) {
                let sum: f64 = t.iter().map(|p| p.1).sum();
                assert!((sum - 1.0).abs() < 1e-12, "{s}->{d}: {sum}");
                assert!(t.iter().all(|p| p.0 < s));
            }
        }
    }
}
