//! `cubeforge ibl --target`: each engine's files, their levels and roughness mapping, light
//! kept, and orientation checked with a chiral marker through each engine's own lookup.
//!
//! This module holds the marker panorama, the readers and the `ibl` runner every part uses;
//! the tests are split by topic below it.

mod command_line;
mod engines;
mod one_target;
mod readers;
mod snippets;
pub(crate) mod sun;

use crate::common::{self, run, stderr};
use cubeforge::internals::chain::LevelsFile;
use cubeforge::internals::cube::{face_dir, CubeMap};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, Decoded, ReadOptions};
use glam::{Vec3, Vec4};
use std::path::{Path, PathBuf};

/// A dim panorama with three marks: red straight ahead (+Z, the panorama's centre), green 35
/// degrees to its right (towards +X) and blue 35 degrees above it. A mirrored copy puts green
/// on the left; a turned one moves red.
pub(crate) fn marker_panorama(dir: &Path) -> PathBuf {
    let (w, h) = (256, 128);
    let marks = [
        (Vec3::Z, Vec4::new(40.0, 0.0, 0.0, 1.0)),
        (
            Vec3::new(35f32.to_radians().sin(), 0.0, 35f32.to_radians().cos()),
            Vec4::new(0.0, 40.0, 0.0, 1.0),
        ),
        (
            Vec3::new(0.0, 35f32.to_radians().sin(), 35f32.to_radians().cos()),
            Vec4::new(0.0, 0.0, 40.0, 1.0),
        ),
    ];
    let img = Image::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32;
        let v = (y as f32 + 0.5) / h as f32;
        let lon = (u - 0.5) * std::f32::consts::TAU;
        let lat = (0.5 - v) * std::f32::consts::PI;
        let d = Vec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
        let mut c = Vec4::new(0.1, 0.1, 0.1, 1.0);
        for (m, col) in marks {
            if d.dot(m) > 8f32.to_radians().cos() {
                c += col;
            }
        }
        c.w = 1.0;
        c
    });
    let path = dir.join("marks.exr");
    common::write_image(&path, &img);
    path
}

fn read_cube(path: &Path) -> CubeMap {
    let opts = ReadOptions {
        as_stored: true,
        ..ReadOptions::default()
    };
    match cubeforge::internals::convert::read(path, &opts) {
        Ok((Decoded::Cube(c), _)) => c,
        Ok(_) => panic!("{} holds no cube map", path.display()),
        Err(e) => panic!("{e}"),
    }
}

fn levels_of(path: &Path) -> LevelsFile {
    let bytes = std::fs::read(path).unwrap();
    let meta = io::ktx2::metadata(&bytes);
    let json = meta
        .iter()
        .find(|(k, _)| k == io::ktx2::LEVELS_KEY)
        .map(|(_, v)| v.clone())
        .expect("levels metadata");
    serde_json::from_slice(&json).unwrap()
}

/// Where each mark lands in the engine's world: the mean world direction of the texels of
/// level 0 where its colour dominates, with `world_of(d)` the world direction whose lookup
/// reads cube direction d.
fn marks_in_world(cube: &CubeMap, world_of: impl Fn(Vec3) -> Vec3) -> [Vec3; 3] {
    let n = cube.size();
    let mut sums = [Vec3::ZERO; 3];
    for (f, face) in cube.levels[0].iter().enumerate() {
        for y in 0..n {
            for x in 0..n {
                let p = face.pixels[y * n + x];
                let d = face_dir(f, (x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32)
                    .normalize();
                for (c, sum) in sums.iter_mut().enumerate() {
                    let others = (0..3).filter(|&o| o != c).map(|o| p[o]).fold(0.0, f32::max);
                    if p[c] > 5.0 && p[c] > 4.0 * others {
                        *sum += world_of(d);
                    }
                }
            }
        }
    }
    sums.map(|s| {
        assert!(s.length() > 0.0, "a mark is missing");
        s.normalize()
    })
}

/// Asserts the marks read un-mirrored for a viewer in a right- or left-handed Y-up world,
/// with the centre mark at `ahead`.
pub(crate) fn assert_unmirrored(engine: &str, marks: [Vec3; 3], right_handed: bool, ahead: Vec3) {
    let [red, green, blue] = marks;
    assert!(
        red.dot(ahead) > 0.99,
        "{engine}: centre at {red}, expected {ahead}"
    );
    let right = if right_handed {
        red.cross(Vec3::Y)
    } else {
        Vec3::Y.cross(red)
    };
    assert!(
        green.dot(right) > 0.45,
        "{engine}: the right-hand mark is at {green}, the viewer's right is {right}: mirrored"
    );
    assert!(
        blue.dot(Vec3::Y) > 0.45,
        "{engine}: the upper mark is at {blue}"
    );
}

pub(crate) fn ibl(input: &Path, out: &Path, target: &str, extra: &[&str]) {
    let mut args = vec![
        "ibl",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--target",
        target,
        "-q",
    ];
    // The chains' descriptions in their metadata, which `levels_of` reads.
    if matches!(target, "bevy" | "gltf" | "generic") {
        args.push("--cubeforge-keys");
    }
    args.extend_from_slice(extra);
    let o = run(&args);
    assert!(o.status.success(), "{target}: {}", stderr(&o));
}

const SMALL: [&str; 8] = [
    "--size",
    "32",
    "--min-size",
    "4",
    "--diffuse-size",
    "8",
    "--samples",
    "16",
];

const BABYLON: [&str; 8] = [
    "--size",
    "32",
    "--min-size",
    "1",
    "--diffuse-size",
    "8",
    "--samples",
    "16",
];
