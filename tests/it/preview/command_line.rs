//! Materials, inputs and the command line: material files and presets, prefiltered chains as
//! input, the outputs the command writes and its one-line errors.

use super::*;
use crate::common;
use cubeforge::internals::io::ReadOptions;
use std::path::Path;

#[test]
fn material_files_parse_and_errors_name_the_file_and_line() {
    let p = Path::new("mats/gem.toml");
    let m = material::parse_toml(
        "model = \"dispersion\"\neta_ratio = [0.65, 0.67, 0.69]\nfresnel_bias = 0.1\nfresnel_scale = 1.0\nfresnel_power = 5\n",
        p,
    )
    .unwrap();
    assert_eq!(m.model, Model::Dispersion);
    assert_eq!(m.eta_ratio, Vec3::new(0.65, 0.67, 0.69));
    assert_eq!(m.name, "gem");
    let m = material::parse_toml(
        "model = \"refract\"\neta_ratio = 0.75\ndecal = \"wood.png\"\n",
        p,
    )
    .unwrap();
    assert_eq!(m.eta_ratio, Vec3::splat(0.75));
    assert_eq!(m.decal.as_deref(), Some(Path::new("mats/wood.png")));
    // Every preset round-trips through the TOML it is listed as.
    for (preset, _) in material::presets() {
        let back = material::parse_toml(&material::to_toml(&preset), Path::new("x.toml")).unwrap();
        assert_eq!(back.model, preset.model);
        assert!((back.eta_ratio - preset.eta_ratio).abs().max_element() < 1e-4);
    }
    for (text, needle) in [
        ("model = \"reflect\"\nreflectivty = 0.5\n", "line 2"),
        ("model = \"glossy\"\n", "line 1"),
        ("model = \"refract\"\n", "needs eta_ratio"),
        (
            "model = \"reflect\"\nreflectivity = 1.5\n",
            "between 0 and 1",
        ),
        (
            "model = \"refract\"\neta_ratio = [0.6, 0.7, 0.8]\n",
            "dispersion",
        ),
        ("model = \"refract\"\neta_ratio = -1\n", "positive"),
        ("model = [\n", "line"),
    ] {
        let e = material::parse_toml(text, p).unwrap_err().to_string();
        assert!(e.starts_with("mats/gem.toml: "), "{e}");
        assert!(e.contains(needle), "{e} should say {needle}");
        assert!(!e.contains('\n'), "one line: {e}");
    }
    let e = material::resolve("velvet", Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown material") && e.contains("chrome"),
        "{e}"
    );
    let e = material::resolve("/nonexistent/m.toml", Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/m.toml: "), "{e}");
}

#[test]
fn presets_follow_table_7_2() {
    let eta = |n: &str| material::preset(n).unwrap().eta_ratio.x;
    assert!((eta("glass") - 1.0 / 1.5).abs() < 1e-6);
    assert!((eta("water") - 1.0 / 1.3333).abs() < 1e-6);
    assert!((eta("diamond") - 1.0 / 2.417).abs() < 1e-6);
    assert!((eta("plastic") - 1.0 / 1.5).abs() < 1e-6);
    let crystal = material::preset("crystal").unwrap();
    assert_eq!(crystal.model, Model::Dispersion);
    assert!(
        crystal.eta_ratio.x != crystal.eta_ratio.z,
        "a rainbow needs spread"
    );
    let names: Vec<String> = material::presets()
        .into_iter()
        .map(|(m, _)| m.name)
        .collect();
    assert_eq!(
        names,
        [
            "chrome",
            "mirror-decal",
            "glass",
            "water",
            "diamond",
            "plastic",
            "crystal",
            "pbr",
            "gold",
            "copper",
            "plastic-glossy",
            "plastic-rough"
        ]
    );
}

#[test]
fn prefilter_folder_chains_load_level_by_level() {
    let dir = tempfile::tempdir().unwrap();
    let sizes = [8usize, 4, 2, 1];
    for (k, n) in sizes.iter().enumerate() {
        let sub = dir.path().join(format!("m{k}"));
        std::fs::create_dir_all(&sub).unwrap();
        for f in cubeforge::internals::cube::FACE_NAMES {
            let p = sub.join(format!("{f}.exr"));
            let img = Image::filled(*n, *n, Vec4::new(k as f32, 0.0, 0.0, 1.0));
            std::fs::write(
                &p,
                cubeforge::internals::output::encode_image(&p, &img, &WriteOptions::default())
                    .unwrap(),
            )
            .unwrap();
        }
    }
    std::fs::write(
        dir.path().join("levels.json"),
        r#"{"levels": [{"size": 8}, {"size": 4}, {"size": 2}, {"size": 1}]}"#,
    )
    .unwrap();
    let env = common::preview_env(dir.path()).unwrap();
    assert_eq!(env.levels(), 4);
    use cubeforge::internals::cube::Environment;
    assert_eq!(env.sampler.lookup(Vec3::X, 2.0).x, 2.0);
    assert_eq!(env.sampler.lookup(Vec3::X, 1.5).x, 1.5);
    // A level of the wrong size is named.
    std::fs::remove_dir_all(dir.path().join("m3")).unwrap();
    std::fs::remove_dir_all(dir.path().join("m2")).unwrap();
    let sub = dir.path().join("m2");
    std::fs::create_dir_all(&sub).unwrap();
    for f in cubeforge::internals::cube::FACE_NAMES {
        let p = sub.join(format!("{f}.exr"));
        let img = Image::filled(3, 3, Vec4::ONE);
        std::fs::write(
            &p,
            cubeforge::internals::output::encode_image(&p, &img, &WriteOptions::default()).unwrap(),
        )
        .unwrap();
    }
    let e = common::preview_env(dir.path()).err().unwrap().to_string();
    assert!(e.contains("m2") && e.contains("2x2"), "{e}");
}

#[test]
fn command_line_renders_png_exr_and_grids() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let png = out("ball.png");
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &png,
        "--size",
        "48",
        "-m",
        "crystal",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (img, meta) =
        cubeforge::internals::convert::read(Path::new(&png), &ReadOptions::default()).unwrap();
    assert_eq!(meta.file_format, io::FileFormat::Png);
    let io::Decoded::Image(img) = img else {
        panic!()
    };
    assert_eq!((img.width, img.height), (48, 48));
    // EXR: linear radiance, one sample through each pixel centre, as the library renders it.
    let exr = out("ball.exr");
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &exr,
        "--size",
        "32",
        "--yaw",
        "-40",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let got = common::read_image(Path::new(&exr));
    let env = common::preview_env(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/sky.exr"
    )))
    .unwrap();
    let want = preview::render(
        &env.sampler,
        &material::preset("chrome").unwrap(),
        &Surface::default(),
        &Options {
            size: 32,
            yaw: -40.0,
            ..Options::default()
        },
    )
    .unwrap();
    let worst = got
        .pixels
        .iter()
        .zip(&want.pixels)
        .map(|(a, b)| ((*a - *b).abs() / b.abs().max(Vec4::splat(1e-3))).max_element())
        .fold(0.0f32, f32::max);
    assert!(
        worst < 2e-3,
        "EXR holds the radiance (half precision): {worst}"
    );
    // A grid: three cells side by side with labels below.
    let grid = out("grid.png");
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &grid,
        "--size",
        "40",
        "--grid",
        "chrome,glass,crystal",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let g = common::read_image(Path::new(&grid));
    assert!(g.width > 3 * 40 && g.width < 3 * 40 + 20 && g.height > 40 + 7);
    let label_rows = (40..g.height).flat_map(|y| (0..g.width).map(move |x| (x, y)));
    assert!(
        label_rows.filter(|&(x, y)| g.get(x, y).x > 0.9).count() > 30,
        "labels are drawn"
    );
    // --grid-bias on a one-level map: rendered, with a warning that blur needs a chain.
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &out("bias.png"),
        "--size",
        "24",
        "--grid-bias",
        "0,2",
    ]);
    assert!(r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("warning") && err.contains("prefilter"),
        "{err}"
    );
    // --material list prints every preset.
    let r = common::run(["preview", "--material", "list"]);
    let text = String::from_utf8_lossy(&r.stdout);
    for name in [
        "chrome",
        "mirror-decal",
        "glass",
        "water",
        "diamond",
        "plastic",
        "crystal",
    ] {
        assert!(text.contains(name), "{text}");
    }
}

