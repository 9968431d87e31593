//! OpenEXR's own environment maps (the header attribute `envmap`): files whose texels hold the
//! direction OpenEXR's definitions give them (`LatLongMap::direction`, `CubeMap::direction`
//! and `CubeMap::pixelPosition`, written out here from OpenEXR's ImfEnvmap.cpp), made by this
//! test with the exr crate and by OpenEXR's own `exrenvmap`, read by cubeforge: every texel
//! lands within about a texel of its direction (seamless, the right way round), and `info`
//! says what the file declared; and how `info` names an EXR's samples and compression.

use crate::common;
use cubeforge::internals::cube::{texel_dir, CubeMap};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, Decoded, ReadOptions};
use cubeforge::internals::layout::equirect;
use exr::meta::attribute::EnvironmentMap;
use exr::prelude::{Encoding, Layer, LayerAttributes, SpecificChannels, WritableImage};
use glam::Vec3;
use std::f32::consts::PI;
use std::path::Path;

/// Writes a `w` x `h` float RGB EXR declaring `map`, texel (x, y) holding (d + 1) / 2 for the
/// direction d = `dir(x, y)` (positive, so no reader clamps it).
fn write(
    path: &Path,
    w: usize,
    h: usize,
    map: EnvironmentMap,
    dir: impl Fn(usize, usize) -> Vec3 + Sync,
) {
    let attributes = LayerAttributes {
        environment_map: Some(map),
        ..LayerAttributes::default()
    };
    let channels = SpecificChannels::rgb(|p: exr::math::Vec2<usize>| {
        let c = (dir(p.0, p.1).normalize() + 1.0) * 0.5;
        (c.x, c.y, c.z)
    });
    let layer = Layer::new((w, h), attributes, Encoding::FAST_LOSSLESS, channels);
    exr::image::Image::from_layer(layer)
        .write()
        .to_file(path)
        .expect("writes the EXR");
}

/// OpenEXR's `LatLongMap::direction` of pixel (x, y) of a `w` x `h` map.
fn latlong_dir(x: usize, y: usize, w: usize, h: usize) -> Vec3 {
    let lat = -PI * (y as f32 / (h - 1) as f32 - 0.5);
    let lon = -2.0 * PI * (x as f32 / (w - 1) as f32 - 0.5);
    Vec3::new(lon.sin() * lat.cos(), lat.sin(), lon.cos() * lat.cos())
}

/// OpenEXR's direction of pixel (x, y) of a cube map of faces `sof` square: the face is the
/// row band, the position in the face undoes `CubeMap::pixelPosition`, and
/// `CubeMap::direction` turns it into a direction.
fn cube_dir(x: usize, y: usize, sof: usize) -> Vec3 {
    let (face, px, py) = (y / sof, x as f32, (y % sof) as f32);
    let last = (sof - 1) as f32;
    let (ix, iy) = match face {
        0 => (last - py, px),
        1 => (last - py, last - px),
        2 => (px, last - py),
        3 => (px, py),
        4 => (last - px, last - py),
        _ => (px, last - py),
    };
    let (a, b) = (ix / last * 2.0 - 1.0, iy / last * 2.0 - 1.0);
    match face {
        0 => Vec3::new(1.0, a, b),
        1 => Vec3::new(-1.0, a, b),
        2 => Vec3::new(a, 1.0, b),
        3 => Vec3::new(a, -1.0, b),
        4 => Vec3::new(a, b, 1.0),
        _ => Vec3::new(a, b, -1.0),
    }
}

/// The direction a texel holds.
fn held(p: glam::Vec4) -> Vec3 {
    (p.truncate() * 2.0 - 1.0).normalize()
}

/// The largest angle (degrees) between each texel's own direction and the one it holds.
fn worst_equirect(img: &Image) -> f32 {
    let mut worst = 0f32;
    for y in 0..img.height {
        for x in 0..img.width {
            let u = (x as f32 + 0.5) / img.width as f32;
            let v = (y as f32 + 0.5) / img.height as f32;
            let d = equirect::uv_to_dir(u, v);
            let got = held(img.pixels[y * img.width + x]);
            worst = worst.max(d.angle_between(got).to_degrees());
        }
    }
    worst
}

fn worst_cube(cube: &CubeMap) -> f32 {
    let n = cube.size();
    let mut worst = 0f32;
    for (face, img) in cube.levels[0].iter().enumerate() {
        for y in 0..n {
            for x in 0..n {
                let d = texel_dir(face, x, y, 1.0 / n as f32);
                worst = worst.max(d.angle_between(held(img.pixels[y * n + x])).to_degrees());
            }
        }
    }
    worst
}

