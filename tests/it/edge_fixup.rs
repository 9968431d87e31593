//! `--edge-fixup warp|stretch`: maps sampled the way GLES 2 / WebGL 1 / DX9 hardware samples
//! them, each face bilinear on its own and clamped at its edges (written here), show no
//! seams, and cmft's warp formula places the texels.

use crate::common::{run, stderr};
use cubeforge::internals::convert;
use cubeforge::internals::cube::fixup::{self, warp_factor, EdgeFixup};
use cubeforge::internals::cube::{dir_face, face_dir, CubeMap, Faces};
use cubeforge::internals::io::ReadOptions;
use cubeforge::Resampler;
use glam::{Vec3, Vec4};
use std::path::Path;

/// A smooth sky with detail on every face.
fn sky(d: Vec3) -> Vec4 {
    let v = 1.0 + 0.6 * (3.0 * d.x).sin() * (2.0 * d.y).cos() + 0.4 * d.z * d.z + 0.3 * d.y;
    Vec4::new(v, 0.5 * v + 0.2, 1.5 - 0.3 * d.x, 1.0)
}

/// A per-face bilinear lookup clamped to the face (no seamless filtering), the face
/// coordinates first mapped as a fixup's shader counterpart asks.
fn clamped(faces: &Faces, d: Vec3, mode: EdgeFixup) -> Vec4 {
    let (face, s, t) = dir_face(d);
    let img = &faces[face];
    let n = img.width;
    let at = |c: f32| {
        let u = mode.lookup(2.0 * c as f64 - 1.0, n);
        ((0.5 * (u + 1.0)) * n as f64 - 0.5).clamp(0.0, (n - 1) as f64)
    };
    let (x, y) = (at(s), at(t));
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(n - 1), (y0 + 1).min(n - 1));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let top = img.get(x0, y0).lerp(img.get(x1, y0), fx);
    let bottom = img.get(x0, y1).lerp(img.get(x1, y1), fx);
    top.lerp(bottom, fy)
}

/// The largest jump across the twelve face edges: pairs of directions a hair either side of
/// each edge, relative to the mean.
fn seam(faces: &Faces, mode: EdgeFixup) -> f32 {
    let mut worst = 0.0f32;
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        let c = 3 - a - b;
        for (sa, sb) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
            for k in 0..97 {
                let mut p = [0.0f32; 3];
                p[a] = sa;
                p[b] = sb;
                p[c] = -0.98 + 1.96 * k as f32 / 96.0;
                let (mut p1, mut p2) = (p, p);
                p1[a] *= 1.0 + 1e-4;
                p2[b] *= 1.0 + 1e-4;
                let v1 = clamped(faces, Vec3::from(p1).normalize(), mode);
                let v2 = clamped(faces, Vec3::from(p2).normalize(), mode);
                worst = worst.max((v1 - v2).truncate().abs().max_element());
            }
        }
    }
    worst
}

/// The mean error of the clamped lookup against the sky itself, over a spiral of directions.
fn error(faces: &Faces, mode: EdgeFixup) -> f32 {
    let n = 4000;
    let mut sum = 0.0;
    for i in 0..n {
        let z = 1.0 - (2 * i + 1) as f32 / n as f32;
        let r = (1.0 - z * z).sqrt();
        let phi = 2.399_963 * i as f32;
        let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        sum += (clamped(faces, d, mode) - sky(d))
            .truncate()
            .abs()
            .max_element();
    }
    sum / n as f32
}

