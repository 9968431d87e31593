//! A new user's first hour: the surprises a first try ran into, each one now said or avoided.

use crate::cli_options::{err, run, run_ok};
use cubeforge::internals::image::Image;
use glam::{Vec3, Vec4};
use std::path::Path;

const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

#[test]
fn bare_cubeforge_prints_the_usage_and_fails() {
    let t = tempfile::tempdir().unwrap();
    let o = run(&[], t.path());
    assert_eq!(o.status.code(), Some(2), "{}", err(&o));
    assert!(err(&o).contains("Usage:"), "{}", err(&o));
    assert!(o.stdout.is_empty());
}

#[test]
fn zstd_takes_its_level_after_a_space() {
    let t = tempfile::tempdir().unwrap();
    let spaced = t.path().join("spaced.ktx2");
    let joined = t.path().join("joined.ktx2");
    for (out, level) in [(&spaced, ["--zstd", "9"]), (&joined, ["--zstd=9", ""])] {
        let mut args = vec![
            "convert",
            SKY_EXR,
            "-o",
            out.to_str().unwrap(),
            "--size",
            "16",
        ];
        args.extend(level.iter().filter(|a| !a.is_empty()));
        run_ok(&args, t.path());
    }
    assert_eq!(
        std::fs::read(&spaced).unwrap(),
        std::fs::read(&joined).unwrap()
    );
    // The level's default still works before an input, and a level out of range is refused.
    run_ok(
        &[
            "convert",
            "--zstd",
            SKY_EXR,
            "-o",
            "plain.ktx2",
            "--size",
            "16",
        ],
        t.path(),
    );
    let o = run(
        &["convert", SKY_EXR, "-o", "x.ktx2", "--zstd", "23"],
        t.path(),
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err(&o).contains("23") && err(&o).contains("--zstd"),
        "{}",
        err(&o)
    );
}

/// The largest Laplacian of the luminance over the inner disc of a sphere preview, relative:
/// a chain's 1 x 1 faces draw the cube's box outline there as creases.
fn crease(path: &Path) -> f32 {
    let (d, _) = cubeforge::internals::convert::read(path, &Default::default()).unwrap();
    let cubeforge::internals::io::Decoded::Image(img) = d else {
        panic!("an image")
    };
    let n = img.width;
    let lum = |x: usize, y: usize| {
        let p = img.get(x, y);
        0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z
    };
    let mut mean = 0.0;
    let mut values = Vec::new();
    for y in 1..n - 1 {
        for x in 1..n - 1 {
            let r = ((x as f32 + 0.5 - n as f32 / 2.0).hypot(y as f32 + 0.5 - n as f32 / 2.0))
                / (n as f32 / 2.0);
            if r < 0.8 {
                let l =
                    4.0 * lum(x, y) - lum(x - 1, y) - lum(x + 1, y) - lum(x, y - 1) - lum(x, y + 1);
                values.push(l.abs());
                mean += lum(x, y);
            }
        }
    }
    mean /= values.len() as f32;
    values.iter().copied().fold(0.0, f32::max) / mean
}

