//! Seeded mutations of the text front doors: control recipes, material files, a control
//! map's sidecar and a DDS chain's levels.json.

use crate::harness::{campaign, encoded, limits, test_cube, test_image};
use crate::mutator::Mutator;
use cubeforge::internals::control::{self, Size, Syntax};
use cubeforge::internals::io::{self, GpuFormat, ReadOptions, WriteOptions};
use std::path::Path;

/// Control recipes (TOML and JSON) through `control::parse`, and baked at 16x16 when they
/// parse: the recipes in fixtures/control, and one that reads an image.
#[test]
fn recipe_mutations() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("recipes");
    std::fs::create_dir(&base).unwrap();
    let png = encoded("x.png", &test_image(12, 10), &WriteOptions::default());
    std::fs::write(dir.path().join("sky.png"), &png).unwrap();
    std::fs::write(base.join("small.png"), &png).unwrap();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/control");
    let mut sources: Vec<(String, String, Syntax)> = Vec::new();
    for name in [
        "chrome_and_paint.toml",
        "frosted_glass.toml",
        "wet_ground.json",
    ] {
        let path = fixtures.join(name);
        let syntax = Syntax::from_path(&path).unwrap();
        sources.push((name.into(), std::fs::read_to_string(&path).unwrap(), syntax));
    }
    sources.push((
        "image recipe".into(),
        "size = \"24x16\"\nmax_lod_bias = 3\n[reflectivity]\nimage = { path = \"small.png\", channel = \"r\", srgb = true }\ninvert = true\n[fresnel]\nimage = { path = \"small.png\", channel = \"luminance\" }\nremap = { in = [0.1, 0.9], out = [0, 1], gamma = 2 }\n[pack]\nr = \"fresnel\"\ng = \"reflectivity\"\n"
            .into(),
        Syntax::Toml,
    ));
    let origin = Path::new("recipe-under-test");
    let door = |text: &[u8], syntax: Syntax| -> cubeforge::Result<()> {
        let text = String::from_utf8_lossy(text);
        let recipe = control::parse(&text, syntax, origin, &base, &limits())?;
        recipe.bake(Some(Size::new(16, 16).unwrap()), &limits())?;
        Ok(())
    };
    for (i, (what, text, syntax)) in sources.into_iter().enumerate() {
        door(text.as_bytes(), syntax).unwrap_or_else(|e| panic!("{what}: the valid recipe: {e}"));
        let mutator = Mutator::new(0x3f84_d5b5_b547_0917 + i as u64, Vec::new(), true);
        campaign(
            &what,
            text.as_bytes(),
            mutator,
            150,
            "recipe-under-test",
            &|b| door(b, syntax),
        );
    }
}

/// Material files through `material::parse_toml`: every preset as written by `to_toml`.
#[test]
fn material_mutations() {
    use cubeforge::internals::preview::material;
    let path = Path::new("material-under-test.toml");
    for (i, (preset, _)) in material::presets().into_iter().enumerate() {
        let text = material::to_toml(&preset);
        let mutator = Mutator::new(0x9216_d5d9_8979_fb1b + i as u64, Vec::new(), true);
        campaign(
            &format!("material {}", preset.name),
            text.as_bytes(),
            mutator,
            60,
            "material-under-test",
            &|b| material::parse_toml(&String::from_utf8_lossy(b), path).map(drop),
        );
    }
}

/// A control map's sidecar (`MAP.json`) through `preview::read_control`, and a DDS chain's
/// `NAME.dds.levels.json` through `info::describe`.
#[test]
fn sidecar_mutations() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("map.png");
    std::fs::write(
        &map,
        encoded("x.png", &test_image(8, 8), &WriteOptions::default()),
    )
    .unwrap();
    let side = dir.path().join("map.png.json");
    let text = br#"{ "max_lod_bias": 6.0, "pack": { "r": "reflectivity", "g": "transmittance", "b": "blur", "a": "fresnel" } }"#;
    let mutator = Mutator::new(0xd131_0ba6_98df_b5ac, Vec::new(), true);
    campaign(
        "control sidecar",
        text,
        mutator,
        100,
        "map.png.json",
        &|b| {
            std::fs::write(&side, b).unwrap();
            match cubeforge::internals::preview::read_control(&map, 4.0, &Default::default()) {
                // A bad sidecar must be named, not the map.
                Err(e) if !e.to_string().contains("map.png.json") => Err(cubeforge::Error::file(
                    &side,
                    format!("blamed on the map: {e}"),
                )),
                r => r.map(drop),
            }
        },
    );

    let dds = dir.path().join("chain.dds");
    std::fs::write(
        &dds,
        io::dds::encode(&test_cube(4), GpuFormat::Rgba16f).unwrap(),
    )
    .unwrap();
    let levels = dir.path().join("chain.dds.levels.json");
    let text = br#"{"levels":[{"level":0,"size":4,"roughness":0.0},{"level":1,"size":2,"roughness":0.5},{"level":2,"size":1,"roughness":1.0}]}"#;
    let mutator = Mutator::new(0x2ffd_72db_d01a_dfb7, Vec::new(), true);
    let opts = ReadOptions {
        limits: limits(),
        linear: false,
        as_stored: false,
        ..Default::default()
    };
    campaign("levels.json", text, mutator, 100, "chain.dds", &|b| {
        std::fs::write(&levels, b).unwrap();
        cubeforge::internals::info::describe(&dds, None, &opts).map(drop)
    });
}
