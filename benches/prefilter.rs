//! Benchmark (not a timed test): the jobs of the speed issue, each from a 4096 x 2048 HDR
//! panorama with a sun (the real esplanade enlarged 8x; the demo sky drawn at 4K without
//! ../shared), stage by stage, best of a few runs, with the issue's reference figures (the
//! CEO's 2-core machine, cmft built -O3 in the same run) printed beside them, and the
//! previous code paths timed in the same run where they still exist. Then a Charlie chain
//! and the 128 BRDF lookup tables. Honours RAYON_NUM_THREADS (run it with 2 and 16).
//! Run with `cargo bench --bench prefilter`.

use cubeforge::internals::convert::{self, Loaded};
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::filter::{self, brute, lobe, ChainOptions, FilterKind, LightingModel};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{Decoded, ReadOptions, WriteOptions};
use cubeforge::internals::layout::Projection;
use cubeforge::internals::resample::{FnEnv, Resampler};
use cubeforge::internals::synthetic;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Runs per measurement (the best counts).
const RUNS: usize = 3;

/// The best wall time of `RUNS` calls of `f`, and its last result.
fn best<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut time = f64::MAX;
    let mut out = None;
    for _ in 0..RUNS {
        let t = Instant::now();
        let r = f();
        time = time.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (time, out.expect("RUNS > 0"))
}

fn main() {
    let threads = rayon::current_num_threads();
    println!("threads: {threads} (RAYON_NUM_THREADS), best of {RUNS}");
    println!("reference: the issue's figures, cubeforge and cmft on the CEO's 2-core machine");
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bench-prefilter");
    std::fs::create_dir_all(&dir).unwrap();
    let pano = panorama(&dir);
    let read = ReadOptions::default();
    let (decode, loaded) =
        best(|| convert::load(std::slice::from_ref(&pano), None, &read).unwrap());
    println!("{}: decode {decode:.3} s", pano.display());

    irradiance(&loaded, decode);
    let cosine = ChainOptions {
        filter: FilterKind::Cosine,
        lighting: LightingModel::Phongbrdf,
        ..ChainOptions::default()
    };
    let base256 = chain(
        "cosine phongbrdf 256, 9 levels",
        &loaded,
        decode,
        256,
        ChainOptions {
            levels: Some(9),
            ..cosine
        },
        "0.99 s, cmft 12.0 s (12x); aim >= 20x cmft",
    );
    level0(&base256, &cosine);
    chain(
        "cosine phongbrdf 512, 10 levels",
        &loaded,
        decode,
        512,
        ChainOptions {
            levels: Some(10),
            ..cosine
        },
        "2.74 s, cmft 151 s (55x); keep",
    );
    chain(
        "GGX 512, 10 levels",
        &loaded,
        decode,
        512,
        ChainOptions {
            filter: FilterKind::Ggx,
            levels: Some(10),
            ..ChainOptions::default()
        },
        "1.83 s, cmgen 12x slower; aim <= 1 s",
    );
    let (t, _) = best(|| {
        let opts = ChainOptions {
            filter: FilterKind::Charlie,
            min_size: Some(16),
            ..ChainOptions::default()
        };
        filter::prefilter(&base256, &opts, &|_| {})
    });
    println!("charlie 256, min size 16 (5 levels): filter {t:.3} s");
    lut();
}

/// The 4K panorama: esplanade (sun about 25000) enlarged 8x, or the demo sky.
fn panorama(dir: &Path) -> PathBuf {
    let src =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real/hdr/esplanade.hdr");
    let (name, img): (&str, Box<dyn Fn() -> Image>) = if src.exists() {
        (
            "esplanade4k.hdr",
            Box::new(move || {
                let (Decoded::Image(small), _) =
                    cubeforge::internals::convert::read(&src, &ReadOptions::default()).unwrap()
                else {
                    unreachable!()
                };
                Image::from_fn(4096, 2048, |x, y| {
                    small.bilinear((x as f32 + 0.5) / 8.0, (y as f32 + 0.5) / 8.0, true)
                })
            }),
        )
    } else {
        println!("../shared/fixtures/real is absent: the demo sky instead of esplanade");
        (
            "sky4k.hdr",
            Box::new(|| {
                Resampler::default().to_projection(
                    &FnEnv(synthetic::demo_sky),
                    Projection::Equirect,
                    4096,
                    2048,
                )
            }),
        )
    };
    let path = dir.join(name);
    if !path.exists() {
        let bytes =
            cubeforge::internals::output::encode_image(&path, &img(), &WriteOptions::default())
                .unwrap();
        std::fs::write(&path, bytes).unwrap();
    }
    path
}

