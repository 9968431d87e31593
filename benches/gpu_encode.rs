//! Benchmark (not a timed test): the GPU texel formats on a 512-face GGX chain (all ten
//! levels), against the GGX filtering that made it. Target: BC6H-encoding the chain takes less
//! than filtering it. Also BC7, the packed HDR formats and Zstandard levels, and the PSNR of
//! each lossy format at level 0. Run with `cargo bench --bench gpu_encode` (add `--features astc`
//! for ASTC HDR 4x4 and 6x6, `--features uastc` for those and UASTC HDR 4x4).

use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::filter::{self, ChainOptions, FilterKind};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, ktx2, GpuFormat};
use cubeforge::internals::synthetic;
use std::time::Instant;

fn main() {
    println!("threads: {}", rayon::current_num_threads());
    let base = CubeMap::from_fn(512, synthetic::demo_sky);
    let ggx = ChainOptions {
        filter: FilterKind::Ggx,
        ..ChainOptions::default()
    };
    let t = Instant::now();
    let (chain, _) = filter::prefilter(&base, &ggx, &|_| {});
    let filtering = t.elapsed().as_secs_f64();
    println!(
        "ggx 512 filter: {filtering:.3} s ({} levels)",
        chain.levels.len()
    );
    let texels: usize = chain
        .levels
        .iter()
        .map(|l| 6 * l[0].width * l[0].width)
        .sum();
    let faces: Vec<&Image> = chain.levels[0].iter().collect();
    let astc: &[(GpuFormat, Option<i32>)] = if cfg!(feature = "uastc") {
        &[
            (GpuFormat::AstcHdr4x4, None),
            (GpuFormat::AstcHdr6x6, None),
            (GpuFormat::UastcHdr4x4, None),
            (GpuFormat::UastcHdr4x4, Some(19)),
        ]
    } else if cfg!(feature = "astc") {
        &[(GpuFormat::AstcHdr4x4, None), (GpuFormat::AstcHdr6x6, None)]
    } else {
        &[]
    };
    for &(format, zstd) in [
        (GpuFormat::Bc6h, None),
        (GpuFormat::Bc6h, Some(19)),
        (GpuFormat::Bc7Srgb, None),
        (GpuFormat::Rgb9e5, None),
        (GpuFormat::Rg11b10, None),
        (GpuFormat::Rgba16f, None),
        (GpuFormat::Rgba16f, Some(3)),
        (GpuFormat::Rgba16f, Some(9)),
        (GpuFormat::Rgba16f, Some(19)),
    ]
    .iter()
    .chain(astc)
    {
        let t = Instant::now();
        let bytes = ktx2::encode_cube_with(&chain, format, zstd, &[]).expect("encodes");
        let s = t.elapsed().as_secs_f64();
        let quality = if format.is_lossy() {
            let db = io::container_psnr(&bytes, format, &faces).unwrap_or(f64::NAN);
            format!(", PSNR {db:.2} dB")
        } else {
            String::new()
        };
        let z = zstd.map(|l| format!(" zstd {l}")).unwrap_or_default();
        println!(
            "{}{z}: {s:.3} s ({:.1} M texels/s, {:.2} of the filter time), {} bytes{quality}",
            format.name(),
            texels as f64 / s / 1e6,
            s / filtering,
            bytes.len()
        );
    }
}
