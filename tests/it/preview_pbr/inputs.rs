//! What `pbr` makes of its input (a chain's own mapping, an engine's, or a chain prefiltered
//! in memory), material files and the command line, and a real panorama.

use super::{pbr, render};
use crate::common;
use cubeforge::internals::cube::{CubeMap, CubeSampler, Environment};
use cubeforge::internals::ibl::Engine;
use cubeforge::internals::preview::material::{self, Model};
use cubeforge::internals::preview::pbr::LevelMapping;
use cubeforge::internals::preview::{self, Options, Surface};
use glam::{Vec3, Vec4};
use std::path::Path;

// ---------------------------------------------------------------------------------------
// What the preview makes of its input.

fn sky_exr() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/sky.exr")
}

fn run_ok(args: &[&str]) {
    let out = common::run(args);
    assert!(out.status.success(), "{args:?}: {}", common::stderr(&out));
}

fn load(path: &Path) -> preview::LoadedEnv {
    common::preview_env(path).unwrap()
}

#[test]
fn chains_keep_their_own_mapping_and_anything_else_is_prefiltered() {
    let dir = tempfile::tempdir().unwrap();
    let sky = sky_exr();
    let sky = sky.to_str().unwrap();
    let ggx = dir.path().join("ggx.ktx2");
    let gauss = dir.path().join("gauss.ktx2");
    let folder = dir.path().join("chain");
    let mips = dir.path().join("mips.ktx2");
    let g = ggx.to_str().unwrap();
    run_ok(&[
        "prefilter",
        sky,
        "-o",
        g,
        "--filter",
        "ggx",
        "--size",
        "32",
        "--min-size",
        "8",
    ]);
    let args = ["--filter", "gaussian", "--size", "32"];
    run_ok(
        &[
            &["prefilter", sky, "-o", gauss.to_str().unwrap()],
            &args[..],
        ]
        .concat(),
    );
    let args = ["--filter", "ggx", "--size", "16", "--levels", "3"];
    run_ok(
        &[
            &["prefilter", sky, "-o", folder.to_str().unwrap()],
            &args[..],
        ]
        .concat(),
    );
    run_ok(&["convert", sky, "-o", mips.to_str().unwrap(), "--size", "32"]);

    // A GGX chain: its levels and their roughness from its description (KTX2 key or
    // levels.json), nothing prefiltered.
    for (path, want) in [(&ggx, vec![0.0, 0.5, 1.0]), (&folder, vec![0.0, 0.5, 1.0])] {
        let env = load(path);
        let levels = env.levels();
        let setup = pbr::prepare(&env, path, None).unwrap();
        assert!(setup.warning.is_none(), "{:?}", setup.warning);
        assert!(setup.note.contains("its description"), "{}", setup.note);
        assert_eq!(setup.split_sum.mapping(), &LevelMapping::Levels(want));
        assert!(setup.chain.is_none(), "the chain as it is");
        assert_eq!(setup.sampler(&env).levels(), levels);
    }
    // An engine's mapping, continuous, when --target names one.
    let env = load(&ggx);
    let setup = pbr::prepare(&env, &ggx, Some(Engine::Filament)).unwrap();
    assert!(
        setup.note.contains("filament's roughness mapping"),
        "{}",
        setup.note
    );
    assert!((setup.split_sum.lod(0.5) - 2.0 * 0.75).abs() < 1e-5);
    let e = pbr::prepare(&load(&ggx), &ggx, Some(Engine::Godot)).unwrap_err();
    assert!(
        e.to_string().contains("prefilters the panorama itself"),
        "{e}"
    );

    // Not a GGX chain, or one that does not say: a GGX chain from its level 0, and a warning.
    for (path, why) in [
        (&gauss, "is a gaussian chain, not GGX"),
        (&mips, "does not say their roughness"),
    ] {
        let env = load(path);
        let setup = pbr::prepare(&env, path, None).unwrap();
        let w = setup.warning.as_deref().expect("a warning");
        assert!(
            w.contains(why) && w.contains("prefiltered a GGX chain"),
            "{w}"
        );
        assert_eq!(setup.sampler(&env).levels(), 3, "32, 16, 8");
        assert_eq!(
            setup.split_sum.mapping(),
            &LevelMapping::Levels(vec![0.0, 0.5, 1.0])
        );
    }
    // One level: prefiltered in memory, said with -v only.
    let env = load(&sky_exr());
    assert_eq!(env.levels(), 1);
    let setup = pbr::prepare(&env, &sky_exr(), None).unwrap();
    assert!(setup.warning.is_none());
    assert!(
        setup.note.contains("prefiltered a GGX chain in memory"),
        "{}",
        setup.note
    );
    assert_eq!(setup.sampler(&env).levels(), 5, "128 down to 8");
    assert_eq!(env.levels(), 1, "the map itself is as read");
}