#[test]
fn fixed_maps_have_no_seams_under_a_per_face_sampler() {
    let n = 16;
    let plain = CubeMap::from_fn(n, sky).levels.remove(0);
    let before = seam(&plain, EdgeFixup::None);
    let base = error(&plain, EdgeFixup::None);
    eprintln!("{n} px, no fixup: seam {before:.4}, mean error {base:.4}");
    assert!(before > 0.02, "a clamped sampler shows the seams: {before}");
    // The docs' figures: the largest seam left, each mode's errors with and without its lookup.
    let (mut left, mut with, mut without) = (0f32, Vec::new(), Vec::new());
    for mode in [EdgeFixup::Warp, EdgeFixup::Stretch] {
        let fixed = fixup::apply(&plain, mode);
        let after = seam(&fixed, mode);
        // Read with the shader counterpart, and (warp) without it.
        let err = error(&fixed, mode);
        let raw = error(&fixed, EdgeFixup::None);
        eprintln!(
            "{mode:?}: seam {after:.5}, mean error {err:.4} with its lookup, {raw:.4} without"
        );
        assert!(after < 0.02 * before, "{mode:?} leaves a seam of {after}");
        let name = format!("{mode:?}").to_lowercase();
        left = left.max(after);
        with.push(format!("{err:.4} ({name})"));
        without.push(format!("{raw:.4} ({name})"));
        assert!(
            err < 1.5 * base + 2e-3,
            "{mode:?} error {err} against {base}"
        );
    }
    let text = format!("seams drop from {before:.3} to {left:.5}");
    crate::figures::check("README.md", "seams", &text);
    let text = format!(
        "the largest jump across an edge is {before:.3} without a fixup and {left:.5} with \
         either (what remains is the sky's own change over the 1e-4 step). The mean error \
         against the sky is {base:.4} for the plain map read by the same clamped sampler, {} \
         for the fixed maps read with their lookups, and {} read without",
        with.join(" and "),
        without.join(" and ")
    );
    crate::figures::check("docs/conventions.md", "seams", &text);
}

#[test]
fn warp_places_texels_by_cmfts_formula() {
    // cmft's warpFixupFactor and texel-to-vector warp: u' = a u^3 + u at the texel centre u.
    for n in [2usize, 5, 16, 256] {
        let fs = n as f64;
        let cmft = fs * fs / ((fs - 1.0) * (fs - 1.0) * (fs - 1.0));
        assert!((warp_factor(n) - cmft).abs() < 1e-12 * cmft);
        for i in 0..n {
            let u = (2 * i + 1) as f64 / fs - 1.0;
            let want = cmft * u * u * u + u;
            assert!((EdgeFixup::Warp.coordinate(u, n) - want).abs() < 1e-12);
        }
    }
    // Each texel of a warped map holds the sky where cmft's direction points, within the
    // bilinear reading of the map it is moved from.
    let n = 32;
    let plain = CubeMap::from_fn(n, sky).levels.remove(0);
    let fixed = fixup::apply(&plain, EdgeFixup::Warp);
    let a = warp_factor(n);
    let mut worst = 0.0f32;
    for (face, img) in fixed.iter().enumerate() {
        for y in 0..n {
            for x in 0..n {
                let c = |i: usize| {
                    let u = (2 * i + 1) as f64 / n as f64 - 1.0;
                    (0.5 * (a * u * u * u + u + 1.0)) as f32
                };
                let d = face_dir(face, c(x), c(y)).normalize();
                worst = worst.max((img.get(x, y) - sky(d)).truncate().abs().max_element());
            }
        }
    }
    eprintln!("warped {n} px map against the sky at cmft's directions: {worst:.4}");
    assert!(worst < 0.01, "{worst}");
    // Faces of one texel stay as they are.
    let one = CubeMap::from_fn(1, sky).levels.remove(0);
    assert_eq!(
        fixup::apply(&one, EdgeFixup::Stretch)[0].pixels,
        one[0].pixels
    );
}

fn faces_of(path: &Path) -> Faces {
    let loaded = convert::load(&[path.to_path_buf()], None, &ReadOptions::default()).unwrap();
    let n = loaded.face_size();
    convert::to_cube(&loaded, n, &Resampler::default())
        .levels
        .remove(0)
}