#[test]
fn blurry_chains_stop_at_16_px_and_show_no_box_outline() {
    let t = tempfile::tempdir().unwrap();
    // Light that varies smoothly with direction: any crease in its reflection is the chain's.
    let smooth = Image::from_fn(256, 128, |x, y| {
        let lon = ((x as f32 + 0.5) / 256.0 - 0.5) * std::f32::consts::TAU;
        let lat = (0.5 - (y as f32 + 0.5) / 128.0) * std::f32::consts::PI;
        let d = Vec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
        Vec4::new(1.0 + 0.8 * d.y, 1.0 + 0.5 * d.x, 1.0 + 0.6 * d.z, 1.0)
    });
    let input = t.path().join("smooth.exr");
    let bytes =
        cubeforge::internals::output::encode_image(&input, &smooth, &Default::default()).unwrap();
    std::fs::write(&input, bytes).unwrap();
    let input = input.to_str().unwrap().to_owned();
    let mut creases = Vec::new();
    for (name, floor) in [("default", None), ("full", Some("1"))] {
        let chain = format!("{name}.ktx2");
        let mut args = vec![
            "prefilter",
            &input,
            "-o",
            &chain,
            "--filter",
            "gaussian",
            "--size",
            "64",
        ];
        if let Some(f) = floor {
            args.extend(["--min-size", f]);
        }
        let o = run_ok(&args, t.path());
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let levels = text.lines().filter(|l| l.starts_with("level")).count();
        assert_eq!(levels, if floor.is_none() { 3 } else { 7 }, "{text}");
        if floor.is_none() {
            assert!(
                text.contains("stopped at 16 px (--min-size 16, the default"),
                "{text}"
            );
        }
        let picture = format!("{name}.exr");
        run_ok(
            &[
                "preview",
                &chain,
                "-o",
                &picture,
                "--material",
                "chrome",
                "--lod-bias",
                "4",
                "--size",
                "128",
                "--background",
                "black",
            ],
            t.path(),
        );
        creases.push(crease(&t.path().join(&picture)));
    }
    let (default, full) = (creases[0], creases[1]);
    assert!(
        default * 4.0 < full,
        "creases: default {default}, full chain {full}"
    );
    // Babylon's .env holds every level down to 1 x 1 whatever the default.
    let o = run_ok(
        &[
            "prefilter",
            SKY_EXR,
            "-o",
            "b.env",
            "--filter",
            "ggx",
            "--size",
            "16",
            "--samples",
            "4",
        ],
        t.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(
        text.lines().filter(|l| l.starts_with("level")).count(),
        5,
        "{text}"
    );
}

fn mean_rgb(path: &Path) -> f64 {
    let (d, _) = cubeforge::internals::convert::read(path, &Default::default()).unwrap();
    let images: Vec<Image> = match d {
        cubeforge::internals::io::Decoded::Image(img) => vec![img],
        cubeforge::internals::io::Decoded::Cube(c) => c.levels[0].to_vec(),
    };
    let (sum, n) = images
        .iter()
        .flat_map(|i| i.pixels.iter())
        .fold((0.0, 0), |(s, n), p| (s + (p.x + p.y + p.z) as f64, n + 1));
    sum / n as f64
}

#[test]
fn hdr_written_in_8_bits_says_how_much_clips() {
    let t = tempfile::tempdir().unwrap();
    let o = run_ok(
        &["convert", SKY_EXR, "-o", "sky.png", "--size", "32"],
        t.path(),
    );
    let e = err(&o);
    assert!(
        e.contains("texels brighter than 1 clip to white in an 8-bit file")
            && e.contains("--exposure -")
            && e.contains("--tonemap aces"),
        "{e}"
    );
    // A tone curve clips nothing; a float output keeps everything.
    for args in [
        &[
            "convert",
            SKY_EXR,
            "-o",
            "aces.png",
            "--size",
            "32",
            "--tonemap",
            "aces",
        ][..],
        &["convert", SKY_EXR, "-o", "sky.exr", "--size", "32"][..],
    ] {
        let o = run_ok(args, t.path());
        assert!(!err(&o).contains("clip"), "{args:?}: {}", err(&o));
    }
    // The suggested exposure is enough.
    let ev = e
        .split("--exposure ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap();
    let o = run_ok(
        &[
            "convert",
            SKY_EXR,
            "-o",
            "dim.png",
            "--size",
            "32",
            "--exposure",
            ev,
        ],
        t.path(),
    );
    assert!(!err(&o).contains("clip"), "--exposure {ev}: {}", err(&o));
}

#[test]
fn exposure_scales_float_outputs_and_every_lighting_command() {
    let t = tempfile::tempdir().unwrap();
    let run_pair = |args: &[&str], out: &str| {
        let mut base: Vec<&str> = args.to_vec();
        base.extend(["-o", out]);
        run_ok(&base, t.path());
        let brighter = format!("bright_{out}");
        let mut lifted: Vec<&str> = args.to_vec();
        lifted.extend(["-o", &brighter, "--exposure", "1"]);
        let o = run_ok(&lifted, t.path());
        assert!(!err(&o).contains("apply to 8-bit"), "{}", err(&o));
        (t.path().join(out), t.path().join(&brighter))
    };
    let cases = [
        (
            vec!["convert", SKY_EXR, "--size", "16", "--to", "equirect"],
            "c.exr",
            "",
        ),
        (
            vec!["prefilter", SKY_EXR, "--size", "16", "--filter", "box"],
            "p.ktx2",
            "",
        ),
        (vec!["irradiance", SKY_EXR, "--size", "8"], "i.ktx2", ""),
        (vec!["preview", SKY_EXR, "--size", "16"], "v.exr", ""),
        (
            vec![
                "ibl",
                SKY_EXR,
                "--target",
                "bevy",
                "--size",
                "16",
                "--samples",
                "4",
            ],
            "ibl",
            "env_diffuse.ktx2",
        ),
    ];
    for (args, out, inner) in cases {
        let (a, b) = run_pair(&args, out);
        let (a, b) = if inner.is_empty() {
            (a, b)
        } else {
            (a.join(inner), b.join(inner))
        };
        let (ma, mb) = (mean_rgb(&a), mean_rgb(&b));
        assert!((mb / ma - 2.0).abs() < 2e-3, "{args:?}: {ma} -> {mb}");
    }
    // The SH coefficients scale with the map.
    for (ev, name) in [("0", "sh0.json"), ("-1", "sh1.json")] {
        run_ok(
            &[
                "irradiance",
                SKY_EXR,
                "-o",
                "x.ktx2",
                "--size",
                "8",
                "--sh",
                name,
                "--exposure",
                ev,
            ],
            t.path(),
        );
    }
    let dc = |name: &str| -> f64 {
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(t.path().join(name)).unwrap()).unwrap();
        v["radiance"][0][0].as_f64().unwrap()
    };
    assert!((dc("sh1.json") / dc("sh0.json") - 0.5).abs() < 1e-6);
}

#[test]
fn a_sun_beyond_half_float_is_kept_with_exr_float_f32() {
    let t = tempfile::tempdir().unwrap();
    let sun = Image::from_fn(64, 32, |x, y| {
        let v = if (x, y) == (20, 10) { 2.0e5 } else { 0.5 };
        Vec4::new(v, v, v, 1.0)
    });
    let input = t.path().join("sun.exr");
    let write = cubeforge::internals::io::WriteOptions {
        exr_float: cubeforge::internals::io::ExrFloat::F32,
        ..Default::default()
    };
    std::fs::write(
        &input,
        cubeforge::internals::output::encode_image(&input, &sun, &write).unwrap(),
    )
    .unwrap();
    let input = input.to_str().unwrap();
    let o = run_ok(
        &["convert", input, "-o", "half.exr", "--to", "equirect"],
        t.path(),
    );
    assert!(
        err(&o)
            .contains("written as that value: --exr-float f32 keeps them; --exposure lowered by"),
        "{}",
        err(&o)
    );
    let o = run_ok(
        &[
            "convert",
            input,
            "-o",
            "full.exr",
            "--to",
            "equirect",
            "--exr-float",
            "f32",
        ],
        t.path(),
    );
    assert!(err(&o).is_empty(), "{}", err(&o));
    let (d, _) =
        cubeforge::internals::convert::read(&t.path().join("full.exr"), &Default::default())
            .unwrap();
    let cubeforge::internals::io::Decoded::Image(img) = d else {
        panic!("an image")
    };
    let top = img.pixels.iter().map(|p| p.x).fold(0.0, f32::max);
    assert!(top > 65504.0, "{top}");
    // The flux is kept whole only in f32.
    let (full, half) = (
        mean_rgb(&t.path().join("full.exr")),
        mean_rgb(&t.path().join("half.exr")),
    );
    assert!(full > half * 1.5, "{full} {half}");
}

#[test]
fn lighting_from_an_8_bit_image_is_called_dim() {
    let t = tempfile::tempdir().unwrap();
    let png = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");
    let o = run_ok(&["irradiance", png, "-o", "i.exr", "--size", "8"], t.path());
    assert!(
        err(&o).contains("holds display colours, not radiance"),
        "{}",
        err(&o)
    );
    let o = run_ok(
        &[
            "ibl",
            png,
            "-o",
            "ibl",
            "--target",
            "gltf",
            "--size",
            "16",
            "--samples",
            "4",
        ],
        t.path(),
    );
    assert!(err(&o).contains("give an HDR panorama"), "{}", err(&o));
    let o = run_ok(
        &["irradiance", SKY_EXR, "-o", "h.exr", "--size", "8"],
        t.path(),
    );
    assert!(!err(&o).contains("display colours"), "{}", err(&o));
}

#[test]
fn ibl_never_enlarges_without_saying_so() {
    let t = tempfile::tempdir().unwrap();
    // sky.exr is 512 x 256: 128 px faces; Bevy's default chain is 512 px.
    let o = run_ok(
        &[
            "ibl",
            SKY_EXR,
            "-o",
            "b",
            "--target",
            "bevy",
            "--samples",
            "4",
        ],
        t.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains("specular chain at 128 px, the input's face size"),
        "{text}"
    );
    let (d, _) = cubeforge::internals::convert::read(
        &t.path().join("b/env_specular.ktx2"),
        &Default::default(),
    )
    .unwrap();
    let cubeforge::internals::io::Decoded::Cube(c) = d else {
        panic!("a cube")
    };
    assert_eq!(c.size(), 128);
    let o = run_ok(
        &[
            "ibl",
            SKY_EXR,
            "-o",
            "big",
            "--target",
            "bevy",
            "--size",
            "256",
            "--samples",
            "4",
        ],
        t.path(),
    );
    assert!(
        err(&o).contains("--size 256 enlarges the input's 128 px faces 2.0 times"),
        "{}",
        err(&o)
    );
}

#[test]
fn skybox_packs_are_read_in_opengl_order_and_said_so() {
    let t = tempfile::tempdir().unwrap();
    run_ok(
        &[
            "convert", SKY_EXR, "-o", "axes", "--to", "faces", "--size", "16", "--format", "exr",
        ],
        t.path(),
    );
    run_ok(&["convert", "axes", "-o", "axes.exr"], t.path());
    let axes = ["px", "nx", "py", "ny", "pz", "nz"];
    for (pack, names) in [
        ("words", ["right", "left", "top", "bottom", "front", "back"]),
        (
            "quake",
            ["sky_rt", "sky_lf", "sky_up", "sky_dn", "sky_ft", "sky_bk"],
        ),
    ] {
        std::fs::create_dir(t.path().join(pack)).unwrap();
        for (a, n) in axes.iter().zip(names) {
            std::fs::copy(
                t.path().join(format!("axes/{a}.exr")),
                t.path().join(format!("{pack}/{n}.EXR")),
            )
            .unwrap();
        }
        let out = format!("{pack}.exr");
        let o = run_ok(&["convert", pack, "-o", &out], t.path());
        assert!(
            err(&o).contains("faces named as a skybox pack, read as +X -X +Y -Y +Z -Z"),
            "{}",
            err(&o)
        );
        assert_eq!(
            std::fs::read(t.path().join(&out)).unwrap(),
            std::fs::read(t.path().join("axes.exr")).unwrap(),
            "{pack}"
        );
    }
    // A pack with a face missing names it in the pack's words.
    std::fs::remove_file(t.path().join("words/back.EXR")).unwrap();
    let o = run(&["convert", "words", "-o", "w.exr"], t.path());
    assert!(
        err(&o).contains("face back (nz) of a skybox pack is missing"),
        "{}",
        err(&o)
    );
}

#[test]
fn messages_speak_the_users_terms() {
    let t = tempfile::tempdir().unwrap();
    let o = run(&["prefilter", SKY_EXR, "-o", "x.ktx2"], t.path());
    assert!(err(&o).contains("not provided: --filter"), "{}", err(&o));
    let o = run(
        &[
            "convert", SKY_EXR, "-o", "-", "--format", "ktx2", "--to", "equirect",
        ],
        t.path(),
    );
    assert!(
        !err(&o).contains("-.ktx2") && err(&o).contains("standard output"),
        "{}",
        err(&o)
    );
    let o = run(
        &["preview", SKY_EXR, "-o", "-", "--format", "ktx2"],
        t.path(),
    );
    assert!(
        !err(&o).contains("ktx2,") && err(&o).contains("png, jpg"),
        "{}",
        err(&o)
    );
    let o = run(
        &["prefilter", SKY_EXR, "-o", "x.png", "--filter", "box"],
        t.path(),
    );
    assert!(err(&o).contains(".ktx2 .dds .ktx or .env"), "{}", err(&o));
    let o = run_ok(
        &["irradiance", SKY_EXR, "-o", "i.exr", "--size", "8"],
        t.path(),
    );
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        !text.contains("Brute") && text.contains("exact sum"),
        "{text}"
    );
}
