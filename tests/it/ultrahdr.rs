//! UltraHDR (gain-map JPEG): `convert --ultrahdr` and `ibl --target three` written, read back
//! by cubeforge and by three.js's own `UltraHDRLoader` in headless Chromium
//! (`tests/tools/three_uhdr.cjs`): light kept, the sun's range, size, and the chiral marks
//! where three.js's equirect mapping puts them.

use crate::common::{self, read_image, run, stderr};
use cubeforge::internals::image::Image;
use glam::{Vec3, Vec4};
use std::path::{Path, PathBuf};
use std::process::Command;

pub(crate) const THREE_TOOL: &str =
    concat!(env!("CARGO_MANIFEST_DIR"), "/tests/tools/three_uhdr.cjs");

fn ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `cubeforge convert IN -o OUT --to equirect EXTRA...`, its run.
fn to_equirect(input: &Path, output: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "convert",
        input.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
        "--to",
        "equirect",
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// [`to_equirect`], which must succeed; its standard output.
fn to_equirect_ok(input: &Path, output: &Path, extra: &[&str]) -> String {
    let o = to_equirect(input, output, extra);
    assert!(o.status.success(), "{}: {}", input.display(), stderr(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Each channel's mean radiance over the sphere of an equirect (rows weighed by solid angle).
fn sphere_mean(img: &Image) -> [f64; 3] {
    let (w, h) = (img.width, img.height);
    let (mut sum, mut weight) = ([0.0f64; 3], 0.0);
    for y in 0..h {
        let s = ((y as f64 + 0.5) / h as f64 * std::f64::consts::PI).sin();
        for x in 0..w {
            let p = img.pixels[y * w + x];
            for c in 0..3 {
                sum[c] += s * p[c] as f64;
            }
            weight += s;
        }
    }
    sum.map(|v| v / weight)
}

/// The largest relative difference of the channels' means.
fn flux_off(a: &Image, b: &Image) -> f64 {
    let (a, b) = (sphere_mean(a), sphere_mean(b));
    (0..3)
        .map(|c| (a[c] / b[c] - 1.0).abs())
        .fold(0.0, f64::max)
}

/// The files as three.js's loaders hold them (UltraHDRLoader for .jpg, HDRLoader for .hdr), rows
/// top first; None (after a SKIPPED line, or a failure under CI) without Chromium and three.
fn three_reads(files: &[&Path]) -> Option<Vec<Image>> {
    if !crate::view::browser() || common::three_js().is_none() {
        return None;
    }
    let out = tempfile::tempdir().unwrap();
    let o = Command::new("node")
        .arg(THREE_TOOL)
        .arg(out.path())
        .args(files)
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "three_uhdr.cjs: {stdout} {}",
        stderr(&o)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), files.len(), "three_uhdr.cjs printed {stdout}");
    let images = lines
        .iter()
        .enumerate()
        .map(|(i, line)| {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            assert!(
                v.get("error").is_none(),
                "three.js read {}: {v}",
                files[i].display()
            );
            let (w, h) = (
                v["width"].as_u64().unwrap() as usize,
                v["height"].as_u64().unwrap() as usize,
            );
            let bytes = std::fs::read(out.path().join(format!("{i}.f32"))).unwrap();
            let f: Vec<f32> = bytes
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
                .collect();
            assert_eq!(f.len(), w * h * 4);
            Image::from_fn(w, h, |x, y| {
                let i = (y * w + x) * 4;
                Vec4::new(f[i], f[i + 1], f[i + 2], 1.0)
            })
        })
        .collect();
    Some(images)
}

/// A dim panorama with a sun: 20 texels at 2^13 to 2^15 over a sky near 1.
fn sunny_panorama(dir: &Path) -> PathBuf {
    let img = Image::from_fn(256, 128, |x, y| {
        let sky = Vec4::new(0.4 + y as f32 / 256.0, 0.6, 0.9, 1.0);
        let (dx, dy) = (x as f32 - 80.5, y as f32 - 30.5);
        let r2 = dx * dx + dy * dy;
        if r2 < 6.0 {
            let k = (15.0 - r2 / 3.0).exp2();
            Vec4::new(k, k * 0.9, k * 0.6, 1.0)
        } else {
            sky * (1.0 + (x % 7) as f32 / 7.0)
        }
    });
    let path = dir.join("sunny.exr");
    std::fs::write(
        &path,
        cubeforge::internals::output::encode_image(&path, &img, &Default::default()).unwrap(),
    )
    .unwrap();
    path
}

#[test]
fn ultrahdr_round_trips_through_info_and_convert_with_its_sun() {
    let dir = tempfile::tempdir().unwrap();
    let src = sunny_panorama(dir.path());
    let jpg = dir.path().join("sunny.jpg");
    let out = to_equirect_ok(&src, &jpg, &["--ultrahdr"]);
    assert!(out.contains("UltraHDR: gains"), "{out}");
    let info = ok(&["info", jpg.to_str().unwrap()]);
    assert!(
        info.contains("UltraHDR JPEG") && info.contains("gain map"),
        "{info}"
    );
    let (a, b) = (read_image(&jpg), read_image(&src));
    let off = flux_off(&a, &b);
    // The sun holds most of the light in 17 texels, each a code or two of an 8-bit gain map
    // that spans 16 stops (4.5% a code): the real panoramas' suns keep theirs within 2%.
    println!("UltraHDR round trip: light within {:.2}%", off * 100.0);
    assert!(off < 0.03, "light off by {:.2}%", off * 100.0);
    let top = |i: &Image| i.pixels.iter().map(|p| p.x).fold(0.0, f32::max);
    assert!(
        top(&a) > 0.5 * top(&b),
        "the sun: {} of {}",
        top(&a),
        top(&b)
    );
    // Back through convert to an EXR: the radiance, not the SDR picture.
    let exr = dir.path().join("back.exr");
    to_equirect_ok(&jpg, &exr, &[]);
    // (half floats round the sun by a part in 2000)
    assert!((flux_off(&read_image(&exr), &b) - off).abs() < 0.002);
    // A plain JPEG of the same panorama still reads as an 8-bit picture.
    let plain = dir.path().join("plain.jpg");
    to_equirect_ok(&src, &plain, &["--tonemap", "aces"]);
    let info = ok(&["info", plain.to_str().unwrap()]);
    assert!(info.contains("format:       JPEG"), "{info}");
}

#[test]
fn ultrahdr_is_refused_for_other_outputs_and_cut_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let src = sunny_panorama(dir.path());
    let o = run([
        "convert",
        src.to_str().unwrap(),
        "-o",
        dir.path().join("x.png").to_str().unwrap(),
        "--ultrahdr",
    ]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("--ultrahdr writes JPEG files"),
        "{}",
        stderr(&o)
    );
    let jpg = dir.path().join("sunny.jpg");
    to_equirect_ok(&src, &jpg, &["--ultrahdr"]);
    let bytes = std::fs::read(&jpg).unwrap();
    // Cut inside the gain map: one line naming the file, no output.
    let cut = dir.path().join("cut.jpg");
    std::fs::write(&cut, &bytes[..bytes.len() - bytes.len() / 8]).unwrap();
    let back = dir.path().join("cut.exr");
    let o = to_equirect(&cut, &back, &[]);
    let err = stderr(&o);
    assert!(!o.status.success(), "a cut UltraHDR file read: {err}");
    assert!(err.contains("cut.jpg") && err.lines().count() == 1, "{err}");
    assert!(!back.exists());
}

/// The real panoramas (../shared/fixtures/real/hdr, with suns up to 30000): `convert
/// --ultrahdr` at their own size keeps the light within 2% as cubeforge reads it and is under
/// an eighth of the `.hdr`; `ibl --target three` is read by three.js within 2%, its JPEG under
/// an eighth of the `.hdr` beside it.
#[test]
fn real_panoramas_keep_their_light_in_ultrahdr_and_in_three() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut threes = vec![];
    let mut ratios_seen = Vec::new();
    let mut table = vec![
        "| panorama | UltraHDR | of the `.hdr` | light as cubeforge reads it back, within |"
            .to_string(),
        "| --- | --- | --- | --- |".to_string(),
    ];
    for name in ["esplanade", "park", "studio", "venice"] {
        let src = real.join(format!("hdr/{name}.hdr"));
        let jpg = dir.path().join(format!("{name}.jpg"));
        let said = to_equirect_ok(&src, &jpg, &["--ultrahdr"]);
        if name == "esplanade" {
            // The line docs/formats.md shows.
            let line = said
                .lines()
                .find(|l| l.starts_with("UltraHDR: gains"))
                .expect("convert says what it kept");
            let text = format!("```text\n{line}\n```");
            crate::figures::check("docs/formats.md", "ultrahdr esplanade", &text);
        }
        let (size, hdr) = (
            std::fs::metadata(&jpg).unwrap().len(),
            std::fs::metadata(&src).unwrap().len(),
        );
        let off = flux_off(&read_image(&jpg), &read_image(&src));
        println!(
            "{name}: UltraHDR {size} bytes (1/{:.1} of the .hdr), light within {:.2}%",
            hdr as f64 / size as f64,
            off * 100.0
        );
        ratios_seen.push(hdr as f64 / size as f64);
        table.push(format!(
            "| {name} | {size} bytes | 1/{:.1} | {:.2}% |",
            hdr as f64 / size as f64,
            off * 100.0
        ));
        assert!(
            off < 0.02 && size * 8 < hdr,
            "{name}: {:.2}%, {size} of {hdr} bytes",
            off * 100.0
        );
        let out = dir.path().join(name);
        crate::ibl::ibl(&src, &out, "three", &[]);
        threes.push((name, src, out));
    }
    crate::figures::check("docs/formats.md", "ultrahdr real", &table.join("\n"));
    let (least, most) = ratios_seen
        .iter()
        .fold((f64::MAX, 0f64), |(a, b), &r| (a.min(r), b.max(r)));
    let text = format!("in 1/{least:.1} to 1/{most:.1} of the bytes of the `.hdr`");
    crate::figures::check("README.md", "ultrahdr bytes", &text);
    // What a reader of the format's own arithmetic (Android, Chrome, libultrahdr below its
    // clamp) gets from the three.js-fitted env.jpg: the same file with its mark blanked (same
    // length, so the MPF offsets hold), read by cubeforge the format's way.
    let mut standard = Vec::new();
    for (name, src, out) in &threes {
        let mut bytes = std::fs::read(out.join("env.jpg")).unwrap();
        let mark = cubeforge::internals::io::ultrahdr::THREE_MARK;
        let at = bytes
            .windows(mark.len())
            .position(|w| w == mark)
            .expect("env.jpg carries the three.js mark");
        bytes[at..at + mark.len()].fill(b'-');
        let plain = dir.path().join(format!("{name}_plain.jpg"));
        std::fs::write(&plain, bytes).unwrap();
        let off = flux_off(&read_image(&plain), &read_image(src));
        standard.push(format!("{:.1}% ({name})", off * 100.0));
    }
    let text = format!(
        "read by the format's own arithmetic, its light is off by {}",
        standard.join(", ")
    );
    crate::figures::check("docs/formats.md", "three fitted standard", &text);
    let files: Vec<PathBuf> = threes
        .iter()
        .flat_map(|(_, _, o)| [o.join("env.jpg"), o.join("env.hdr")])
        .collect();
    let refs: Vec<&Path> = files.iter().map(|p| p.as_path()).collect();
    let Some(read) = three_reads(&refs) else {
        return;
    };
    let (mut within, mut ratios) = (Vec::new(), Vec::new());
    for (i, (name, src, out)) in threes.iter().enumerate() {
        let (jpg, hdr) = (&read[2 * i], &read[2 * i + 1]);
        let source = read_image(src);
        let (off, off_hdr) = (flux_off(jpg, &source), flux_off(hdr, &source));
        let (a, b) = (
            std::fs::metadata(out.join("env.jpg")).unwrap().len(),
            std::fs::metadata(out.join("env.hdr")).unwrap().len(),
        );
        println!("{name}: three.js reads env.jpg within {:.2}% (env.hdr {:.2}%), {a} bytes, 1/{:.1} of env.hdr", off * 100.0, off_hdr * 100.0, b as f64 / a as f64);
        assert!(
            off < 0.02 && off_hdr < 0.02,
            "{name}: {:.2}% / {:.2}%",
            off * 100.0,
            off_hdr * 100.0
        );
        assert!(a * 8 < b, "{name}: {a} of {b} bytes");
        within.push(format!("{:.2}% ({name})", off * 100.0));
        ratios.push(format!("1/{:.1}", b as f64 / a as f64));
        assert_eq!(
            jpg.width, 1024,
            "{name}: PMREM's faces are a quarter of the width, a power of two"
        );
    }
    let text = format!(
        "three.js reads `env.jpg`'s light within {} of the source, and `env.jpg` is {} of \
         `env.hdr`",
        within.join(", "),
        ratios.join(", ")
    );
    crate::figures::check("docs/engines.md", "three ultrahdr", &text);
}

