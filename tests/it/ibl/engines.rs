//! What each engine gets: the marker seen un-mirrored through its lookup, its chains'
//! roughness per level and mapping, light kept, and the files of each target.

use super::*;
use cubeforge::internals::ibl::RoughnessMapping;

#[test]
fn each_engine_sees_the_panorama_unmirrored() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    // (target, specular file, the engine's lookup as cube direction -> world direction,
    // right-handed world, where the panorama's centre faces)
    type WorldOf = fn(Vec3) -> Vec3;
    let cases: [(&str, &str, WorldOf, bool, Vec3); 4] = [
        // Filament looks its cube maps up with the world direction (right-handed); cmgen
        // mirrors X first, so the view is the panorama's, centre at +Z.
        ("filament", "env_ibl.ktx", |d| d, true, Vec3::Z),
        // Babylon's default scene is left-handed and looks the cube up with the world direction.
        ("babylon", "env.env", |d| d, false, Vec3::Z),
        // Bevy samples (x, y, -z) of the world direction (environment_map.wesl).
        (
            "bevy",
            "env_specular.ktx2",
            |d| Vec3::new(d.x, d.y, -d.z),
            true,
            -Vec3::Z,
        ),
        // The Sample Viewer samples u_EnvRotation * w, a 90-degree turn about +Y by default:
        // cube = (w.z, w.y, -w.x), so w = (-d.z, d.y, d.x).
        (
            "gltf",
            "env_ggx.ktx2",
            |d| Vec3::new(-d.z, d.y, d.x),
            true,
            Vec3::Z,
        ),
    ];
    for (target, file, world_of, rh, ahead) in cases {
        let out = dir.path().join(target);
        // Babylon's .env holds every level down to 1 x 1.
        let args: &[&str] = if target == "babylon" {
            &BABYLON
        } else {
            &SMALL
        };
        ibl(&input, &out, target, args);
        let cube = read_cube(&out.join(file));
        assert_unmirrored(target, marks_in_world(&cube, world_of), rh, ahead);
    }
    // The check catches a mirror: Bevy's files looked up without its z flip read mirrored.
    let cube = read_cube(&dir.path().join("bevy/env_specular.ktx2"));
    let marks = marks_in_world(&cube, |d| d);
    let caught = std::panic::catch_unwind(|| assert_unmirrored("control", marks, true, Vec3::Z));
    assert!(caught.is_err(), "a mirrored lookup passed");
}

#[test]
fn chains_hold_the_engines_roughness_per_level() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    for (target, file, count) in [
        ("bevy", "env_specular.ktx2", 4),
        ("gltf", "env_ggx.ktx2", 4),
        ("generic", "env_specular.ktx2", 4),
    ] {
        let out = dir.path().join(target);
        ibl(&input, &out, target, &SMALL);
        let levels = levels_of(&out.join(file));
        assert_eq!(levels.level_count, count, "{target}");
        let cube = read_cube(&out.join(file));
        assert_eq!(cube.levels.len(), count, "{target}");
        assert_eq!(cube.size(), 32, "{target}");
        for l in &levels.levels {
            let r = l.level as f32 / (count - 1) as f32;
            assert!((l.roughness.unwrap() - r).abs() < 1e-6, "{target}: {l:?}");
            assert!((l.alpha.unwrap() - r * r).abs() < 1e-6, "{target}: {l:?}");
        }
    }
    // Default sizes: Bevy's chain from 512 stops at 8 px (7 levels), the diffuse cube is 32;
    // the marker panorama's 64 px faces cap it at 64 (4 levels), and --size 512 has it anyway.
    let out = dir.path().join("bevy_default");
    ibl(&input, &out, "bevy", &["--samples", "4"]);
    let spec = read_cube(&out.join("env_specular.ktx2"));
    assert_eq!(
        spec.levels.iter().map(|l| l[0].width).collect::<Vec<_>>(),
        [64, 32, 16, 8]
    );
    assert_eq!(read_cube(&out.join("env_diffuse.ktx2")).size(), 32);
    let out = dir.path().join("bevy_512");
    ibl(&input, &out, "bevy", &["--samples", "4", "--size", "512"]);
    let spec = read_cube(&out.join("env_specular.ktx2"));
    assert_eq!(
        spec.levels.iter().map(|l| l[0].width).collect::<Vec<_>>(),
        [512, 256, 128, 64, 32, 16, 8]
    );
}

