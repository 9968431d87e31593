//! Benchmark (not a timed test): 4096 x 2048 HDR panoramas to six 1024 faces, each stage timed,
//! plus the other directions users run. Run with `cargo bench --bench convert`.
//! Reference on a 2-core machine: cmft 0.6 s with I/O; py360convert 1.2 s conversion alone.
//!
//! Two panoramas: the bundled demo sky drawn at 4K (smooth: compresses easily), and a
//! "photo" made from the real park panorama in ../shared/fixtures/real (skipped when absent),
//! enlarged 8x with a fixed 8% grain so its files compress like a camera's.

use cubeforge::convert::{self, Output, Source};
use cubeforge::cube::FACE_NAMES;
use cubeforge::image::Image;
use cubeforge::io::{self, Decoded, ReadOptions, WriteOptions};
use cubeforge::layout::{Kind, Projection};
use cubeforge::resample::{FnEnv, Orientation, Resampler};
use cubeforge::synthetic;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

const RUNS: usize = 5;

fn main() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("bench-convert");
    std::fs::create_dir_all(&dir).unwrap();
    println!(
        "on {} threads, best of {RUNS}:",
        rayon::current_num_threads()
    );
    let sky = dir.join("pano4k.hdr");
    if !sky.exists() {
        let img = Resampler {
            antialias: false,
            ..Resampler::default()
        }
        .to_projection(
            &FnEnv(synthetic::demo_sky),
            Projection::Equirect,
            4096,
            2048,
        );
        write(&sky, &img);
    }
    faces(&sky, "sky", &dir);
    if let Some(photo) = photo(&dir) {
        faces(&photo, "photo", &dir);
        others(&photo, &dir);
    }
    println!("(cmft: 0.6 s total for the first case; target 0.3 s)");
}

fn write(path: &Path, img: &Image) {
    std::fs::write(
        path,
        io::encode_image(path, img, &WriteOptions::default()).unwrap(),
    )
    .unwrap();
}

/// The real park panorama enlarged to 4096 x 2048 with a fixed grain.
fn photo(dir: &Path) -> Option<PathBuf> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real/hdr/park.hdr");
    if !src.exists() {
        println!("photo: skipped, ../shared/fixtures/real is absent");
        return None;
    }
    let path = dir.join("photo4k.hdr");
    if !path.exists() {
        let (Decoded::Image(park), _) = io::read(&src, &ReadOptions::default()).unwrap() else {
            unreachable!()
        };
        let img = Image::from_fn(4096, 2048, |x, y| {
            let p = park.bilinear((x as f32 + 0.5) / 8.0, (y as f32 + 0.5) / 8.0, true);
            let mut h = (x as u32).wrapping_mul(0x9E37_79B9) ^ (y as u32).wrapping_mul(0x85EB_CA6B);
            h ^= h >> 15;
            h = h.wrapping_mul(0x2C1B_3C6D);
            h ^= h >> 12;
            let grain = 1.0 + 0.08 * ((h & 0xffff) as f32 / 65535.0 - 0.5);
            (p.truncate() * grain).extend(1.0)
        });
        write(&path, &img);
    }
    Some(path)
}

/// The headline case, stage by stage.
fn faces(input: &Path, name: &str, dir: &Path) {
    let mut best = [f64::MAX; 5];
    for _ in 0..RUNS {
        let t0 = Instant::now();
        let loaded = convert::load(
            std::slice::from_ref(&input.to_path_buf()),
            None,
            &ReadOptions::default(),
        )
        .unwrap();
        let t1 = Instant::now();
        let Output::Cube(cube) =
            convert::convert(&loaded, Kind::Faces, 1024, &Resampler::default())
        else {
            unreachable!()
        };
        let t2 = Instant::now();
        let out = dir.join(format!("faces-{name}"));
        let files: Vec<(PathBuf, Vec<u8>)> = FACE_NAMES
            .par_iter()
            .zip(cube.levels[0].par_iter())
            .map(|(n, f)| {
                let p = out.join(format!("{n}.exr"));
                let b = io::encode_image(&p, f, &WriteOptions::default()).unwrap();
                (p, b)
            })
            .collect();
        let t3 = Instant::now();
        std::fs::create_dir_all(&out).unwrap();
        io::write_all_atomic(&files).unwrap();
        let t4 = Instant::now();
        let times = [t1 - t0, t2 - t1, t3 - t2, t4 - t3, t4 - t0].map(|d| d.as_secs_f64());
        for (b, t) in best.iter_mut().zip(times) {
            *b = b.min(t);
        }
    }
    println!("{name}: 4096x2048 .hdr -> 6 x 1024 EXR faces");
    for (stage, t) in ["decode", "resample", "encode", "write", "total"]
        .iter()
        .zip(best)
    {
        println!("  {stage:<9} {t:7.3} s");
    }
}

