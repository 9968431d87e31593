//! Benchmark (not a timed test): prefilter a 512-face HDR cube map into a full GGX chain and a
//! full cosine chain (and a 256 cosine chain, cmft's 5.8 s case, and a 256 Charlie chain down
//! to 16 px); seconds per level and samples per second; and the 128 BRDF lookup tables.
//! Run with `cargo bench --bench prefilter`.

use cubeforge::cube::CubeMap;
use cubeforge::filter::{self, ChainOptions, FilterKind, LightingModel};
use cubeforge::synthetic;
use std::time::Instant;

fn run(name: &str, base: &CubeMap, opts: ChainOptions) {
    let plan = filter::plan(&opts, base.size());
    let t0 = Instant::now();
    let (chain, infos) = filter::prefilter(base, &opts, &|_| {});
    let total = t0.elapsed().as_secs_f64();
    let samples: f64 = infos
        .iter()
        .map(|i| (6 * i.size * i.size) as f64 * i.samples.unwrap_or(0) as f64)
        .sum();
    println!(
        "{name}: {} levels in {total:.3} s, {:.1} M samples/s",
        chain.levels.len(),
        samples / total / 1e6
    );
    // Per-level cost, each level on its own (the chain itself runs levels in parallel).
    for (info, lobe) in plan {
        if let Some(l) = lobe {
            let src = filter::lobe::source_sampler(base);
            let k = filter::lobe::Kernel::new(l, info.samples.unwrap(), base.size());
            let t = Instant::now();
            let _ = filter::lobe::filter_level(&src, &k, info.size, l, &Default::default());
            println!(
                "  level {:2} size {:4}: {:.3} s ({} taps)",
                info.level,
                info.size,
                t.elapsed().as_secs_f64(),
                k.taps.len()
            );
        }
    }
}

fn main() {
    let base512 = CubeMap::from_fn(512, synthetic::demo_sky);
    let base256 = CubeMap::from_fn(256, synthetic::demo_sky);
    let ggx = ChainOptions {
        filter: FilterKind::Ggx,
        ..ChainOptions::default()
    };
    let cosine = ChainOptions {
        filter: FilterKind::Cosine,
        lighting: LightingModel::Phongbrdf,
        ..ChainOptions::default()
    };
    println!("threads: {}", rayon::current_num_threads());
    run("ggx 512 (target < 2 s)", &base512, ggx);
    run("cosine phongbrdf 256 (cmft 5.8 s)", &base256, cosine);
    run("cosine phongbrdf 512 (cmft 81 s)", &base512, cosine);
    let charlie = ChainOptions {
        filter: FilterKind::Charlie,
        min_size: Some(16),
        ..ChainOptions::default()
    };
    run("charlie 256, min size 16", &base256, charlie);
    lut();
}

/// The 128 lookup tables at the default sample count, best of 5.
fn lut() {
    use cubeforge::lut::{self, LutOptions};
    let opts = LutOptions::default();
    let best = |f: &dyn Fn()| {
        (0..5)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::MAX, f64::min)
    };
    let dfg = best(&|| drop(lut::dfg(128, &opts)));
    let sheen = best(&|| drop(lut::charlie(128, &opts)));
    println!(
        "lut 128, {} samples (target well under 1 s): dfg {dfg:.3} s, charlie {sheen:.3} s",
        opts.samples
    );
}