#[test]
fn command_line_errors_are_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png").to_string_lossy().into_owned();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "model = \"reflect\"\nshininess = 3\n").unwrap();
    let bad = bad.to_string_lossy().into_owned();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["preview", "missing.exr", "-o", &out], "missing.exr"),
        (
            vec!["preview", "fixtures/sky.exr", "-o", &out, "-m", &bad],
            "bad.toml",
        ),
        (
            vec!["preview", "fixtures/sky.exr", "-o", &out, "-m", "velvet"],
            "velvet",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "-m",
                "nothere.toml",
            ],
            "nothere.toml",
        ),
        (
            vec!["preview", "fixtures/sky.exr", "-o", "x.ktx2"],
            "x.ktx2",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--decal",
                "nodecal.png",
            ],
            "nodecal.png",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--control",
                "nomask.png",
            ],
            "nomask.png",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--distance",
                "0.5",
            ],
            "--distance",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--background",
                "mauve",
            ],
            "--background",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--parallax",
                "exact",
            ],
            "--env-radius",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--env-radius",
                "1.5",
                "--env-center",
                "1,0,0",
                "--parallax",
                "exact",
            ],
            "--env-radius",
        ),
        (vec!["preview", "fixtures/sky.exr"], "-o OUTPUT"),
    ];
    for (args, needle) in cases {
        let r = common::run(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.starts_with("cubeforge: error: "), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    assert!(!Path::new(&out).exists(), "nothing written on error");
}
