//! `ibl --sun` (issue 49): the sun taken out of the maps with its light, and each target's
//! snippet shining it from where each engine shows the sun of the files written without
//! `--sun` (that file's bright disc, looked up through the engine's own lookup, written here
//! apart from the code).

use super::*;
use cubeforge::internals::layout::equirect;
use glam::Quat;

/// Where the test sky's sun is (cubeforge's frame), its radius and radiance.
pub(crate) const SUN_AT: Vec3 = Vec3::new(0.5, 0.6, -0.62);
pub(crate) const RADIUS_DEG: f32 = 2.0;
pub(crate) const RADIANCE: f32 = 20000.0;

/// A 512 x 256 sky of 0.5 to 1 with a disc, each texel the mean of 4 x 4 sub-samples.
pub(crate) fn sky_with_sun(dir: &Path) -> PathBuf {
    let (w, h) = (512, 256);
    let at = SUN_AT.normalize();
    let cos_r = RADIUS_DEG.to_radians().cos();
    let img = Image::from_fn(w, h, |x, y| {
        let mut acc = Vec3::ZERO;
        for j in 0..4 {
            for i in 0..4 {
                let u = (x as f32 + (i as f32 + 0.5) / 4.0) / w as f32;
                let v = (y as f32 + (j as f32 + 0.5) / 4.0) / h as f32;
                let d = equirect::uv_to_dir(u, v);
                let sky = Vec3::new(0.5, 0.7, 1.0) * (0.5 + 0.5 * d.y.max(0.0));
                acc += sky
                    + if d.dot(at) >= cos_r {
                        Vec3::new(1.0, 0.9, 0.7) * RADIANCE
                    } else {
                        Vec3::ZERO
                    };
            }
        }
        (acc / 16.0).extend(1.0)
    });
    let path = dir.join("sunny.exr");
    common::write_image(&path, &img);
    path
}

/// `ibl` with its printed report (the snippet).
fn ibl_out(input: &Path, out: &Path, target: &str, extra: &[&str]) -> String {
    let mut args = vec![
        "ibl",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--target",
        target,
    ];
    args.extend_from_slice(extra);
    let o = run(&args);
    assert!(o.status.success(), "{target}: {}", stderr(&o));
    String::from_utf8(o.stdout).unwrap()
}

/// The three numbers after `start` in `text`.
fn numbers_after(text: &str, start: &str, count: usize) -> Vec<f32> {
    let at = text
        .find(start)
        .unwrap_or_else(|| panic!("no {start:?} in {text}"))
        + start.len();
    text[at..]
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter(|s| !s.is_empty())
        .take(count)
        .map(|s| s.parse().unwrap())
        .collect()
}

/// The direction towards the sun each snippet writes, in its engine's world.
fn towards_in_snippet(target: &str, s: &str) -> Vec3 {
    let v = |start: &str| {
        let n = numbers_after(s, start, 3);
        Vec3::new(n[0], n[1], n[2]).normalize()
    };
    match target {
        "bevy" => v("Transform::from_xyz("),
        "three" => v("sun.position.set("),
        "godot" => v("look_at_from_position(Vector3("),
        "filament" => -v(".direction({"),
        "babylon" => -v("new BABYLON.Vector3("),
        "unity" => -v("LookRotation(new Vector3("),
        "unreal" => -v("FVector("),
        "generic" => v("towards ("),
        // A glTF light shines along its node's -Z.
        "gltf" => {
            let q = numbers_after(s, "\"rotation\": [", 4);
            -(Quat::from_xyzw(q[0], q[1], q[2], q[3]) * Vec3::NEG_Z)
        }
        _ => unreachable!(),
    }
}

/// The direction in the target's file that the engine looks up for world direction `w`.
fn lookup(target: &str, w: Vec3) -> Vec3 {
    match target {
        "bevy" => Vec3::new(w.x, w.y, -w.z),
        "gltf" => Vec3::new(w.z, w.y, -w.x),
        "three" => Vec3::new(w.z, w.y, w.x),
        "godot" => Vec3::new(-w.x, w.y, w.z),
        "unreal" => Vec3::new(w.x, w.z, -w.y),
        _ => w,
    }
}

