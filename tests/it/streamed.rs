//! Issue 47: a panorama reduced as it is decoded (`convert::stream`) gives the cube the whole
//! image gives: the same flux, the same texels within the antialiasing's difference, the
//! same bytes on any thread count. On the real ZIP, DWAB and Radiance .hdr panoramas (skipped when
//! ../shared/fixtures/real is absent).

use crate::common;
use cubeforge::internals::convert::{self, stream, Source};
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::io::ReadOptions;
use cubeforge::internals::resample::Resampler;
use std::path::PathBuf;

/// The finest texel of a cube of `size`: a face's corner.
fn corner(size: usize) -> f32 {
    2.0 * std::f32::consts::SQRT_2 / 3.0 / size as f32
}

fn flux(cube: &CubeMap) -> [f64; 3] {
    convert::Loaded::from_cube(cube.clone()).mean_radiance()
}

fn panoramas() -> Vec<PathBuf> {
    let Some(real) = common::real_dir() else {
        println!("SKIPPED streamed: ../shared/fixtures/real not found");
        return vec![];
    };
    [
        "zip/esplanade.exr",
        "zip/park.exr",
        "zip/city.exr",
        "dwab/venice.exr",
        "hdr/esplanade.hdr",
        "hdr/park.hdr",
    ]
    .iter()
    .map(|f| real.join(f))
    .collect()
}

/// Flux bound 0.5% (the flux tests'). Mean texel difference measured at most 1.64% of the
/// map's (esplanade, faces of 8: the box-reduced copy and fewer taps rather than the
/// pyramid's), bound 2%.
#[test]
fn streamed_panoramas_give_the_whole_images_cube() {
    let opts = ReadOptions::default();
    let r = Resampler::default();
    for path in panoramas() {
        let whole = convert::load(std::slice::from_ref(&path), None, &opts).expect("loads");
        for size in [8, 16] {
            let reduced = stream::load(&path, &opts, corner(size))
                .expect("reads")
                .expect("512 x 256 reduces for faces of 16 and less");
            assert!(matches!(reduced.source, Source::Reduced(_)));
            assert_eq!(reduced.face_size(), whole.face_size());
            let (a, b) = (
                convert::to_cube(&whole, size, &r),
                convert::to_cube(&reduced, size, &r),
            );
            let (fa, fb) = (flux(&a), flux(&b));
            for c in 0..3 {
                let rel = (fb[c] - fa[c]).abs() / fa[c].max(1e-12);
                assert!(
                    rel < 0.005,
                    "{} size {size}: flux {fa:?} vs {fb:?}",
                    path.display()
                );
            }
            let (mut diff, mut sum) = (0.0f64, 0.0f64);
            for (fa, fb) in a.levels[0].iter().zip(&b.levels[0]) {
                for (p, q) in fa.pixels.iter().zip(&fb.pixels) {
                    diff += (*p - *q).truncate().abs().element_sum() as f64;
                    sum += p.truncate().element_sum() as f64;
                }
            }
            println!(
                "{} {size}: mean texel difference {:.3}%",
                path.display(),
                100.0 * diff / sum
            );
            assert!(
                diff < 0.02 * sum,
                "{}: texels differ by {diff} of {sum}",
                path.display()
            );
            // The input's own flux, peaks included, as the whole image's.
            let (ma, mb) = (whole.mean_radiance(), reduced.mean_radiance());
            for c in 0..3 {
                assert!((mb[c] - ma[c]).abs() <= 1e-3 * ma[c], "{ma:?} vs {mb:?}");
            }
        }
    }
}

/// The same bytes on 1 and 3 threads.
#[test]
fn streamed_reduction_is_the_same_on_any_thread_count() {
    let Some(path) = panoramas().into_iter().next() else {
        return;
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let l = stream::load(&path, &ReadOptions::default(), corner(16))
                .unwrap()
                .unwrap();
            let cube = convert::to_cube(&l, 16, &Resampler::default());
            cube.levels[0]
                .iter()
                .flat_map(|f| f.pixels.clone())
                .collect::<Vec<_>>()
        })
    };
    assert!(run(1) == run(3), "outputs differ by thread count");
}