fn read(path: &Path) -> (Decoded, io::Meta) {
    cubeforge::internals::convert::read(path, &ReadOptions::default()).expect("reads")
}

/// Reads an OpenEXR latlong file and returns the worst angle (degrees) and the texel size.
fn check_latlong(path: &Path) -> (f32, f32) {
    let (decoded, meta) = read(path);
    assert!(
        meta.declared.as_deref().unwrap_or("").contains("latlong"),
        "{meta:?}"
    );
    let Decoded::Image(img) = decoded else {
        panic!("a latlong map reads as a panorama");
    };
    assert_eq!(img.width, 2 * img.height);
    (worst_equirect(&img), 180.0 / img.height as f32)
}

fn check_cube(path: &Path) -> (f32, f32) {
    let (decoded, meta) = read(path);
    assert!(
        meta.declared.as_deref().unwrap_or("").contains("cube"),
        "{meta:?}"
    );
    let Decoded::Cube(cube) = decoded else {
        panic!("a cube envmap reads as a cube map");
    };
    // The angle of one texel at a face's centre.
    (
        worst_cube(&cube),
        (2.0 / cube.size() as f32).atan().to_degrees(),
    )
}

#[test]
fn openexr_envmaps_land_every_texel_at_its_direction() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h, sof) = (128, 64, 32);
    let ll = dir.path().join("latlong.exr");
    write(&ll, w, h, EnvironmentMap::LatitudeLongitude, |x, y| {
        latlong_dir(x, y, w, h)
    });
    let (worst, texel) = check_latlong(&ll);
    // Measured: 0.03 degrees (a texel is 2.81).
    println!("latlong: {worst:.2} degrees at worst, a texel {texel:.2}");
    assert!(worst <= 0.25 * texel, "{worst} > {texel} / 4");

    let cube = dir.path().join("cube.exr");
    write(&cube, sof, 6 * sof, EnvironmentMap::Cube, |x, y| {
        cube_dir(x, y, sof)
    });
    let (worst, texel) = check_cube(&cube);
    // Measured: 0.03 degrees (a texel is 3.58).
    println!("cube: {worst:.2} degrees at worst, a texel {texel:.2}");
    assert!(worst <= 0.25 * texel, "{worst} > {texel} / 4");

    // What info says.
    let o = common::run(["info".as_ref(), cube.as_os_str()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("declared by its envmap attribute: an OpenEXR cube map"),
        "{text}"
    );
    let o = common::run(["info".as_ref(), ll.as_os_str()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("layout:       equirect (declared by its envmap attribute"),
        "{text}"
    );

    // A file that says cube but holds no six faces: one line.
    let bad = dir.path().join("bad.exr");
    write(&bad, 8, 4, EnvironmentMap::Cube, |_, _| Vec3::Z);
    let o = common::run(["info".as_ref(), bad.as_os_str()]);
    assert!(!o.status.success());
    assert!(
        common::stderr(&o).contains("hold no six square faces"),
        "{}",
        common::stderr(&o)
    );
}

#[test]
fn exrenvmaps_own_files_land_every_texel_at_its_direction() {
    if !common::exrenvmap() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (w, h, sof) = (128, 64, 32);
    let ll = dir.path().join("latlong.exr");
    write(&ll, w, h, EnvironmentMap::LatitudeLongitude, |x, y| {
        latlong_dir(x, y, w, h)
    });
    let cube = dir.path().join("cube.exr");
    write(&cube, sof, 6 * sof, EnvironmentMap::Cube, |x, y| {
        cube_dir(x, y, sof)
    });
    let run = |args: &[&std::ffi::OsStr]| {
        let o = std::process::Command::new("exrenvmap")
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    // exrenvmap -c: OpenEXR resamples the latlong map into its cube layout, and the other way.
    let made_cube = dir.path().join("made_cube.exr");
    run(&[
        "-c".as_ref(),
        "-w".as_ref(),
        "32".as_ref(),
        ll.as_os_str(),
        made_cube.as_os_str(),
    ]);
    let (worst, texel) = check_cube(&made_cube);
    println!("exrenvmap -c: {worst:.2} degrees at worst, a texel {texel:.2}");
    // Measured: 0.06 degrees; exrenvmap's filter (radius 1, 5 x 5 samples) averages
    // directions around each texel's own, which keeps their mean.
    assert!(worst <= 0.25 * texel, "{worst} > {texel} / 4");
    let made_ll = dir.path().join("made_latlong.exr");
    run(&[
        "-l".as_ref(),
        "-w".as_ref(),
        "128".as_ref(),
        cube.as_os_str(),
        made_ll.as_os_str(),
    ]);
    let (worst, texel) = check_latlong(&made_ll);
    println!("exrenvmap -l: {worst:.2} degrees at worst, a texel {texel:.2}");
    assert!(worst <= 0.25 * texel, "{worst} > {texel} / 4");
}

/// exrenvmap's split faces (`-c` with `%` in the output name: `NAME+X.exr` ... `NAME-Z.exr`,
/// each face oriented as OpenEXR's cube and carrying no envmap attribute) read as a folder of
/// faces and as six files: every texel at its direction, and the warning names them and the
/// mirror a cubeforge panorama gets through `exrenvmap -li`.
#[test]
fn exrenvmaps_split_faces_read_as_a_cube() {
    if !common::exrenvmap() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (128, 64);
    let ll = dir.path().join("latlong.exr");
    write(&ll, w, h, EnvironmentMap::LatitudeLongitude, |x, y| {
        latlong_dir(x, y, w, h)
    });
    let faces = dir.path().join("faces");
    std::fs::create_dir(&faces).unwrap();
    let o = std::process::Command::new("exrenvmap")
        .args(["-c".as_ref(), "-w".as_ref(), "32".as_ref(), ll.as_os_str()])
        .arg(faces.join("sky_%.exr"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names = ["+X", "-X", "+Y", "-Y", "+Z", "-Z"].map(|a| faces.join(format!("sky_{a}.exr")));
    assert!(
        names.iter().all(|n| n.is_file()),
        "exrenvmap wrote its six faces"
    );
    let out = dir.path().join("cube.ktx2");
    for input in [vec![faces.clone()], names.to_vec()] {
        let mut args: Vec<std::ffi::OsString> = vec!["convert".into()];
        args.extend(input.iter().map(|p| p.clone().into_os_string()));
        args.extend([
            "-o".into(),
            out.clone().into_os_string(),
            "--gpu-format".into(),
        ]);
        args.push("rgba32f".into());
        let o = common::run(&args);
        assert!(o.status.success(), "{}", common::stderr(&o));
        if input.len() == 1 {
            let err = common::stderr(&o);
            assert!(
                err.contains("OpenEXR's split faces") && err.contains("--mirror"),
                "{err}"
            );
        }
        let Decoded::Cube(cube) = read(&out).0 else {
            panic!("a cube")
        };
        let texel = (2.0 / cube.size() as f32).atan().to_degrees();
        let worst = worst_cube(&cube);
        println!("exrenvmap's split faces: {worst:.2} degrees at worst, a texel {texel:.2}");
        assert!(worst <= 0.25 * texel, "{worst} > {texel} / 4");
    }
    // A folder with no faces lists every naming cubeforge reads.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    std::fs::write(empty.join("notes.txt"), b"no faces here").unwrap();
    let o = common::run(["info".as_ref(), empty.as_os_str()]);
    assert!(!o.status.success());
    let err = common::stderr(&o);
    assert!(
        err.contains("exrenvmap") && err.contains("posx") && err.contains("skybox"),
        "{err}"
    );
}

#[test]
fn info_names_exr_compressions_and_mixed_channel_types() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mixed.exr");
    let channels = SpecificChannels::rgb(|_: exr::math::Vec2<usize>| {
        (half::f16::from_f32(0.5), 0.25f32, 0.125f32)
    });
    let encoding = Encoding {
        compression: exr::prelude::Compression::DWAB(None),
        ..Encoding::FAST_LOSSLESS
    };
    let layer = Layer::new((64, 32), LayerAttributes::default(), encoding, channels);
    exr::image::Image::from_layer(layer)
        .write()
        .to_file(&path)
        .unwrap();
    let o = common::run(["info".as_ref(), path.as_os_str()]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("pixel format: R16F G32F B32F (DWAB, tiles 64x64)"),
        "{text}"
    );
    assert!(!text.contains("None"), "{text}");
    // And the article before a layout's name.
    let o = common::run([
        "info".as_ref(),
        path.as_os_str(),
        "--from".as_ref(),
        "angular".as_ref(),
    ]);
    assert!(
        common::stderr(&o).contains("cannot hold an angular layout"),
        "{}",
        common::stderr(&o)
    );
}
