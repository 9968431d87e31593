//! Display transforms for tone-mapped (8-bit, sRGB) outputs: an exposure in stops, then a
//! curve taking radiance to [0, 1]. EXR and HDR outputs keep linear radiance, scaled by the
//! exposure alone.

#![warn(missing_docs)]

use crate::image::Image;
use glam::Vec4;

/// The curve that takes exposed linear radiance to [0, 1] for an 8-bit output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Tonemap {
    /// Clip at 1 (values at or below 1 pass unchanged).
    #[default]
    None,
    /// Reinhard, per channel: x / (1 + x).
    Reinhard,
    /// Narkowicz's fit of the ACES filmic curve: x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14).
    Aces,
}

impl Tonemap {
    /// Maps one linear channel value (already exposed) to [0, 1].
    #[inline]
    pub fn curve(self, x: f32) -> f32 {
        let x = x.max(0.0);
        match self {
            Tonemap::None => x.min(1.0),
            Tonemap::Reinhard => x / (1.0 + x),
            Tonemap::Aces => {
                // Past 1e4 the curve is flat at 1; its squares would overflow near 1e19.
                let x = x.min(1e4);
                ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
            }
        }
    }

    /// The colour `c` (linear radiance) scaled by 2^`exposure` and mapped; alpha unchanged.
    #[inline]
    pub fn map(self, c: Vec4, exposure: f32) -> Vec4 {
        let k = exposure.exp2();
        Vec4::new(
            self.curve(c.x * k),
            self.curve(c.y * k),
            self.curve(c.z * k),
            c.w,
        )
    }
}

/// Applies exposure and curve to every pixel.
pub fn apply(img: &mut Image, tonemap: Tonemap, exposure: f32) {
    use rayon::prelude::*;
    img.pixels
        .par_iter_mut()
        .for_each(|p| *p = tonemap.map(*p, exposure));
}

/// Scales every pixel's radiance by 2^`exposure` (alpha unchanged): what `--exposure` does to
/// outputs that keep linear radiance (EXR, HDR, float containers).
pub fn scale(img: &mut Image, exposure: f32) {
    use rayon::prelude::*;
    let k = exposure.exp2();
    img.pixels.par_iter_mut().for_each(|p| {
        *p = Vec4::new(p.x * k, p.y * k, p.z * k, p.w);
    });
}

/// Texels that an 8-bit output clips to white: those with a channel above 1 (by more than one
/// 8-bit step) once exposed by 2^`exposure`, with the brightest channel value among them.
/// Tone curves other than `None` roll every value off below 1 and clip nothing.
pub fn clipped<'a>(
    images: impl IntoIterator<Item = &'a Image>,
    tonemap: Tonemap,
    exposure: f32,
) -> (u64, f32) {
    use rayon::prelude::*;
    if tonemap != Tonemap::None {
        return (0, 0.0);
    }
    let k = exposure.exp2();
    let limit = 1.0 + 1.0 / 255.0;
    images
        .into_iter()
        .map(|img| {
            img.pixels
                .par_chunks(4096)
                .map(|run| {
                    run.iter().fold((0u64, 0f32), |(n, top), p| {
                        let m = p.x.max(p.y).max(p.z) * k;
                        if m > limit {
                            (n + 1, top.max(m))
                        } else {
                            (n, top)
                        }
                    })
                })
                .reduce(|| (0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
        })
        .fold((0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_are_finite_and_in_range_for_every_input() {
        for t in [Tonemap::None, Tonemap::Reinhard, Tonemap::Aces] {
            for x in [
                0.0,
                1e-30,
                0.5,
                1.0,
                1e4,
                1e19,
                1e28 * 2f32.powi(32),
                f32::MAX,
            ] {
                let y = t.curve(x);
                assert!((0.0..=1.0).contains(&y), "{t:?}({x}) = {y}");
            }
            assert!(t.curve(1e30) >= t.curve(10.0), "{t:?} is monotone");
        }
    }
}