// ---------------------------------------------------------------------------------------
// Material files and the command line.

#[test]
fn pbr_material_files_parse_and_errors_name_the_file_and_line() {
    let p = Path::new("mats/ball.toml");
    let m = material::parse_toml(
        "model = \"pbr\"\nbase_color = [1.0, 0.5, 0.25]\nmetallic = 1\nroughness = 0.3\nior = 1.33\ndecal = \"albedo.png\"\n",
        p,
    )
    .unwrap();
    assert_eq!(m.model, Model::Pbr);
    assert_eq!(m.base_color, Vec3::new(1.0, 0.5, 0.25));
    assert_eq!((m.metallic, m.roughness, m.ior), (1.0, 0.3, 1.33));
    assert_eq!(m.decal.as_deref(), Some(Path::new("mats/albedo.png")));
    let m = material::parse_toml("model = \"pbr\"\n", p).unwrap();
    assert!(
        (m.dielectric_f0() - 0.04).abs() < 1e-7,
        "glTF's 0.04 by default"
    );
    for (preset, _) in material::presets() {
        let back = material::parse_toml(&material::to_toml(&preset), p).unwrap();
        assert_eq!(
            (back.model, back.metallic, back.roughness),
            (preset.model, preset.metallic, preset.roughness)
        );
        assert!((back.base_color - preset.base_color).abs().max_element() < 1e-4);
    }
    for (text, line, needle) in [
        (
            "model = \"pbr\"\nmetallic = 1.5\n",
            2,
            "metallic must be between 0 and 1",
        ),
        (
            "model = \"pbr\"\n\nroughness = -0.1\n",
            3,
            "roughness must be between 0 and 1",
        ),
        (
            "model = \"pbr\"\nbase_color = [1.2, 0, 0]\n",
            2,
            "base_color values",
        ),
        ("model = \"pbr\"\nbase_color = [1, 0]\n", 2, ""),
        (
            "model = \"pbr\"\nmetallic = 0\nior = 0.5\n",
            3,
            "ior must be",
        ),
        (
            "model = \"pbr\"\nreflectivity = 0.5\n",
            2,
            "not a parameter of model \"pbr\"",
        ),
        ("model = \"pbr\"\nroughnes = 0.5\n", 2, "unknown field"),
        (
            "model = \"reflect\"\nroughness = 0.5\n",
            2,
            "applies to model \"pbr\" only",
        ),
        (
            "model = \"reflect\"\n\nreflectivity = 2\n",
            3,
            "between 0 and 1",
        ),
        ("model = \"refract\"\n", 1, "needs eta_ratio"),
    ] {
        let e = material::parse_toml(text, p).unwrap_err().to_string();
        let at = format!("mats/ball.toml: line {line}: ");
        assert!(e.starts_with(&at), "{e} should start with {at}");
        assert!(e.contains(needle), "{e} should say {needle}");
        assert!(!e.contains('\n'), "one line: {e}");
    }
    // The library refuses a pbr material without its lighting rather than render black.
    let e = preview::render(
        &CubeSampler::new(&CubeMap::from_fn(4, |_| Vec4::ONE)),
        &material::preset("gold").unwrap(),
        &Surface::default(),
        &Options::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("split-sum"), "{e}");
}