/// The marks of `tests/it/ibl`'s panorama (red at +Z, green 35 degrees right of it, blue 35
/// degrees above) land, through three.js's own loaders and its `equirectUv` (u = 0.5 +
/// atan2(z, x) / 2pi, v = 0.5 + asin(y) / pi, the top row at v = 1), at those directions of
/// three.js's right-handed Y-up world.
#[test]
fn three_sees_the_marks_where_they_belong() {
    let dir = tempfile::tempdir().unwrap();
    let src = crate::ibl::marker_panorama(dir.path());
    let out = dir.path().join("three");
    let said = ok(&[
        "ibl",
        src.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--target",
        "three",
    ]);
    assert!(
        said.contains("UltraHDRLoader") && said.contains("scene.environment"),
        "{said}"
    );
    // `view` takes the folder: the UltraHDR panorama, as it is.
    let page = dir.path().join("page");
    let shown = ok(&["view", out.to_str().unwrap(), "-o", page.to_str().unwrap()]);
    assert!(
        shown.contains("showing") && shown.contains("env.jpg"),
        "{shown}"
    );
    let Some(read) = three_reads(&[&out.join("env.jpg"), &out.join("env.hdr")]) else {
        return;
    };
    for (img, what) in read.iter().zip(["env.jpg", "env.hdr"]) {
        let marks = marks_three_sees(img, true, what);
        crate::ibl::assert_unmirrored(&format!("three.js {what}"), marks, true, Vec3::Z);
    }
}