#[test]
fn roughness_mappings_follow_the_engines_shaders() {
    // Filament's shader picks lod = (levels - 1) * r (2 - r); its chain holds the inverse.
    for count in [5, 6] {
        for m in 0..count {
            let r = RoughnessMapping::Filament.roughness(m, count, 256);
            let lod = (count - 1) as f32 * r * (2.0 - r);
            assert!((lod - m as f32).abs() < 1e-4, "{m}/{count}: {r}");
        }
    }
    // Babylon's shader picks lod = log2(width * alpha) * 0.8 with alpha = r^2 (+ 0.0005).
    for m in 1..6 {
        let r = RoughnessMapping::Babylon.roughness(m, 9, 256);
        let lod = (256.0 * r * r).log2() * 0.8;
        assert!((lod - m as f32).abs() < 1e-3, "{m}: {r}");
    }
    assert_eq!(RoughnessMapping::Babylon.roughness(0, 9, 256), 0.0);
    assert_eq!(RoughnessMapping::Babylon.roughness(8, 9, 256), 1.0);
    assert_eq!(RoughnessMapping::Linear.roughness(3, 4, 256), 1.0);
}

#[test]
fn light_is_kept_in_the_specular_and_diffuse_maps() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let input = real.join("hdr/venice.hdr");
    let out = dir.path().join("generic");
    ibl(
        &input,
        &out,
        "generic",
        &["--size", "64", "--samples", "32"],
    );
    let flux = |cube: &CubeMap, level: usize| -> [f64; 3] {
        let faces = &cube.levels[level];
        [0, 1, 2].map(|c| common::sphere_mean(faces, c))
    };
    let source = {
        let o = run(["info", input.to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let f = &v["flux"];
        [0, 1, 2].map(|c| f[c].as_f64().unwrap())
    };
    let spec = read_cube(&out.join("env_specular.ktx2"));
    let diff = read_cube(&out.join("env_diffuse.ktx2"));
    for (what, got) in [
        ("specular level 0", flux(&spec, 0)),
        ("specular level 3", flux(&spec, 3)),
        ("diffuse", flux(&diff, 0)),
    ] {
        for c in 0..3 {
            let rel = (got[c] / source[c] - 1.0).abs();
            assert!(
                rel < 0.005,
                "{what} channel {c}: {} vs {}",
                got[c],
                source[c]
            );
        }
    }
    // The SH file's constant term is the same mean radiance.
    let sh: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("env_sh.json")).unwrap()).unwrap();
    let c0 = sh["radiance"][0][0].as_f64().unwrap() * 0.282_094_791_773_878_1;
    assert!(
        (c0 / source[0] - 1.0).abs() < 0.005,
        "{c0} vs {}",
        source[0]
    );
}

