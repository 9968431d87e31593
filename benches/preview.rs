//! Benchmark (not a timed test): `cubeforge preview` at 1024 x 1024, 4 samples per pixel, the
//! crystal (Fresnel + chromatic dispersion) material, on a 512 cube map of the demo sky; chrome
//! and the pbr gold for comparison.
//! Run with `cargo bench --bench preview`. Target: under 0.5 s on 2 cores.

use cubeforge::internals::cube::{CubeMap, CubeSampler};
use cubeforge::internals::preview::pbr::{LevelMapping, SplitSum};
use cubeforge::internals::preview::{self, material, Options, Shading, Surface};
use cubeforge::internals::synthetic;
use std::time::Instant;

/// CPU seconds this process has used (user + system, all threads), from /proc (Linux).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses): utime is the 12th, stime the 13th.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Best wall time of `runs`, and the mean CPU time per run (what a machine with the cores to
/// itself would spend; the wall time suffers when other processes share the cores).
fn best_of(runs: usize, mut f: impl FnMut()) -> (f64, Option<f64>) {
    let c0 = cpu_seconds();
    let best = (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::MAX, f64::min);
    let cpu = c0.zip(cpu_seconds()).map(|(a, b)| (b - a) / runs as f64);
    (best, cpu)
}

fn report(name: &str, t: f64, cpu: Option<f64>) {
    let threads = rayon::current_num_threads() as f64;
    match cpu {
        Some(c) => println!(
            "  {name:<52} {t:7.3} s wall, {c:6.3} s CPU = {:6.3} s on {threads} idle cores",
            c / threads
        ),
        None => println!("  {name:<52} {t:7.3} s"),
    }
}

fn main() {
    let cube = CubeMap::from_fn(512, synthetic::demo_sky);
    let chain = CubeSampler::new(&cube.clone().with_box_mips(None));
    let single = CubeSampler::new(&cube);
    let crystal = material::preset("crystal").unwrap();
    let opts = Options {
        size: 1024,
        samples: 4,
        ..Options::default()
    };
    let runs = 5;
    println!(
        "preview 1024 x 1024, 4 samples/pixel, best of {runs} on {} threads:",
        rayon::current_num_threads()
    );
    let cases: [(&str, &CubeSampler, Options); 4] = [
        ("crystal, per fragment", &single, opts),
        (
            "crystal, per fragment, 10-level chain + LOD bias 1",
            &chain,
            Options {
                lod_bias: 1.0,
                ..opts
            },
        ),
        (
            "crystal, per vertex, tessellation 64",
            &single,
            Options {
                shading: Shading::PerVertex,
                tessellation: 64,
                ..opts
            },
        ),
        ("chrome, per fragment", &single, opts),
    ];
    for (i, (name, env, o)) in cases.iter().enumerate() {
        let mat = if i == 3 {
            material::preset("chrome").unwrap()
        } else {
            crystal.clone()
        };
        let (t, cpu) = best_of(runs, || {
            let img = preview::render(*env, &mat, &Surface::default(), o).unwrap();
            std::hint::black_box(img);
        });
        report(name, t, cpu);
    }
    // pbr: a trilinear lookup at the roughness's level, the DFG table and the SH per sample
    // (the chain's levels read as roughness m / 9; the table made before timing).
    let gold = material::preset("gold").unwrap();
    let mapping = LevelMapping::levels((0..10).map(|m| m as f32 / 9.0).collect()).unwrap();
    let split = SplitSum::for_cube(&cube, mapping);
    let (t, cpu) = best_of(runs, || {
        let img = preview::render_lit(
            &chain,
            Some(&split),
            &gold,
            &Surface::default(),
            &opts,
            &|_| {},
        )
        .unwrap();
        std::hint::black_box(img);
    });
    report("gold (pbr), per fragment, 10-level chain", t, cpu);
    println!("  (target: crystal per fragment under 0.5 s on 2 cores; the CPU column is the");
    println!("  estimate when other processes share the cores)");
}
