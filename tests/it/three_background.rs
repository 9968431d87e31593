//! three.js draws `ibl --target three`'s panoramas as the scene's background, set up by the
//! printed snippet itself (run in headless Chromium, `tests/tools/three_background.cjs`): each of the
//! marker panorama's marks is where the snippet says, in its colour, and the sky between them
//! is the panorama's grey, not black (r187 drew the UASTC HDR background black through the
//! texture's mip-map filter until the snippet set `minFilter`).

use crate::common;
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;

const TOOL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/tools/three_background.cjs"
);

/// The marks in three.js's world (the panorama's centre at +Z, the viewer's right at -X), then
/// the grey sky behind the default camera's view.
fn looks() -> [(Vec3, Option<usize>); 4] {
    let (s, c) = 35f32.to_radians().sin_cos();
    [
        (Vec3::Z, Some(0)),
        (Vec3::new(-s, 0.0, c), Some(1)),
        (Vec3::new(0.0, s, c), Some(2)),
        (Vec3::NEG_Z, None),
    ]
}

/// What three.js draws as the background `snippet` sets (the files it names in `folder`),
/// along each of [`looks`]; None without the browser or three (a failure under CI, as those
/// helpers say).
fn drawn(snippet: &str, folder: &Path) -> Option<Vec<[f64; 3]>> {
    if !crate::view::browser() || common::three_js().is_none() {
        return None;
    }
    let dirs: Vec<String> = looks()
        .iter()
        .map(|(d, _)| format!("{},{},{}", d.x, d.y, d.z))
        .collect();
    let js = folder.with_extension("snippet.js");
    std::fs::write(&js, snippet).unwrap();
    let o = Command::new("node")
        .arg(TOOL)
        .arg(&js)
        .arg(folder)
        .args(&dirs)
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout} {}", common::stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert!(v.get("error").is_none(), "three.js: {v}");
    let looks = v["looks"].as_array().expect("looks").iter();
    Some(
        looks
            .map(|l| [0, 1, 2].map(|c| l[c].as_f64().unwrap()))
            .collect(),
    )
}

/// Each mark drawn in its own colour (that channel near white, the others at most half of it)
/// and the sky the panorama's grey (0.1 linear: about 89 in sRGB), never black.
fn assert_marks_drawn(what: &str, snippet: &str, folder: &Path) {
    let Some(drawn) = drawn(snippet, folder) else {
        return;
    };
    println!("three.js background of {what}: {drawn:?}");
    for ((dir, mark), rgb) in looks().iter().zip(&drawn) {
        match mark {
            Some(c) => {
                let others = (0..3)
                    .filter(|o| o != c)
                    .map(|o| rgb[o])
                    .fold(0.0, f64::max);
                assert!(
                    rgb[*c] > 200.0 && others < rgb[*c] / 2.0,
                    "{what}: along {dir} three.js draws {rgb:?}, not mark {c}"
                );
            }
            None => assert!(
                rgb.iter().all(|v| (60.0..120.0).contains(v)),
                "{what}: along {dir} three.js draws {rgb:?}, not the grey sky"
            ),
        }
    }
}

/// `ibl --target three` of the marker panorama (with `extra`), and its printed snippet.
fn three(dir: &Path, extra: &[&str]) -> (PathBuf, String) {
    let src = crate::ibl::marker_panorama(dir);
    let out = dir.join("three");
    let mut args = vec!["ibl", src.to_str().unwrap(), "-o", out.to_str().unwrap()];
    args.extend(["--target", "three"]);
    args.extend(extra);
    let o = common::run(&args);
    assert!(o.status.success(), "{}", common::stderr(&o));
    (out, String::from_utf8(o.stdout).unwrap())
}

/// The code of the snippet that begins with the line holding `first`, to the first line that
/// closes its loader call (`});` at the indent of that loader call).
fn code(snippet: &str, first: &str) -> String {
    let lines: Vec<&str> = snippet.lines().collect();
    let start = lines.iter().position(|l| l.contains(first)).expect(first);
    let end = start
        + lines[start..]
            .iter()
            .position(|l| l.trim_start().starts_with("}") && l.trim_end().ends_with("});"))
            .expect("the loader call's end");
    lines[start..=end].join("\n")
}

/// The UltraHDR panorama (`env.jpg`) as the snippet's UltraHDRLoader lines set it, and the
/// `.hdr` fallback with "the same lines" through HDRLoader.
#[test]
fn three_draws_the_ultrahdr_background_with_its_marks() {
    let dir = tempfile::tempdir().unwrap();
    let (out, printed) = three(dir.path(), &[]);
    let jpg = code(&printed, "import { UltraHDRLoader }");
    assert_marks_drawn("env.jpg", &jpg, &out);
    let hdr = jpg
        .replace("UltraHDRLoader", "HDRLoader")
        .replace("env.jpg", "env.hdr");
    assert_marks_drawn("env.hdr", &hdr, &out);
}

/// The UASTC HDR panorama (`env.ktx2`, its mips the panorama's own) as the snippet's
/// KTX2Loader lines set it: the background three.js drew black before they set `minFilter`.
#[cfg(feature = "uastc")]
#[test]
fn three_draws_the_uastc_background_with_its_marks() {
    let dir = tempfile::tempdir().unwrap();
    let (out, printed) = three(dir.path(), &["--gpu-format", "uastc-hdr-4x4"]);
    let ktx2 = code(&printed, "import { KTX2Loader }");
    assert_marks_drawn("env.ktx2", &ktx2, &out);
}