/// Where three.js's equirect mapping (`equirectUv`) puts the marker panorama's three marks
/// (red, green, blue), from a texture's rows as three.js holds them: with `flip_y` (images)
/// row 0 is uploaded to the top, v = 1; without (compressed textures) to the bottom, v = 0.
pub(crate) fn marks_three_sees(img: &Image, flip_y: bool, what: &str) -> [Vec3; 3] {
    let (w, h) = (img.width, img.height);
    let mut sums = [Vec3::ZERO; 3];
    for y in 0..h {
        for x in 0..w {
            let p = img.pixels[y * w + x];
            let u = (x as f32 + 0.5) / w as f32;
            let row = (y as f32 + 0.5) / h as f32;
            let v = if flip_y { 1.0 - row } else { row };
            let phi = (u - 0.5) * std::f32::consts::TAU;
            let theta = (v - 0.5) * std::f32::consts::PI;
            let d = Vec3::new(
                theta.cos() * phi.cos(),
                theta.sin(),
                theta.cos() * phi.sin(),
            );
            for (c, sum) in sums.iter_mut().enumerate() {
                let others = (0..3).filter(|&o| o != c).map(|o| p[o]).fold(0.0, f32::max);
                if p[c] > 5.0 && p[c] > 4.0 * others {
                    *sum += d;
                }
            }
        }
    }
    sums.map(|s| {
        assert!(s.length() > 0.0, "{what}: a mark is missing");
        s.normalize()
    })
}

