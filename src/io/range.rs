//! The range a file can hold: the largest value of each format, counts of the values an
//! encoder clamps, and the warning that says how to keep them.

use super::{babylon_env, ExrFloat, FileFormat, GpuFormat, WriteOptions, HALF_MAX};
use crate::image::Image;
use std::path::Path;

/// The largest magnitude `format` (with `gpu` for containers) stores as a finite float; None
/// where values are clamped to [0, 1] as a matter of course (8-bit formats, BC7).
pub fn largest_value(format: FileFormat, gpu: GpuFormat) -> Option<f32> {
    match format {
        FileFormat::Exr => Some(HALF_MAX),
        FileFormat::Hdr | FileFormat::UltraHdr => Some(f32::MAX),
        FileFormat::Env => Some(babylon_env::RGBD_MAX),
        FileFormat::Ktx2 | FileFormat::Dds | FileFormat::Ktx1 => gpu.largest_value(),
        _ => None,
    }
}

/// How many channel values of `images` are NaN or beyond +-`max`: what the encoders clamp.
pub fn count_out_of_range<'a>(images: impl IntoIterator<Item = &'a Image>, max: f32) -> u64 {
    count_outside(images, -max, max, 4)
}

/// How many of the first `channels` values of each texel are NaN or outside [`min`, `max`].
/// Counted per channel in float lanes over runs of texels (exact: a run's counts stay far below
/// 2^24), which compiles to a few vector instructions a texel; a count per texel through a
/// bit mask did not vectorise and read the faces at half the memory's speed.
fn count_outside<'a>(
    images: impl IntoIterator<Item = &'a Image>,
    min: f32,
    max: f32,
    channels: usize,
) -> u64 {
    use glam::Vec4;
    use rayon::prelude::*;
    let keep = Vec4::from_array(std::array::from_fn(|c| f32::from(u8::from(c < channels))));
    let (lo, hi) = (Vec4::splat(min), Vec4::splat(max));
    images
        .into_iter()
        .map(|img| {
            img.pixels
                .par_chunks(1 << 12)
                .map(|run| {
                    let lanes = run.iter().fold(Vec4::ZERO, |n, p| {
                        // NaN compares false: it is not inside.
                        let inside = p.cmpge(lo) & p.cmple(hi);
                        n + Vec4::select(inside, Vec4::ZERO, Vec4::ONE)
                    });
                    (lanes * keep).element_sum() as u64
                })
                .sum::<u64>()
        })
        .sum()
}

/// The warning for values an output clamps: how many are negative or beyond the largest the
/// format holds, and how to keep them (a wider format, or `--exposure` to scale them down).
/// Unsigned float formats (BC6H, E5B9G9R9, B10G11R11) count negative values too, and only the
/// RGB they store. None when every value fits.
pub fn clamp_warning<'a>(
    path: &Path,
    format: FileFormat,
    gpu: GpuFormat,
    images: impl IntoIterator<Item = &'a Image> + Clone,
) -> Option<String> {
    let write = WriteOptions {
        gpu_format: gpu,
        ..Default::default()
    };
    clamp_warning_with(path, format, &write, images)
}

