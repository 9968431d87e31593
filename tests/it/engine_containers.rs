//! The engine containers: KTX 1 as Filament's cmgen deploys it, Babylon.js .env. Round trips
//! through the library and the CLI (`convert -o x.ktx|x.env`, `info`), independent readers
//! (PlayCanvas's KtxParser; Babylon's own GetEnvInfo, image slicing and spherical-polynomial
//! code, with Pillow decoding the PNGs), the irradiance conventions against analytic
//! environments, and hostile headers.

use crate::common::{self, run, stderr};
use cubeforge::internals::cube::{face_dir, CubeMap};
use cubeforge::internals::filter::sh;
use cubeforge::internals::filter::sh_engines::SphericalPolynomial;
use cubeforge::internals::io::babylon_env;
use cubeforge::internals::io::ktx1::{self, KeyValue, Ktx1Format};
use cubeforge::internals::io::{self, Decoded, GpuFormat, Limits, ReadOptions};
use glam::{Vec3, Vec4};
use std::path::Path;
use std::process::Command;

/// An environment of order 2 in each channel (so its irradiance is known exactly), HDR in blue:
/// r = 2 + 1.5 z + 0.5 x y, g = 0.5 + 0.4 x, b = 10 (1 + y).
fn radiance(d: Vec3) -> Vec4 {
    Vec4::new(
        2.0 + 1.5 * d.z + 0.5 * d.x * d.y,
        0.5 + 0.4 * d.x,
        10.0 * (1.0 + d.y),
        1.0,
    )
}

/// E(n) / pi of [`radiance`]: band factors 1, 2/3, 1/4.
fn irradiance_over_pi(n: Vec3) -> [f64; 3] {
    let (x, y, z) = (n.x as f64, n.y as f64, n.z as f64);
    [
        2.0 + z + 0.5 * 0.25 * x * y, // 1.5 z times 2/3
        0.5 + 0.4 * 2.0 / 3.0 * x,
        10.0 * (1.0 + 2.0 / 3.0 * y),
    ]
}

fn analytic_cube(size: usize) -> CubeMap {
    CubeMap::from_fn(size, radiance)
}

fn directions() -> Vec<Vec3> {
    let mut d = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    d.push(Vec3::ONE.normalize());
    d
}

fn cube_of(decoded: Decoded) -> CubeMap {
    match decoded {
        Decoded::Cube(c) => c,
        Decoded::Image(_) => panic!("expected a cube map"),
    }
}

/// Largest error of `b` against `a`, allowed `rel` of each value (of the texel's brightest
/// channel with `of_max`, as RGBD keeps it) plus `abs`, over every texel of every level: the
/// worst ratio (<= 1 passes).
fn worst_ratio(a: &CubeMap, b: &CubeMap, rel: f32, abs: f32, of_max: bool) -> f32 {
    assert_eq!(a.levels.len(), b.levels.len(), "level counts differ");
    let mut worst = 0.0f32;
    for (la, lb) in a.levels.iter().zip(&b.levels) {
        for (fa, fb) in la.iter().zip(lb) {
            assert_eq!(fa.width, fb.width);
            for (p, q) in fa.pixels.iter().zip(&fb.pixels) {
                for c in 0..3 {
                    let base = if of_max {
                        p.truncate().abs().max_element()
                    } else {
                        p[c].abs()
                    };
                    let allowed = rel * base + abs;
                    worst = worst.max((p[c] - q[c]).abs() / allowed);
                }
            }
        }
    }
    worst
}

#[test]
fn filament_sh_is_cmgen_prescaled_irradiance() {
    // cmgen's renderPreScaledSH3Bands: what Filament's shader evaluates from the "sh" key.
    let cube = analytic_cube(32);
    let s = cubeforge::internals::filter::sh_engines::filament_sh(&sh::project(&cube));
    let mut worst = 0.0f64;
    for n in directions() {
        let (x, y, z) = (n.x as f64, n.y as f64, n.z as f64);
        let poly = [
            1.0,
            y,
            z,
            x,
            y * x,
            y * z,
            3.0 * z * z - 1.0,
            z * x,
            x * x - y * y,
        ];
        let exact = irradiance_over_pi(n);
        for c in 0..3 {
            let v: f64 = (0..9).map(|i| s[i][c] * poly[i]).sum();
            worst = worst.max((v - exact[c]).abs() / exact[c].abs().max(1.0));
        }
    }
    println!("Filament sh vs analytic E/pi: worst relative error {worst:.2e}");
    assert!(worst < 2e-3, "worst {worst}");
}