#[test]
fn command_line_renders_pbr_balls_and_sheets() {
    let dir = tempfile::tempdir().unwrap();
    let sky = sky_exr();
    let sky = sky.to_str().unwrap();
    let one = dir.path().join("gold.exr");
    let out = common::run([
        "-v",
        "preview",
        sky,
        "-o",
        one.to_str().unwrap(),
        "--material",
        "gold",
        "--size",
        "48",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let err = common::stderr(&out);
    assert!(err.contains("prefiltered a GGX chain in memory"), "{err}");
    let img = common::read_image(&one);
    assert!(img
        .pixels
        .iter()
        .all(|p| p.is_finite() && p.min_element() >= 0.0));

    // Rows metallic, columns roughness, each cell labelled.
    let sheet = dir.path().join("sheet.png");
    let out = common::run([
        "preview",
        sky,
        "-o",
        sheet.to_str().unwrap(),
        "--material",
        "pbr",
        "--size",
        "48",
        "--grid-roughness",
        "0,0.5,1",
        "--grid-metallic",
        "0,1",
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let img = common::read_image(&sheet);
    // Cells of 48 + an 11-pixel label strip, 2-pixel gaps.
    assert_eq!(
        (img.width, img.height),
        (3 * 48 + 4 * 2, 2 * (48 + 11) + 3 * 2)
    );

    let chrome = ["preview", sky, "-o", "x.png", "--size", "8"];
    for (extra, needle) in [
        (&["--grid-roughness", "0.5"][..], "needs a pbr material"),
        (
            &["--material", "pbr", "--grid-metallic", "0,1.5"][..],
            "between 0 and 1",
        ),
        (
            &["--material", "pbr", "--target", "godot"][..],
            "prefilters the panorama itself",
        ),
        (&["--target", "bevy"][..], "not pbr"),
    ] {
        let out = common::run([&chrome[..], extra].concat());
        let err = common::stderr(&out);
        assert!(!out.status.success(), "{extra:?}");
        assert!(err.contains(needle), "{extra:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{extra:?}: {err}");
    }
    let out = common::run(
        [
            &chrome[..],
            &[
                "--material",
                "pbr",
                "--grid",
                "pbr,gold",
                "--grid-roughness",
                "0,1",
            ],
        ]
        .concat(),
    );
    assert!(
        !out.status.success(),
        "--grid and --grid-roughness exclude each other"
    );
}

/// A real panorama with a sun (esplanade, peak about 30000): the sweep is finite and the sun's
/// highlight falls with roughness.
#[test]
fn real_panorama_sweep_is_finite_and_falls_with_roughness() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let path = real.join("hdr/esplanade.hdr");
    let env = load(&path);
    let setup = pbr::prepare(&env, &path, None).unwrap();
    let (env, split) = (setup.sampler(&env), &setup.split_sum);
    let mut last = f32::INFINITY;
    for r in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
        let img = render(env, split, &pbr(Vec3::ONE, 1.0, r), 64);
        assert!(img
            .pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0));
        let peak = img.pixels.iter().map(|p| p.x).fold(0.0f32, f32::max);
        println!("esplanade, roughness {r}: peak {peak:.1}");
        assert!(peak <= last, "roughness {r}");
        last = peak;
    }
}

/// Next to a sun of 1e28 (the largest value a reader passes on) the pbr preview stays finite.
#[test]
fn pbr_stays_finite_next_to_the_largest_radiance() {
    let sun = Vec3::new(0.3, 0.5, 0.8).normalize();
    let base = CubeMap::from_fn(16, |d| {
        if d.dot(sun) > 0.99 {
            Vec4::new(1e28, 1e28, 1e28, 1.0)
        } else {
            Vec4::splat(0.5)
        }
    });
    let opts = cubeforge::internals::filter::ChainOptions::default();
    let (chain, levels) = cubeforge::internals::filter::prefilter(&base, &opts, &|_| {});
    let mapping = LevelMapping::levels(levels.iter().map(|l| l.roughness.unwrap()).collect());
    let split = cubeforge::internals::preview::pbr::SplitSum::for_cube(&chain, mapping.unwrap());
    for r in [0.0, 0.3, 1.0] {
        for metallic in [0.0, 1.0] {
            let img = render(
                &CubeSampler::new(&chain),
                &split,
                &pbr(Vec3::ONE, metallic, r),
                32,
            );
            assert!(
                img.pixels
                    .iter()
                    .all(|p| p.is_finite() && p.min_element() >= 0.0),
                "roughness {r}, metallic {metallic}"
            );
        }
    }
}

/// In a grid with a pbr material, the texts' materials still see the map as read, not the
/// GGX chain made for the pbr cells.
#[test]
fn texts_materials_beside_pbr_see_the_map_as_read() {
    let dir = tempfile::tempdir().unwrap();
    let sky = sky_exr();
    let (alone, grid) = (dir.path().join("alone.exr"), dir.path().join("grid.exr"));
    let base = ["preview", sky.to_str().unwrap(), "--size", "32", "-o"];
    run_ok(
        &[
            &base[..],
            &[alone.to_str().unwrap(), "--material", "chrome"],
        ]
        .concat(),
    );
    run_ok(
        &[
            &base[..],
            &[grid.to_str().unwrap(), "--grid", "chrome,gold"],
        ]
        .concat(),
    );
    let (a, g) = (common::read_image(&alone), common::read_image(&grid));
    // The first cell of the sheet starts after the 2-pixel gap.
    for y in 0..32 {
        for x in 0..32 {
            assert_eq!(a.get(x, y), g.get(x + 2, y + 2), "({x}, {y})");
        }
    }
}