/// Irradiance, 32 px faces from a 256-face base (what `cubeforge irradiance` makes of a 4K
/// panorama), and the previous brute force (every texel of a 64-face copy, the sun reduced
/// with the rest, one powf per texel pair) in the same run.
fn irradiance(loaded: &Loaded, decode: f64) {
    let (resample, base) = best(|| convert::to_cube(loaded, 256, &Resampler::default()));
    let (new, _) = best(|| filter::irradiance(&base, 32, filter::IrradianceMethod::Brute));
    let (old, _) = best(|| {
        let chain = CubeMap {
            levels: vec![base.levels[0].clone()],
        }
        .with_box_mips(Some(3));
        let _sh = filter::sh::project(&base);
        let copy = CubeMap {
            levels: vec![chain.levels[2].clone()],
        };
        brute::convolve(&copy, lobe::Lobe::CosinePower { power: 1.0 }, 32)
    });
    let total = decode + resample + new;
    println!(
        "irradiance 256 -> 32: filter {new:.3} s (previous brute force {old:.3} s, {:.1}x); \
         with decode and resample {total:.3} s",
        old / new
    );
    println!("  issue: 0.86 s, cmft 0.85 s (1.0x); aim >= 3x cmft");
}

/// A chain from the panorama: resample to `size` faces, filter; stage times and the total
/// beside the issue's figures (another machine's: compare ratios, not seconds).
fn chain(
    name: &str,
    loaded: &Loaded,
    decode: f64,
    size: usize,
    opts: ChainOptions,
    issue: &str,
) -> CubeMap {
    let (resample, base) = best(|| convert::to_cube(loaded, size, &Resampler::default()));
    let (filter, (chain, infos)) = best(|| filter::prefilter(&base, &opts, &|_| {}));
    let total = decode + resample + filter;
    let exact = infos
        .iter()
        .filter(|i| i.samples.is_none() && (i.power.is_some() || i.sigma.is_some()))
        .count();
    print!(
        "{name}: resample {resample:.3} s, filter {filter:.3} s ({} levels, {exact} exact sums); \
         total {total:.3} s",
        chain.levels.len()
    );
    println!();
    println!("  issue: {issue}");
    base
}

/// Level 0 of the 256 cosine chain (a 2049-power lobe) as the chain sums it, exactly over the
/// texels it covers, and as 64 filtered importance samples did.
fn level0(base: &CubeMap, cosine: &ChainOptions) {
    let one = ChainOptions {
        levels: Some(1),
        ..*cosine
    };
    let (exact, _) = best(|| filter::prefilter(base, &one, &|_| {}));
    let l = lobe::Lobe::CosinePower { power: 2049.0 };
    let k = lobe::Kernel::new(l, 64, base.size());
    let src = lobe::source_sampler(base);
    let (sampled, _) = best(|| lobe::filter_level(&src, &k, base.size(), l, &Default::default()));
    println!(
        "  level 0 alone: exact sum {exact:.3} s (with the sun split and the box mips), \
         64 samples {sampled:.3} s"
    );
}

/// The 128 lookup tables at the default sample count.
fn lut() {
    use cubeforge::internals::lut::{self, LutOptions};
    let opts = LutOptions::default();
    let (dfg, _) = best(|| lut::dfg(128, &opts));
    let (sheen, _) = best(|| lut::charlie(128, &opts));
    println!(
        "lut 128, {} samples (target well under 1 s): dfg {dfg:.3} s, charlie {sheen:.3} s",
        opts.samples
    );
}
