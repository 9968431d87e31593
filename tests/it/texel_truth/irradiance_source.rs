//! The irradiance map's brute force sums a 64-face copy of a larger base, its HDR peaks split
//! off and added at the base's own resolution (`filter::diffuse`): against the clamped cosine
//! over every texel of the 128-face base itself (the reference, written apart), on the real
//! panoramas with and without a sun (16 px: at 32 px the largest is 0.43%, studio, and the
//! reference takes four times as long). docs/prefilter.md quotes the mean and the largest error.

use super::reference::{self, Lobe};
use super::{errors, to_cube};
use crate::common;
use cubeforge::internals::convert::{self, Output};
use cubeforge::internals::filter::{self, IrradianceMethod};
use cubeforge::internals::io::ReadOptions;
use cubeforge::internals::layout::Kind;
use cubeforge::internals::resample::Resampler;

/// The .hdr panoramas and the sunny OpenEXR ones.
const PANORAMAS: [&str; 8] = [
    "hdr/esplanade.hdr",
    "hdr/park.hdr",
    "hdr/studio.hdr",
    "hdr/venice.hdr",
    "dwab/sky.exr",
    "dwab/sunset.exr",
    "dwab/sunrise.exr",
    "dwab/dawn.exr",
];

#[test]
fn brute_irradiance_from_a_128_face_base_matches_every_texel() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let (mut mean, mut largest) = (0.0f64, 0.0f64);
    for name in PANORAMAS {
        let path = real.join(name);
        let loaded = convert::load(std::slice::from_ref(&path), None, &ReadOptions::default())
            .expect("loads");
        let Output::Cube(base) = convert::convert(&loaded, Kind::Faces, 128, &Resampler::default())
        else {
            panic!("faces are a cube");
        };
        let (map, _) = filter::irradiance(&base, 16, IrradianceMethod::Brute);
        let want = reference::convolve(&to_cube(&base.levels[0]), Lobe::Cosine(1.0), 16, 1);
        let (m, w, f) = errors(&to_cube(&map.levels[0]), &want);
        println!(
            "{name}: irradiance 16 px from a 128-face base, {:.3}% mean, {:.2}% largest, flux {:+.3}%",
            m * 100.0,
            w * 100.0,
            f * 100.0
        );
        assert!(m < 0.0005 && w < 0.011, "{name}: {m} mean, {w} largest");
        (mean, largest) = (mean.max(m), largest.max(w));
    }
    let text = format!(
        "within {:.2}% (mean) and {:.1}% (largest",
        mean * 100.0,
        largest * 100.0
    );
    crate::figures::check("docs/prefilter.md", "irradiance source", &text);
}