#[test]
fn filament_gets_cmgen_files_and_its_sh_convention() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let out = dir.path().join("filament");
    ibl(
        &input,
        &out,
        "filament",
        &["--size", "64", "--samples", "16"],
    );
    let bytes = std::fs::read(out.join("env_ibl.ktx")).unwrap();
    let k = io::ktx1::read(&bytes, Path::new("env_ibl.ktx"), &io::Limits::default()).unwrap();
    // 64 down to 16 px: 3 levels, roughness 1 - sqrt(1 - lod) with lod = m / 2.
    assert_eq!(k.levels, 3);
    let levels: LevelsFile =
        serde_json::from_slice(k.value(io::ktx2::LEVELS_KEY).expect("levels key")).unwrap();
    for l in &levels.levels {
        let lod = l.level as f32 / 2.0;
        let r = 1.0 - (1.0 - lod).sqrt();
        assert!((l.roughness.unwrap() - r).abs() < 1e-6, "{l:?}");
    }
    // The "sh" key, evaluated as Filament's shader does, is the irradiance map's value (both
    // over pi) in every direction, within the SH's own smoothing.
    let sh = k.sh().expect("sh key");
    let diffuse = read_cube(&out.join("env_irradiance.ktx"));
    let n = diffuse.size();
    let mut worst = 0.0f64;
    let mut peak = 0.0f64;
    for (f, face) in diffuse.levels[0].iter().enumerate() {
        for y in 0..n {
            for x in 0..n {
                let d = face_dir(f, (x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32)
                    .normalize();
                let (x_, y_, z_) = (d.x as f64, d.y as f64, d.z as f64);
                let poly = [
                    1.0,
                    y_,
                    z_,
                    x_,
                    y_ * x_,
                    y_ * z_,
                    3.0 * z_ * z_ - 1.0,
                    z_ * x_,
                    x_ * x_ - y_ * y_,
                ];
                for c in 0..3 {
                    let e: f64 = sh.iter().zip(poly).map(|(k, p)| k[c] * p).sum();
                    let want = face.pixels[y * n + x][c] as f64;
                    worst = worst.max((e - want).abs());
                    peak = peak.max(want);
                }
            }
        }
    }
    assert!(
        worst < 0.1 * peak,
        "SH vs irradiance map: {worst} (peak {peak})"
    );
    let txt = std::fs::read_to_string(out.join("sh.txt")).unwrap();
    assert_eq!(txt.lines().count(), 9, "{txt}");
    assert!(txt.starts_with('(') && txt.contains("// L00"), "{txt}");
    // The skybox: one level, the environment at the input's resolution (64 px faces).
    let sky = read_cube(&out.join("env_skybox.ktx"));
    assert_eq!((sky.levels.len(), sky.size()), (1, 64));
}

#[test]
fn gltf_ships_the_sheen_chain_and_the_tables() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let out = dir.path().join("gltf");
    let mut args = SMALL.to_vec();
    args.push("--sheen");
    ibl(&input, &out, "gltf", &args);
    let charlie = levels_of(&out.join("env_charlie.ktx2"));
    assert_eq!(charlie.level_count, 4);
    for l in &charlie.levels {
        assert_eq!(l.filter, cubeforge::internals::filter::FilterKind::Charlie);
        assert!(
            (l.roughness.unwrap() - l.level as f32 / 3.0).abs() < 1e-6,
            "{l:?}"
        );
    }
    // The tables: 16-bit linear, roughness 0 in row 0; the DFG's scale + bias is 1 for a
    // smooth surface at normal incidence (Schlick at F0 = 1).
    for (file, charlie) in [("lut_ggx.png", false), ("lut_charlie.png", true)] {
        let opts = ReadOptions {
            linear: true,
            ..ReadOptions::default()
        };
        let Ok((Decoded::Image(img), _)) =
            cubeforge::internals::convert::read(&out.join(file), &opts)
        else {
            panic!("{file}");
        };
        assert_eq!((img.width, img.height), (128, 128), "{file}");
        if !charlie {
            let p = img.pixels[127];
            assert!((p.x + p.y - 1.0).abs() < 0.01, "{file}: {p}");
        }
    }
    // The sheen chain is gltf's alone.
    let r = run([
        "ibl",
        input.to_str().unwrap(),
        "-o",
        dir.path().join("b").to_str().unwrap(),
        "--target",
        "bevy",
        "--sheen",
    ]);
    assert!(!r.status.success());
    assert!(stderr(&r).contains("gltf"), "{}", stderr(&r));
}

#[test]
fn panorama_targets_write_what_the_engine_imports() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    for (target, file) in [
        ("godot", "env.exr"),
        ("unity", "env.exr"),
        ("unreal", "env.hdr"),
    ] {
        let out = dir.path().join(target);
        ibl(&input, &out, target, &[]);
        let img = common::read_image(&out.join(file));
        assert_eq!((img.width, img.height), (256, 128), "{target}");
        // Written as is: the centre mark stays in the middle of the panorama.
        let c = img.pixels[64 * 256 + 128];
        assert!(c.x > 5.0 && c.y < 1.0, "{target}: {c}");
    }
}