#[test]
fn ktx1_round_trips_through_cli_convert_and_info() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("in.ktx2");
    let cube = analytic_cube(16);
    std::fs::write(
        &src,
        cubeforge::internals::output::encode_cube(&src, &cube, GpuFormat::Rgba32f).unwrap(),
    )
    .unwrap();
    let out = dir.path().join("out.ktx");
    let r = run([
        "convert".as_ref(),
        src.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));

    let (decoded, meta) =
        cubeforge::internals::convert::read(&out, &ReadOptions::default()).unwrap();
    assert_eq!(meta.file_format, io::FileFormat::Ktx1);
    assert_eq!(meta.pixel_format, "RGBA16F");
    let back = cube_of(decoded);
    assert_eq!(back.levels.len(), 5);
    let want = cube.with_box_mips(None);
    let w = worst_ratio(&want, &back, 1e-3, 1e-4, false);
    assert!(
        w <= 1.0,
        "half-float round trip off by {w} of its allowance"
    );

    let r = run(["info".as_ref(), out.as_os_str()]);
    let text = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", stderr(&r));
    for line in [
        "format:       KTX",
        "layout:       ktx",
        "mip levels:   5",
        "pixel format: RGBA16F",
    ] {
        assert!(text.contains(line), "{line} missing from:\n{text}");
    }
    // And back out to another container.
    let again = dir.path().join("again.dds");
    let r = run([
        "convert".as_ref(),
        out.as_os_str(),
        "-o".as_ref(),
        again.as_os_str(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
}

#[test]
fn playcanvas_reads_our_ktx1() {
    let Some(tools) = common::playcanvas() else {
        return;
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tools/ktx1_check.mjs");
    let cube = CubeMap::from_fn(8, |d| {
        let v = radiance(d) / 20.0;
        Vec4::new(v.x, v.y, v.z, 1.0)
    })
    .with_box_mips(Some(3));
    let sh_values = cubeforge::internals::filter::sh_engines::filament_sh(&sh::project(&cube));
    for (format, pc_name, bpt) in [
        (Ktx1Format::Rgba16f, "RGBA16F", 8),
        (Ktx1Format::Rgb16f, "RGB16F", 6),
        (Ktx1Format::Rgba8Srgb, "SRGBA8", 4),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("ibl.ktx");
        let kv = [
            ktx1::sh_key_value(&sh_values),
            KeyValue::text("cubeforge.note", "test"),
        ];
        std::fs::write(&file, ktx1::encode(&cube, format, &kv).unwrap()).unwrap();
        let out = Command::new("node")
            .arg(&script)
            .arg(&tools)
            .arg(&file)
            .arg(dir.path())
            .output()
            .expect("run node");
        assert!(out.status.success(), "{format:?}: {}", stderr(&out));
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        println!("{format:?}: {j}");
        assert_eq!(j["format"], pc_name);
        assert_eq!(
            (j["width"].as_u64(), j["height"].as_u64()),
            (Some(8), Some(8))
        );
        assert_eq!(j["cubemap"], true);
        assert_eq!(j["levels"], 3);
        assert_eq!(j["keyValues"]["cubeforge.note"], "test\0");
        assert!(j["keyValues"]["KTXwriter"]
            .as_str()
            .unwrap()
            .starts_with("cubeforge"));
        let text = j["keyValues"]["sh"].as_str().unwrap().as_bytes().to_vec();
        assert_eq!(ktx1::parse_sh(&text).unwrap().len(), 9);

        // The texels PlayCanvas sliced out, decoded here, against the cube written.
        for (l, faces) in cube.levels.iter().enumerate() {
            let n = faces[0].width;
            let row = (n * bpt).div_ceil(4) * 4;
            for (f, face) in faces.iter().enumerate() {
                let b = std::fs::read(dir.path().join(format!("m{l}_f{f}.bin"))).unwrap();
                assert_eq!(b.len(), row * n, "{format:?} level {l} face {f}");
                for y in 0..n {
                    for x in 0..n {
                        let t = &b[y * row + x * bpt..y * row + (x + 1) * bpt];
                        let got: Vec<f32> = match format {
                            Ktx1Format::Rgba8Srgb => (0..3)
                                .map(|c| {
                                    cubeforge::internals::image::srgb_to_linear(t[c] as f32 / 255.0)
                                })
                                .collect(),
                            _ => (0..3)
                                .map(|c| {
                                    half::f16::from_le_bytes([t[2 * c], t[2 * c + 1]]).to_f32()
                                })
                                .collect(),
                        };
                        let want = face.get(x, y);
                        for c in 0..3 {
                            let tol = if format == Ktx1Format::Rgba8Srgb {
                                0.01
                            } else {
                                1e-3 * want[c].abs() + 1e-4
                            };
                            assert!(
                                (got[c] - want[c]).abs() <= tol,
                                "{format:?} level {l} face {f} ({x}, {y}) channel {c}: {} vs {}",
                                got[c],
                                want[c]
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Level 0's faces as RGBA float32, face by face, rows in face order.
fn faces_f32(cube: &CubeMap) -> Vec<u8> {
    cube.levels[0]
        .iter()
        .flat_map(|f| f.pixels.iter())
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
        .collect()
}

#[test]
fn babylon_reads_our_env() {
    let Some(tools) = common::babylon_core() else {
        return;
    };
    if !common::pillow_png() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Through the CLI: a float KTX2 in, an .env out (box mips, polynomial of level 0).
    let cube = analytic_cube(32);
    let src = dir.path().join("in.ktx2");
    std::fs::write(
        &src,
        cubeforge::internals::output::encode_cube(&src, &cube, GpuFormat::Rgba32f).unwrap(),
    )
    .unwrap();
    let file = dir.path().join("studio.env");
    let r = run([
        "convert".as_ref(),
        src.as_os_str(),
        "-o".as_ref(),
        file.as_os_str(),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let faces = dir.path().join("faces.f32");
    std::fs::write(&faces, faces_f32(&cube)).unwrap();

    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tools/env_check.mjs");
    let out = Command::new("node")
        .arg(&script)
        .arg(&tools)
        .arg(&file)
        .arg(dir.path())
        .arg(&faces)
        .output()
        .expect("run node");
    assert!(out.status.success(), "{}", stderr(&out));
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    println!("Babylon {} read: {}", j["babylonVersion"], j["width"]);
    assert_eq!(j["version"], 2);
    assert_eq!(j["width"], 32);
    assert_eq!(j["imageType"], "image/png");
    assert_eq!(j["lodGenerationScale"], 0.8);
    assert_eq!(j["levels"], 6);
    assert_eq!(j["images"], 36);

    // Babylon's own polynomial from the same faces against the one we stored.
    let keys = ["x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy"];
    let scale = keys
        .iter()
        .flat_map(|k| (0..3).map(move |c| (k, c)))
        .map(|(k, c)| j["babylonPolynomial"][k][c].as_f64().unwrap().abs())
        .fold(0.0, f64::max);
    let mut worst = 0.0f64;
    for k in keys {
        for c in 0..3 {
            let theirs = j["babylonPolynomial"][k][c].as_f64().unwrap();
            let ours = j["irradiance"][k][c].as_f64().unwrap();
            worst = worst.max((theirs - ours).abs() / scale);
        }
    }
    println!("polynomial: ours vs Babylon's CubeMapToSphericalPolynomialTools, worst {worst:.2e} of the largest coefficient");
    assert!(worst < 1e-4, "worst {worst}");

    // Babylon's shader path (FromPolynomial, preScaleForRendering) against analytic E / pi.
    let mut worst = 0.0f64;
    for (i, n) in directions().into_iter().enumerate() {
        let exact = irradiance_over_pi(n);
        for c in 0..3 {
            let got = j["shaderIrradiance"][i][c].as_f64().unwrap();
            worst = worst.max((got - exact[c]).abs() / exact[c].abs().max(1.0));
        }
    }
    println!("Babylon's shader irradiance from our file vs analytic E/pi: worst {worst:.2e}");
    assert!(worst < 3e-3, "worst {worst}");

    // The PNGs Babylon sliced out, decoded by Pillow with Babylon's fromRGBD, every level.
    let py = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tools/rgbd_faces.py");
    let out = Command::new("python3")
        .arg(&py)
        .arg(dir.path())
        .arg("6")
        .output()
        .expect("run python3");
    assert!(out.status.success(), "{}", stderr(&out));
    let decoded = CubeMap {
        levels: (0..6)
            .map(|l| {
                let n = 32 >> l;
                std::array::from_fn(|f| {
                    let b = std::fs::read(dir.path().join(format!("m{l}_f{f}.f32"))).unwrap();
                    let v: Vec<f32> = b
                        .chunks_exact(4)
                        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                        .collect();
                    cubeforge::internals::image::Image::from_fn(n, n, |x, y| {
                        let i = 3 * (y * n + x);
                        Vec4::new(v[i], v[i + 1], v[i + 2], 1.0)
                    })
                })
            })
            .collect(),
    };
    let want = cube.clone().with_box_mips(None);
    // RGBD in 8 bits: the brightest channel of a texel keeps 8 bits of gamma-2.2 precision
    // in (0.5, 1], so about 0.6% of it; the others are relative to it.
    let mut worst = 0.0f32;
    let mut psnr_min = f64::INFINITY;
    for (la, lb) in want.levels.iter().zip(&decoded.levels) {
        for (fa, fb) in la.iter().zip(lb) {
            for (p, q) in fa.pixels.iter().zip(&fb.pixels) {
                let allowed = 0.01 * p.truncate().max_element() + 1e-3;
                worst = worst.max((p.truncate() - q.truncate()).abs().max_element() / allowed);
            }
            psnr_min = psnr_min.min(common::psnr(fa, fb, 20.0));
        }
    }
    println!("RGBD faces (Pillow + fromRGBD) vs our cube: worst {worst:.2} of 1% + 1e-3, PSNR >= {psnr_min:.1} dB (peak 20)");
    assert!(worst <= 1.0, "worst {worst}");
    // Orientation: +Y's face is bright blue (b = 10 (1 + y)), -Y's dark: a flipped or swapped
    // face would not match texel for texel above, and this says which way is up.
    assert!(decoded.levels[0][2].get(16, 16).z > 19.0);
    assert!(decoded.levels[0][3].get(16, 16).z < 1.0);
    let top_of_px = face_dir(0, 0.5, 0.5 / 32.0).normalize();
    assert!(top_of_px.y > 0.6);
    assert!(decoded.levels[0][0].get(16, 0).z > 16.0);
    assert!(decoded.levels[0][0].get(16, 31).z < 4.0);
}

#[test]
fn env_round_trips_through_read_and_info() {
    let dir = tempfile::tempdir().unwrap();
    let cube = analytic_cube(16).with_box_mips(None);
    let poly = SphericalPolynomial::from_radiance_sh(&sh::project(&cube)).coefficients();
    let file = dir.path().join("x.env");
    std::fs::write(&file, babylon_env::encode(&cube, Some(&poly), 0.8).unwrap()).unwrap();
    let env = babylon_env::read(&std::fs::read(&file).unwrap(), &file, &Limits::default()).unwrap();
    assert_eq!(env.version, 2);
    assert_eq!(env.lod_generation_scale, 0.8);
    assert!(worst_ratio(&cube, &env.cube, 0.01, 1e-3, true) <= 1.0);
    // The same file, byte for byte, every time.
    assert_eq!(
        babylon_env::encode(&cube, Some(&poly), 0.8).unwrap(),
        std::fs::read(&file).unwrap()
    );

    let r = run(["info".as_ref(), file.as_os_str()]);
    let text = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{}", stderr(&r));
    for line in [
        "format:       Babylon.js env",
        "layout:       env",
        "mip levels:   5",
        "pixel format: RGBD8 (PNG)",
    ] {
        assert!(text.contains(line), "{line} missing from:\n{text}");
    }
    // Not a full chain, or not a power of two: refused with why.
    let short = cube.clone();
    let mut short = short;
    short.levels.truncate(2);
    assert!(babylon_env::encode(&short, None, 0.8)
        .unwrap_err()
        .contains("every mip level"));
    let odd = CubeMap::from_fn(12, radiance).with_box_mips(None);
    assert!(babylon_env::encode(&odd, None, 0.8)
        .unwrap_err()
        .contains("power-of-two"));
}

/// Reads `bytes` as `name` through io::read and returns the one-line error.
fn refused(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let opts = ReadOptions {
        limits: Limits {
            max_memory: 1 << 30,
            ..Limits::default()
        },
        ..ReadOptions::default()
    };
    match cubeforge::internals::convert::read(&path, &opts) {
        Ok(_) => panic!("{name} was read"),
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "{msg}");
            assert!(msg.contains(name), "{msg}");
            msg
        }
    }
}

#[test]
fn hostile_ktx1_and_env_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cube = analytic_cube(4).with_box_mips(None);
    let good = ktx1::encode(&cube, Ktx1Format::Rgba16f, &[]).unwrap();
    let set = |b: &mut Vec<u8>, field: usize, v: u32| {
        b[12 + 4 * field..16 + 4 * field].copy_from_slice(&v.to_le_bytes())
    };
    let mut huge = good.clone();
    set(&mut huge, 6, 1 << 30);
    set(&mut huge, 7, 1 << 30);
    assert!(refused(d, "huge.ktx", &huge).contains("limit"));
    let mut levels = good.clone();
    set(&mut levels, 11, 40);
    assert!(refused(d, "levels.ktx", &levels).contains("numberOfMipmapLevels"));
    let mut kv = good.clone();
    set(&mut kv, 12, u32::MAX);
    assert!(refused(d, "kv.ktx", &kv).contains("key/value"));
    let mut faces = good.clone();
    set(&mut faces, 10, 5);
    assert!(refused(d, "faces.ktx", &faces).contains("numberOfFaces"));
    let mut endian = good.clone();
    set(&mut endian, 0, 7);
    assert!(refused(d, "endian.ktx", &endian).contains("endianness"));
    let mut compressed = good.clone();
    set(&mut compressed, 1, 0);
    assert!(refused(d, "bc.ktx", &compressed).contains("compressed"));
    assert!(refused(d, "cut.ktx", &good[..good.len() - 3]).contains("truncated"));
    assert!(refused(d, "head.ktx", &good[..40]).contains("truncated"));

    let poly = SphericalPolynomial::default().coefficients();
    let env = babylon_env::encode(&cube, Some(&poly), 0.8).unwrap();
    assert!(refused(d, "cut.env", &env[..env.len() - 10]).contains("truncated"));
    assert!(refused(d, "nonul.env", &env[..20]).contains("NUL"));
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    let json_end = env.iter().position(|&b| b == 0).unwrap();
    let manifest = text(&env[8..json_end]);
    let with = |m: String| {
        let mut b = babylon_env::MAGIC.to_vec();
        b.extend_from_slice(m.as_bytes());
        b.extend_from_slice(&env[json_end..]);
        b
    };
    let wide = with(manifest.replacen("\"width\":4", "\"width\":1073741824", 1));
    assert!(refused(d, "wide.env", &wide).contains("limit"));
    let npot = with(manifest.replacen("\"width\":4", "\"width\":3", 1));
    assert!(refused(d, "npot.env", &npot).contains("power of two"));
    let v9 = with(manifest.replacen("\"version\":2", "\"version\":9", 1));
    assert!(refused(d, "v9.env", &v9).contains("version 9"));
    let webp = with(manifest.replacen("image/png", "image/webp", 1));
    assert!(refused(d, "webp.env", &webp).contains("image/webp"));
    let far = with(manifest.replacen("\"position\":0", "\"position\":99999999999", 1));
    assert!(refused(d, "far.env", &far).contains("truncated"));
    assert!(refused(d, "json.env", &with("{nope".into())).contains("manifest"));
    // A PNG of the wrong size where a level's face belongs.
    let mut swapped = env.clone();
    let start = json_end + 1;
    swapped[start + 16..start + 24].copy_from_slice(&[0, 0, 0, 9, 0, 0, 0, 9]);
    let msg = refused(d, "png.env", &swapped);
    assert!(msg.contains("level 0, face px"), "{msg}");
}