#[test]
fn every_cube_output_and_chain_level_is_fixed() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sky.exr");
    let wrote = run([
        "convert",
        "fixtures/sky.exr",
        "-o",
        src.to_str().unwrap(),
        "--to",
        "equirect",
    ]);
    assert!(wrote.status.success(), "{}", stderr(&wrote));
    // A KTX2 records the fixup; faces and a cross get it too. A clamped tap a hair from
    // the edge reads the edge texels alone: they coincide across every edge.
    let plain = dir.path().join("plain.ktx2");
    let r = run([
        "convert",
        src.to_str().unwrap(),
        "-o",
        plain.to_str().unwrap(),
        "--size",
        "16",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let before = seam(&faces_of(&plain), EdgeFixup::None);
    assert!(before > 0.05, "{before}");
    for (name, mode) in [
        ("w.ktx2", "warp"),
        ("s.exr", "stretch"),
        ("w_faces", "warp"),
    ] {
        let out = dir.path().join(name);
        let mut args = vec![
            "convert",
            src.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(["--size", "16", "--edge-fixup", mode]);
        if name.ends_with(".ktx2") {
            // The key that lets cubeforge read the texels back where they usually are.
            args.push("--cubeforge-keys");
        }
        if name.ends_with(".exr") {
            args.extend(["--to", "hcross"]);
        }
        let r = run(&args);
        assert!(r.status.success(), "{name}: {}", stderr(&r));
        if name.ends_with(".ktx2") {
            // A KTX2 reads back with its texels where they usually are: the smooth sky
            // written as faces, fixed, read back.
            let smooth = CubeMap::from_fn(16, sky).levels.remove(0);
            let faces = dir.path().join("smooth");
            std::fs::create_dir_all(&faces).unwrap();
            for (f, img) in smooth.iter().enumerate() {
                let p = faces.join(format!("{}.exr", cubeforge::internals::cube::FACE_NAMES[f]));
                let opts = cubeforge::internals::io::WriteOptions {
                    exr_float: cubeforge::internals::io::ExrFloat::F32,
                    ..Default::default()
                };
                std::fs::write(
                    &p,
                    cubeforge::internals::output::encode_image(&p, img, &opts).unwrap(),
                )
                .unwrap();
            }
            let fixed = dir.path().join("smooth.ktx2");
            let r = run([
                "convert",
                faces.to_str().unwrap(),
                "-o",
                fixed.to_str().unwrap(),
                "--gpu-format",
                "rgba32f",
                "--edge-fixup",
                "warp",
                "--cubeforge-keys",
            ]);
            assert!(r.status.success(), "{}", stderr(&r));
            let back = faces_of(&fixed);
            let mut worst = 0.0f32;
            for (b, w) in back.iter().zip(&smooth) {
                for (p, q) in b.pixels.iter().zip(&w.pixels) {
                    worst = worst.max((*p - *q).truncate().abs().max_element());
                }
            }
            eprintln!("{name}: a smooth sky read back within {worst:.4}");
            assert!(worst < 0.02, "{worst}");
            let info = run(["info", out.to_str().unwrap()]);
            assert!(String::from_utf8_lossy(&info.stdout).contains("edge fixup warp"));
        } else {
            let after = seam(&faces_of(&out), EdgeFixup::None);
            eprintln!("{name}: seam {after:.5} (without the fixup: {before:.5})");
            assert!(after < 1e-3 * before, "{name}: {after}");
        }
        if name.ends_with(".ktx2") {
            let kv = cubeforge::internals::io::ktx2::metadata(&std::fs::read(&out).unwrap());
            assert!(kv
                .iter()
                .any(|(k, v)| k == "cubeforge.edgeFixup" && v == b"warp"));
        }
    }
    // A prefiltered chain: every level, each on its own grid.
    let chain = dir.path().join("chain");
    let r = run([
        "prefilter",
        src.to_str().unwrap(),
        "-o",
        chain.to_str().unwrap(),
        "--size",
        "32",
        "--min-size",
        "2",
        "--edge-fixup",
        "stretch",
        "--filter",
        "ggx",
        "--samples",
        "64",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    for k in 0..5 {
        let faces = faces_of(&chain.join(format!("m{k}")));
        let s = seam(&faces, EdgeFixup::None);
        assert!(s < 1e-3, "level {k}: {s}");
    }
    // Not a cube: warned, ignored.
    let r = run([
        "convert",
        src.to_str().unwrap(),
        "-o",
        dir.path().join("e.exr").to_str().unwrap(),
        "--to",
        "equirect",
        "--edge-fixup",
        "warp",
    ]);
    assert!(r.status.success());
    assert!(stderr(&r).contains("--edge-fixup warp"), "{}", stderr(&r));
}