/// [`clamp_warning`] for the options a file is written with (EXR's sample type among them).
pub fn clamp_warning_with<'a>(
    path: &Path,
    format: FileFormat,
    write: &WriteOptions,
    images: impl IntoIterator<Item = &'a Image> + Clone,
) -> Option<String> {
    use crate::error::param;
    let gpu = write.gpu_format;
    let max = match (format, write.exr_float, write.hdr_encoding) {
        (_, _, Some(e)) => e.largest(),
        (FileFormat::Exr, ExrFloat::F32, _) => f32::MAX,
        _ => largest_value(format, gpu)?,
    };
    let unsigned = format.is_container() && gpu.is_unsigned_float();
    let n = if unsigned {
        count_outside(images.clone(), 0.0, max, 3)
    } else {
        count_out_of_range(images.clone(), max)
    };
    if n == 0 {
        return None;
    }
    let top = images
        .into_iter()
        .flat_map(|img| img.pixels.iter())
        .map(|p| p.x.max(p.y).max(p.z))
        .filter(|v| v.is_finite())
        .fold(0f32, f32::max);
    let scale = (top > max).then(|| {
        let stops = (top / max).log2().ceil().max(1.0);
        let top = if top >= 1e6 {
            format!("{top:.2e}")
        } else {
            format!("{top:.0}")
        };
        format!(
            "{} lowered by {stops} brings the brightest ({top}) within it",
            param("exposure"),
        )
    });
    let wider = match format {
        _ if write.hdr_encoding.is_some() => Some(format!(
            "{}a float format ({} rgba16f, EXR) keeps them all",
            if max < babylon_env::RGBD_MAX {
                "rgbd keeps up to 255; "
            } else {
                ""
            },
            param("gpu_format")
        )),
        FileFormat::Exr if max == HALF_MAX => {
            Some(format!("{} f32 keeps them", param("exr_float")))
        }
        FileFormat::Ktx2 | FileFormat::Dds if max < f32::MAX => {
            Some(format!("{} rgba32f keeps them", param("gpu_format")))
        }
        _ => None,
    };
    let hint: Vec<String> = [wider, scale].into_iter().flatten().collect();
    let hint = if hint.is_empty() {
        String::new()
    } else {
        format!(": {}", hint.join("; "))
    };
    Some(if let Some(e) = write.hdr_encoding {
        format!(
            "{}: {n} values beyond {max} (the largest {}) written as that value{hint}",
            crate::error::shown(path),
            e.name().to_uppercase()
        )
    } else if unsigned {
        format!(
            "{}: {n} values negative or beyond {max} (the range of {}) written as 0 or that value{hint}",
            crate::error::shown(path),
            gpu.name()
        )
    } else {
        format!(
            "{}: {n} values beyond {} (the largest {}) written as that value{hint}",
            crate::error::shown(path),
            if max == HALF_MAX {
                "65504"
            } else if max == babylon_env::RGBD_MAX {
                "255"
            } else {
                "3.4e38"
            },
            if max == HALF_MAX {
                "half float"
            } else if max == babylon_env::RGBD_MAX {
                "RGBD value"
            } else {
                "float"
            }
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane counts agree with a count value by value, for NaN, infinities, the bounds
    /// themselves, -0.0 and ordinary values, in images of several runs (and a partial one).
    #[test]
    fn out_of_range_counts_match_a_plain_count() {
        let special = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            HALF_MAX,
            -HALF_MAX,
            HALF_MAX * 1.0001,
            -0.0,
            0.0,
            1e-30,
            -1e-30,
            7.5,
            -3.0,
        ];
        let img = |n: usize, seed: usize| {
            let mut img = Image::new(n, 1);
            for (i, p) in img.pixels.iter_mut().enumerate() {
                let v = |c: usize| special[(i * 7 + c * 3 + seed) % special.len()];
                *p = glam::Vec4::new(v(0), v(1), v(2), v(3));
            }
            img
        };
        let images = [img(10_007, 0), img(1, 5), img(4096 * 3, 2)];
        let plain = |min: f32, max: f32, channels: usize| -> u64 {
            let inside = |v: f32| v >= min && v <= max;
            images
                .iter()
                .flat_map(|i| &i.pixels)
                .map(|p| (0..channels).filter(|&c| !inside(p[c])).count() as u64)
                .sum()
        };
        for (min, max, channels) in [(-HALF_MAX, HALF_MAX, 4), (0.0, HALF_MAX, 3), (0.0, 1.0, 4)] {
            let n = count_outside(&images, min, max, channels);
            assert_eq!(
                n,
                plain(min, max, channels),
                "[{min}, {max}], {channels} channels"
            );
            assert!(n > 0);
        }
        assert_eq!(
            count_out_of_range(&images, HALF_MAX),
            plain(-HALF_MAX, HALF_MAX, 4)
        );
    }
}