/// The luminance-weighted centroid of the texels above half the brightest one, with its
/// direction for each texel.
fn centroid(texels: impl Iterator<Item = (Vec3, Vec4)> + Clone) -> Vec3 {
    let lum = |p: Vec4| 0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z;
    let top = texels.clone().map(|(_, p)| lum(p)).fold(0.0, f32::max);
    let sum: Vec3 = texels
        .filter(|(_, p)| lum(*p) > top / 2.0)
        .map(|(d, p)| d * lum(p))
        .sum();
    sum.normalize()
}

/// Where the bright disc is in a target's file (level 0 of its chain, or its panorama).
fn disc_in_file(path: &Path) -> Vec3 {
    let opts = ReadOptions {
        as_stored: true,
        ..ReadOptions::default()
    };
    match cubeforge::internals::convert::read(path, &opts).unwrap().0 {
        Decoded::Cube(c) => {
            let n = c.size();
            let faces = &c.levels[0];
            centroid((0..6).flat_map(move |f| {
                (0..n * n).map(move |i| {
                    let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
                    (
                        face_dir(f, x / n as f32, y / n as f32).normalize(),
                        faces[f].pixels[i],
                    )
                })
            }))
        }
        Decoded::Image(img) => {
            let (w, h) = (img.width, img.height);
            let img = &img;
            centroid((0..w * h).map(move |i| {
                let (u, v) = (
                    ((i % w) as f32 + 0.5) / w as f32,
                    ((i / w) as f32 + 0.5) / h as f32,
                );
                (equirect::uv_to_dir(u, v), img.pixels[i])
            }))
        }
    }
}

const TARGETS: [(&str, &str); 9] = [
    ("bevy", "env_specular.ktx2"),
    ("gltf", "env_ggx.ktx2"),
    ("babylon", "env.env"),
    ("filament", "env_ibl.ktx"),
    ("generic", "env_specular.ktx2"),
    ("three", "env.hdr"),
    ("godot", "env.exr"),
    ("unity", "env.exr"),
    ("unreal", "env.hdr"),
];

/// Each target's light, mapped back through its engine's lookup, points where that engine
/// shows the sun of the files made without `--sun`, within a degree (files of 64 px faces).
#[test]
fn each_targets_light_shines_from_its_sun() {
    let dir = tempfile::tempdir().unwrap();
    let input = sky_with_sun(dir.path());
    let mut offs: Vec<f32> = Vec::new();
    let small = [
        "--size",
        "64",
        "--min-size",
        "8",
        "--diffuse-size",
        "8",
        "--samples",
        "8",
    ];
    for (target, file) in TARGETS {
        for yaw in ["0", "70"] {
            let mut args = small.to_vec();
            args.extend(["--yaw", yaw]);
            // Babylon's .env holds every level down to 1 x 1.
            if target == "babylon" {
                args[3] = "1";
            }
            let plain = dir.path().join(format!("{target}_{yaw}"));
            ibl_out(&input, &plain, target, &args);
            assert!(
                !plain.join("sun.json").exists(),
                "{target}: sun.json without --sun"
            );
            let at = disc_in_file(&plain.join(file));
            let lit = dir.path().join(format!("{target}_{yaw}_sun"));
            args.push("--sun");
            let snippet = ibl_out(&input, &lit, target, &args);
            let w = towards_in_snippet(target, &snippet);
            let off = lookup(target, w).angle_between(at).to_degrees();
            println!("{target} --yaw {yaw}: the light {off:.2} degrees from the files' sun");
            assert!(
                off < 1.0,
                "{target} --yaw {yaw}: {off} degrees off ({w} in the world)"
            );
            offs.push(off);
            let json: serde_json::Value =
                serde_json::from_slice(&std::fs::read(lit.join("sun.json")).unwrap()).unwrap();
            let e = &json["engine_direction"];
            let from_json = Vec3::new(
                e[0].as_f64().unwrap() as f32,
                e[1].as_f64().unwrap() as f32,
                e[2].as_f64().unwrap() as f32,
            );
            assert!(
                from_json.angle_between(w).to_degrees() < 0.01,
                "{target}: {json}"
            );
        }
    }
    let (lo, hi) = offs
        .iter()
        .fold((f32::MAX, 0.0f32), |(a, b), &o| (a.min(o), b.max(o)));
    let text = format!("the light {lo:.2} to {hi:.2} degrees from that disc");
    crate::figures::check("docs/engines.md", "sun targets", &text);
}