/// A gain map larger than its picture, or metadata with no finite range, is refused in one
/// line naming the file, before any radiance is made.
#[test]
fn ultrahdr_with_a_bad_gain_map_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut meta = ultrahdr_rs::GainMapMetadata::default();
    meta.gain_map_max = [4.0; 3];
    meta.alternate_hdr_headroom = 4.0;
    let big =
        ultrahdr_rs::encode_ultrahdr(&jpeg(16), &jpeg(32), &meta, ultrahdr_rs::ColorGamut::Bt709)
            .unwrap();
    meta.gain_map_max = [f64::NAN; 3];
    let nan =
        ultrahdr_rs::encode_ultrahdr(&jpeg(16), &jpeg(16), &meta, ultrahdr_rs::ColorGamut::Bt709)
            .unwrap();
    for (name, bytes, says) in [
        ("big.jpg", big, "larger than its picture"),
        ("nan.jpg", nan, "not finite"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let o = run(["info", path.to_str().unwrap()]);
        let err = stderr(&o);
        assert!(
            !o.status.success(),
            "{name} read: {}",
            String::from_utf8_lossy(&o.stdout)
        );
        assert!(
            err.contains(name) && err.contains(says) && err.lines().count() == 1,
            "{err}"
        );
    }
}

/// An n x n JPEG of mid grey: a picture or gain map to build UltraHDR files from.
pub(crate) fn jpeg(n: u32) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 90)
        .write_image(
            &vec![128u8; (n * n * 3) as usize],
            n,
            n,
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
    out
}
