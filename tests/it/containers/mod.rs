//! KTX2 and DDS cube-map containers: round trips of every level in every format, hostile and
//! truncated files (errors naming the file, never a panic), and checks by independent readers
//! (ktx-parse for KTX2, Pillow and nvddsinfo for DDS): skipped with a line on stderr when one is
//! not installed, failed when CI is set.
//!
//! This module holds the test cubes and the encode/decode helpers every part uses; the tests
//! are split by topic below it.

mod hostile;
mod layout;
mod readers;
mod round_trips;

use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::image::{linear_to_srgb, Image};
use cubeforge::internals::io::{
    self, dds, ktx2, Decoded, FileFormat, GpuFormat, Limits, ReadOptions,
};
use glam::Vec4;
use std::path::Path;

const FORMATS: [GpuFormat; 4] = [
    GpuFormat::Rgba16f,
    GpuFormat::Rgba32f,
    GpuFormat::Rgba8Srgb,
    GpuFormat::Rgba8,
];

/// An 8x8 cube with its full chain (8, 4, 2, 1), different on every face and texel. Float
/// formats get values above 1 as well.
fn test_cube(format: GpuFormat) -> CubeMap {
    let scale = match format {
        GpuFormat::Rgba16f | GpuFormat::Rgba32f => 6.0,
        _ => 1.0,
    };
    CubeMap::from_fn(8, move |d| {
        Vec4::new(
            scale * (0.5 + 0.5 * d.x),
            scale * (0.5 + 0.5 * d.y),
            scale * (0.5 + 0.5 * d.z),
            0.2 + 0.7 * (d.x * d.y).abs(),
        )
    })
    .with_box_mips(None)
}

/// Checks every texel of every face of every level, within what `format` can hold.
fn assert_same(original: &CubeMap, decoded: &CubeMap, format: GpuFormat) {
    assert_eq!(decoded.levels.len(), original.levels.len(), "level count");
    for (l, (a, b)) in original.levels.iter().zip(&decoded.levels).enumerate() {
        for f in 0..6 {
            assert_eq!(
                (b[f].width, b[f].height),
                (a[f].width, a[f].height),
                "level {l} face {f} size"
            );
            for (i, (pa, pb)) in a[f].pixels.iter().zip(&b[f].pixels).enumerate() {
                for c in 0..4 {
                    let (x, y) = (pa[c], pb[c]);
                    let ok = match format {
                        GpuFormat::Rgba32f => x == y,
                        GpuFormat::Rgba16f => half::f16::from_f32(x).to_f32() == y,
                        GpuFormat::Rgba8 => (x - y).abs() <= 0.5 / 255.0 + 1e-6,
                        GpuFormat::Rgba8Srgb if c < 3 => {
                            (linear_to_srgb(x) - linear_to_srgb(y)).abs() <= 0.5 / 255.0 + 1e-5
                        }
                        GpuFormat::Rgba8Srgb => (x - y).abs() <= 0.5 / 255.0 + 1e-6,
                        _ => {
                            unreachable!("the plain formats (tests/it/gpu_formats.rs has the rest)")
                        }
                    };
                    assert!(
                        ok,
                        "{}: level {l} face {f} texel {i} channel {c}: wrote {x}, read {y}",
                        format.name()
                    );
                }
            }
        }
    }
}

fn cube_of(decoded: Decoded) -> CubeMap {
    match decoded {
        Decoded::Cube(c) => c,
        Decoded::Image(_) => panic!("a container decoded to a single image"),
    }
}

type DecodeFn = fn(&[u8], &Path, &Limits) -> cubeforge::Result<(Decoded, io::Meta)>;

fn encode(kind: FileFormat, cube: &CubeMap, format: GpuFormat) -> Vec<u8> {
    match kind {
        FileFormat::Ktx2 => ktx2::encode(cube, format),
        FileFormat::Dds => dds::encode(cube, format).expect("DDS encode"),
        _ => unreachable!(),
    }
}

fn decoder(kind: FileFormat) -> DecodeFn {
    match kind {
        FileFormat::Ktx2 => ktx2::decode,
        _ => dds::decode,
    }
}