/// Resampling alone for the other directions, from the photo.
fn others(input: &Path, dir: &Path) {
    let read = ReadOptions::default();
    let pano = convert::load(&[input.to_path_buf()], None, &read).unwrap();
    let cross = dir.join("cross1024.exr");
    if !cross.exists() {
        let Output::Image(img) = convert::convert(&pano, Kind::Hcross, 1024, &Resampler::default())
        else {
            unreachable!()
        };
        write(&cross, &img);
    }
    let cube = convert::load(&[cross], None, &read).unwrap();
    let turned = Resampler {
        orientation: Orientation {
            yaw: 30.0,
            ..Orientation::default()
        },
        ..Resampler::default()
    };
    let bicubic = Resampler {
        interp: cubeforge::cube::Interp::Bicubic,
        ..Resampler::default()
    };
    let cases: [(&str, &convert::Loaded, Kind, usize, &Resampler); 7] = [
        (
            "equirect 4096 -> faces 256 (antialiased)",
            &pano,
            Kind::Faces,
            256,
            &Resampler::default(),
        ),
        (
            "equirect 4096 -> faces 1024, bicubic",
            &pano,
            Kind::Faces,
            1024,
            &bicubic,
        ),
        (
            "equirect 4096 -> equirect 2048",
            &pano,
            Kind::Equirect,
            512,
            &Resampler::default(),
        ),
        (
            "equirect 4096 -> sphere 2048",
            &pano,
            Kind::Sphere,
            1024,
            &Resampler::default(),
        ),
        (
            "equirect 4096 -> angular 2048",
            &pano,
            Kind::Angular,
            1024,
            &Resampler::default(),
        ),
        (
            "faces 1024 -> equirect 4096",
            &cube,
            Kind::Equirect,
            1024,
            &Resampler::default(),
        ),
        (
            "faces 1024 -> faces 1024, yaw 30",
            &cube,
            Kind::Faces,
            1024,
            &turned,
        ),
    ];
    // An 8K panorama (the photo enlarged again) shrunk to small faces: the footprint path.
    let big = {
        let Source::Projection(_, img) = &pano.source else {
            unreachable!()
        };
        Image::from_fn(8192, 4096, |x, y| {
            img.bilinear((x as f32 + 0.5) / 2.0, (y as f32 + 0.5) / 2.0, true)
        })
    };
    let big = convert::Loaded {
        source: Source::Projection(Projection::Equirect, big),
        ..convert::load(&[input.to_path_buf()], None, &read).unwrap()
    };
    println!("photo: resampling alone");
    for size in [64, 256] {
        let mut best = f64::MAX;
        for _ in 0..RUNS {
            let t = Instant::now();
            std::hint::black_box(convert::convert(
                &big,
                Kind::Faces,
                size,
                &Resampler::default(),
            ));
            best = best.min(t.elapsed().as_secs_f64());
        }
        println!("  equirect 8192 -> faces {size:<4} (antialiased)         {best:7.3} s");
    }
    for (name, src, to, size, r) in cases {
        let mut best = f64::MAX;
        for _ in 0..RUNS {
            let t = Instant::now();
            std::hint::black_box(convert::convert(src, to, size, r));
            best = best.min(t.elapsed().as_secs_f64());
        }
        let (w, h) = to.image_size(size);
        let texels = if to == Kind::Faces { 6 * w * h } else { w * h };
        println!(
            "  {name:<42} {best:7.3} s  ({:.0} M texels/s)",
            texels as f64 / best / 1e6
        );
    }
}
