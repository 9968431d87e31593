//! Every level of every prefiltered chain keeps each channel's light: a filter normalised over
//! the sphere keeps the mean radiance, so each level's flux (solid-angle-weighted mean
//! radiance) must be its base's, the 2 px and 1 px levels included, whose texels each stand
//! for a wide patch of the filtered environment rather than its value at their centres.

use crate::common;
use cubeforge::internals::convert::{self, Output};
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::filter::{self, ChainOptions, FilterKind};
use cubeforge::internals::flux::{mean_radiance, Grid};
use cubeforge::internals::io::ReadOptions;
use cubeforge::internals::layout::Kind;
use cubeforge::internals::resample::Resampler;

/// The largest relative change of any channel's flux between `level` and `want`.
fn change(level: &[cubeforge::internals::image::Image; 6], want: [f64; 3]) -> f64 {
    let got = mean_radiance(
        Grid::Cube(level[0].width),
        &level.iter().collect::<Vec<_>>(),
    );
    (0..3)
        .map(|c| (got[c] - want[c]).abs() / want[c].abs().max(1e-12))
        .fold(0.0, f64::max)
}

/// Each filter's chain of a 64-face cube of each real `.hdr` panorama (a sun among them, in
/// esplanade): every level's flux against level 0's. Measured before: GGX's 1 px level 11%
/// off, Charlie's 34%, cosine's 2 px 15% (texels held the filtered radiance at their centres);
/// with small levels filtered at 16 px and reduced, at most 0.6% (Charlie's 32 px level on
/// studio: the sampled estimate's error, which 1024 samples bring to 0.015%); each level is
/// then scaled to its base's flux. The brute-force tests (prefilter.rs) check the texels
/// themselves. Bound: 0.5% for every level.
#[test]
fn every_level_of_every_chain_keeps_each_channels_flux() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let mut names: Vec<_> = std::fs::read_dir(real.join("hdr"))
        .expect("lists")
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    let mut worst = (0.0f64, String::new());
    for path in &names {
        let loaded = convert::load(std::slice::from_ref(path), None, &ReadOptions::default())
            .expect("loads");
        let Output::Cube(base) = convert::convert(&loaded, Kind::Faces, 64, &Resampler::default())
        else {
            panic!("faces are a cube");
        };
        let want = mean_radiance(Grid::Cube(64), &base.levels[0].iter().collect::<Vec<_>>());
        for kind in [
            FilterKind::Box,
            FilterKind::Gaussian,
            FilterKind::Cosine,
            FilterKind::Ggx,
            FilterKind::Charlie,
        ] {
            let opts = ChainOptions {
                filter: kind,
                samples: std::env::var("CF_SAMPLES")
                    .ok()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(ChainOptions::default().samples),
                ..ChainOptions::default()
            };
            let (chain, _) = filter::prefilter(&base, &opts, &|_| {});
            let chain: &CubeMap = &chain;
            for (k, level) in chain.levels.iter().enumerate() {
                let e = change(level, want);
                println!(
                    "{} {} level {k} ({} px): {:+.3}%",
                    path.file_name().unwrap().to_string_lossy(),
                    kind.name(),
                    level[0].width,
                    e * 100.0
                );
                if e > worst.0 {
                    worst = (e, format!("{} {} level {k}", path.display(), kind.name()));
                }
            }
        }
    }
    println!("largest change {:.3}% ({})", worst.0 * 100.0, worst.1);
    assert!(worst.0 < 0.005, "{:.3}% at {}", worst.0 * 100.0, worst.1);
}