/// The known disc: found within 0.5 degree, its irradiance within 3%, gone from the maps, and
/// the chain's flux the source's less the sun's irradiance over 4 pi within 0.5%.
#[test]
fn the_sun_leaves_the_maps_with_its_light() {
    let dir = tempfile::tempdir().unwrap();
    let input = sky_with_sun(dir.path());
    let out = dir.path().join("generic");
    ibl_out(
        &input,
        &out,
        "generic",
        &["--size", "64", "--min-size", "8", "--samples", "8", "--sun"],
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("sun.json")).unwrap()).unwrap();
    let sun = &json["sun"];
    let v = |k: &str| [0, 1, 2].map(|c| sun[k][c].as_f64().unwrap());
    let d = v("direction");
    let off = Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32).angle_between(SUN_AT.normalize());
    let cap = std::f64::consts::TAU * (1.0 - (RADIUS_DEG as f64).to_radians().cos());
    let want = [1.0, 0.9, 0.7].map(|c| c * RADIANCE as f64 * cap);
    let e = v("irradiance");
    println!(
        "sun {:.3} degrees off, irradiance {e:?} against {want:?}",
        off.to_degrees()
    );
    assert!(off.to_degrees() < 0.5);
    for c in 0..3 {
        assert!((e[c] / want[c] - 1.0).abs() < 0.03, "{e:?} vs {want:?}");
    }
    let source = {
        let o = run(["info", input.to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        [0, 1, 2].map(|c| v["flux"][c].as_f64().unwrap())
    };
    let spec = read_cube(&out.join("env_specular.ktx2"));
    let four_pi = 4.0 * std::f64::consts::PI;
    let mut flux_off = 0.0f64;
    for c in 0..3 {
        let got = common::sphere_mean(&spec.levels[0], c);
        let want = source[c] - e[c] / four_pi;
        println!(
            "channel {c}: flux {got:.5}, source less the sun {want:.5} (source {:.5})",
            source[c]
        );
        assert!(
            (got / want - 1.0).abs() < 0.005,
            "channel {c}: {got} vs {want}"
        );
        flux_off = flux_off.max((got / want - 1.0).abs());
    }
    let e_off = (0..3)
        .map(|c| (e[c] / want[c] - 1.0).abs())
        .fold(0.0, f64::max);
    let text = format!(
        "direction {:.3} degrees off, irradiance within {:.2}%, the chain's flux the source's less \
         the sun's irradiance over 4 pi within {:.3}%",
        off.to_degrees(),
        e_off * 100.0,
        flux_off * 100.0
    );
    crate::figures::check("docs/engines.md", "sun disc", &text);
    let top = spec.levels[0]
        .iter()
        .flat_map(|f| &f.pixels)
        .map(|p| p.truncate().max_element())
        .fold(0.0, f32::max);
    assert!(top < 2.0, "the brightest texel left is {top}");
}

/// An overcast sky: --sun leaves the maps as they are and says so.
#[test]
fn no_sun_no_light() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    ibl_out(&input, &a, "bevy", &SMALL);
    let mut args = SMALL.to_vec();
    args.push("--sun");
    let text = ibl_out(&input, &b, "bevy", &args);
    assert!(text.contains("the map has no sun"), "{text}");
    for f in ["env_specular.ktx2", "env_diffuse.ktx2"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(b.join("sun.json")).unwrap()).unwrap();
    assert!(json["sun"].is_null(), "{json}");
}
