//! Every bad input ends with exactly one clear line on stderr naming the file and the problem,
//! a non-zero exit, no panic, and nothing left in the output folder (no partial file, no
//! temporary `.*.tmp`). Bad values (NaN, Inf, negative) are not errors: they are replaced by 0
//! with a warning, and `info` counts them.

use crate::common;

use common::{read_image, run, stderr, write_image};
use cubeforge::internals::cube::FACE_NAMES;
use cubeforge::internals::image::Image;
use cubeforge::internals::layout::{cross, Projection};
use cubeforge::internals::resample::{FnEnv, Resampler};
use cubeforge::internals::synthetic::smooth;
use glam::Vec4;
use std::path::{Path, PathBuf};
use std::process::Output;
use tempfile::TempDir;

/// A temporary folder with an empty `out/` for outputs.
struct Scratch {
    dir: TempDir,
}

impl Scratch {
    fn new() -> Scratch {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::create_dir(dir.path().join("out")).unwrap();
        Scratch { dir }
    }
    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
    fn out(&self, name: &str) -> PathBuf {
        self.dir.path().join("out").join(name)
    }
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
    /// Asserts the output folder is still empty.
    fn assert_no_output(&self) {
        let left = listing(&self.path("out"));
        assert!(left.is_empty(), "files left in the output folder: {left:?}");
    }
}

/// Names in a folder, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

fn equirect(w: usize, h: usize) -> Image {
    Resampler::default().to_projection(&FnEnv(smooth), Projection::Equirect, w, h)
}

fn faces(n: usize) -> [Image; 6] {
    let cube = Resampler::default().to_cube(&FnEnv(smooth), n);
    cube.levels.into_iter().next().unwrap()
}

fn encode(name: &str, img: &Image) -> Vec<u8> {
    cubeforge::internals::output::encode_image(Path::new(name), img, &Default::default()).unwrap()
}

/// Failed cleanly: non-zero exit (not a panic's 101), and stderr is exactly one line, starting
/// "cubeforge: error:", naming `name`.
#[track_caller]
fn assert_one_error_line(out: &Output, name: &str) -> String {
    let err = stderr(out);
    assert!(!out.status.success(), "expected failure, stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert_ne!(out.status.code(), Some(101), "panic exit code: {err}");
    let text = err.trim();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "expected exactly one line on stderr, got: {err}"
    );
    assert!(
        lines[0].starts_with("cubeforge: error:"),
        "not an error line: {err}"
    );
    assert!(lines[0].contains(name), "error does not name {name}: {err}");
    println!("{}", lines[0]);
    lines[0].to_string()
}

/// Runs `convert <input> -o out/<output> <extra>` and checks the one-line failure naming
/// `name`, with nothing written. Returns the error line.
#[track_caller]
fn convert_fails(s: &Scratch, input: &Path, output: &str, extra: &[&str], name: &str) -> String {
    let mut args = vec![
        "convert".to_string(),
        input.display().to_string(),
        "-o".into(),
        s.out(output).display().to_string(),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    let out = run(&args);
    let line = assert_one_error_line(&out, name);
    s.assert_no_output();
    line
}

// ---- unreadable inputs ----

#[test]
fn truncated_png() {
    let s = Scratch::new();
    let bytes = encode("a.png", &equirect(64, 32));
    let p = s.write("trunc.png", &bytes[..bytes.len() / 2]);
    convert_fails(&s, &p, "o.exr", &[], "trunc.png");
}

#[test]
fn truncated_hdr() {
    let s = Scratch::new();
    let bytes = encode("a.hdr", &equirect(64, 32));
    let p = s.write("trunc.hdr", &bytes[..bytes.len() / 2]);
    let line = convert_fails(&s, &p, "o.exr", &[], "trunc.hdr");
    assert!(line.contains("truncated or malformed"), "{line}");
}

#[test]
fn truncated_exr() {
    let s = Scratch::new();
    let bytes = encode("a.exr", &equirect(64, 32));
    let p = s.write("trunc.exr", &bytes[..bytes.len() / 2]);
    convert_fails(&s, &p, "o.exr", &[], "trunc.exr");
}

#[test]
fn empty_file() {
    let s = Scratch::new();
    let p = s.write("empty.png", b"");
    let line = convert_fails(&s, &p, "o.exr", &[], "empty.png");
    assert!(line.contains("empty"), "{line}");
}

#[test]
fn text_named_png() {
    let s = Scratch::new();
    let p = s.write("notes.png", b"this is not a picture\n");
    let line = convert_fails(&s, &p, "o.exr", &[], "notes.png");
    assert!(line.contains("PNG"), "{line}");
}

#[test]
fn png_named_exr() {
    let s = Scratch::new();
    let p = s.write("really_png.exr", &encode("a.png", &equirect(64, 32)));
    let line = convert_fails(&s, &p, "o.png", &[], "really_png.exr");
    assert!(line.contains("PNG") && line.contains("OpenEXR"), "{line}");
}

#[test]
fn garbage_named_hdr() {
    let s = Scratch::new();
    // Deterministic noise (xorshift), not starting with any signature.
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let bytes: Vec<u8> = (0..4096)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect();
    let p = s.write("noise.hdr", &bytes);
    convert_fails(&s, &p, "o.exr", &[], "noise.hdr");
}

#[test]
fn missing_input() {
    let s = Scratch::new();
    let p = s.path("nowhere.png");
    convert_fails(&s, &p, "o.exr", &[], "nowhere.png");
}

// ---- size limits ----

/// CRC-32 (ISO-HDLC, as PNG uses), bit by bit.
fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A PNG signature and a valid IHDR chunk claiming `w` x `h` RGB8, and nothing else.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut chunk = b"IHDR".to_vec();
    chunk.extend_from_slice(&w.to_be_bytes());
    chunk.extend_from_slice(&h.to_be_bytes());
    chunk.extend_from_slice(&[8, 2, 0, 0, 0]); // 8 bits, RGB, deflate, adaptive, no interlace
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend_from_slice(&13u32.to_be_bytes());
    png.extend_from_slice(&chunk);
    png.extend_from_slice(&crc32(&chunk).to_be_bytes());
    png
}

#[test]
fn crc32_check_value() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
}

#[test]
fn hostile_png_refused_by_size_limit() {
    let s = Scratch::new();
    let p = s.write("huge.png", &png_header_only(200_000, 100_000));
    let line = convert_fails(&s, &p, "o.exr", &[], "huge.png");
    assert!(
        line.contains("200000x100000") && line.contains("limit"),
        "not refused by the size limit: {line}"
    );
    let out = run(["info".as_ref(), p.as_os_str()]);
    let line = assert_one_error_line(&out, "huge.png");
    assert!(line.contains("limit"), "{line}");
}

#[test]
fn max_pixels_refuses_normal_image() {
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    let line = convert_fails(&s, &p, "o.exr", &["--max-pixels", "1000"], "pano.png");
    assert!(line.contains("--max-pixels"), "{line}");
}

// ---- faces ----

fn write_faces(dir: &Path, faces: &[Image; 6], ext: &str) {
    std::fs::create_dir_all(dir).unwrap();
    for (f, name) in faces.iter().zip(FACE_NAMES) {
        write_image(&dir.join(format!("{name}.{ext}")), f);
    }
}

#[test]
fn faces_folder_missing_one() {
    let s = Scratch::new();
    let dir = s.path("cube_faces");
    write_faces(&dir, &faces(16), "png");
    std::fs::remove_file(dir.join("nz.png")).unwrap();
    let line = convert_fails(&s, &dir, "o.png", &[], "cube_faces");
    assert!(line.contains("nz"), "{line}");
}

#[test]
fn faces_of_different_sizes() {
    let s = Scratch::new();
    let dir = s.path("mixed");
    write_faces(&dir, &faces(16), "png");
    write_image(&dir.join("py.png"), &faces(8)[2]);
    convert_fails(&s, &dir, "o.png", &[], "py.png");
}

#[test]
fn non_square_face() {
    let s = Scratch::new();
    let dir = s.path("oblong");
    write_faces(&dir, &faces(16), "png");
    write_image(&dir.join("px.png"), &equirect(32, 16));
    let line = convert_fails(&s, &dir, "o.png", &[], "px.png");
    assert!(line.contains("square"), "{line}");
}

// ---- layouts ----

#[test]
fn aspect_ratio_no_layout_has() {
    let s = Scratch::new();
    let p = s.write("odd.png", &encode("a.png", &equirect(30, 20)));
    let line = convert_fails(&s, &p, "o.png", &[], "odd.png");
    assert!(line.contains("30x20"), "{line}");
}

#[test]
fn square_without_from() {
    let s = Scratch::new();
    let p = s.write("ball.png", &encode("a.png", &equirect(32, 32)));
    let line = convert_fails(&s, &p, "o.png", &["--to", "equirect"], "ball.png");
    assert!(
        line.contains("--from sphere")
            && line.contains("angular")
            && line.contains("--from octahedral"),
        "{line}"
    );
}

#[test]
fn from_hcross_on_2_to_1() {
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    let line = convert_fails(&s, &p, "o.png", &["--from", "hcross"], "pano.png");
    assert!(line.contains("hcross"), "{line}");
}

#[test]
fn unknown_output_extension() {
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    convert_fails(&s, &p, "o.xyz", &[], "o.xyz");
    convert_fails(&s, &p, "o.xyz", &["--to", "hcross"], "o.xyz");
}

#[test]
fn ktx2_with_png_name() {
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    let line = convert_fails(&s, &p, "o.png", &["--to", "ktx2"], "o.png");
    assert!(line.contains(".ktx2"), "{line}");
}

// ---- never overwrite an input ----

#[test]
fn output_over_input_refused() {
    let s = Scratch::new();
    let cross = cross::assemble(cross::Cells::Hcross, &faces(16));
    let p = s.write("cross.png", &encode("a.png", &cross));
    let before = std::fs::read(&p).unwrap();
    let out = run([
        "convert".as_ref(),
        p.as_os_str(),
        "-o".as_ref(),
        p.as_os_str(),
        "--to".as_ref(),
        "hcross".as_ref(),
    ]);
    assert_one_error_line(&out, "cross.png");
    assert_eq!(std::fs::read(&p).unwrap(), before, "input changed");
    assert_eq!(listing(s.dir.path()), ["cross.png", "out"], "stray files");
}

#[test]
fn faces_output_into_input_folder_refused() {
    let s = Scratch::new();
    let dir = s.path("cube");
    write_faces(&dir, &faces(16), "png");
    let before: Vec<Vec<u8>> = FACE_NAMES
        .iter()
        .map(|n| std::fs::read(dir.join(format!("{n}.png"))).unwrap())
        .collect();
    let names = listing(&dir);
    let out = run([
        "convert".as_ref(),
        dir.as_os_str(),
        "-o".as_ref(),
        dir.as_os_str(),
        "--to".as_ref(),
        "faces".as_ref(),
        "--format".as_ref(),
        "png".as_ref(),
    ]);
    assert_one_error_line(&out, "cube");
    assert_eq!(listing(&dir), names, "files added or removed");
    for (n, b) in FACE_NAMES.iter().zip(&before) {
        assert_eq!(
            &std::fs::read(dir.join(format!("{n}.png"))).unwrap(),
            b,
            "{n} changed"
        );
    }
}

// ---- info ----

#[test]
fn info_on_broken_file() {
    let s = Scratch::new();
    let bytes = encode("a.exr", &equirect(64, 32));
    let p = s.write("broken.exr", &bytes[..bytes.len() / 3]);
    for json in [false, true] {
        let mut args = vec!["info".as_ref(), p.as_os_str()];
        if json {
            args.push("--json".as_ref());
        }
        let out = run(&args);
        assert_one_error_line(&out, "broken.exr");
        assert!(out.stdout.is_empty(), "stdout: {:?}", out.stdout);
    }
}

// ---- bad values are repaired, not refused ----

/// A 64x32 panorama with NaN in R at (3, 5), +Inf in G at (10, 7), -0.25 in B at (20, 9) and
/// -Inf in R at (40, 20).
fn bad_values_image() -> (Image, [(usize, usize, usize); 4]) {
    let mut img = equirect(64, 32);
    let bad = [(3, 5, 0), (10, 7, 1), (20, 9, 2), (40, 20, 0)];
    let vals = [f32::NAN, f32::INFINITY, -0.25, f32::NEG_INFINITY];
    for (&(x, y, c), v) in bad.iter().zip(vals) {
        let mut p: Vec4 = img.get(x, y);
        p[c] = v;
        img.set(x, y, p);
    }
    (img, bad)
}

/// An f32 EXR holding the image's values as they are (NaN and Inf included), written by the
/// exr crate: cubeforge's own encoder never writes them.
fn raw_exr(path: &Path, img: &Image) -> PathBuf {
    exr::prelude::write_rgba_file(path, img.width, img.height, |x, y| {
        let p = img.get(x, y);
        (p.x, p.y, p.z, p.w)
    })
    .unwrap();
    path.to_path_buf()
}

#[test]
fn bad_values_replaced_with_warning() {
    let s = Scratch::new();
    let (img, bad) = bad_values_image();
    let p = raw_exr(&s.path("bad.exr"), &img);
    let o = s.out("fixed.exr");
    let out = run([
        "convert".as_ref(),
        p.as_os_str(),
        "-o".as_ref(),
        o.as_os_str(),
        "--to".as_ref(),
        "equirect".as_ref(),
    ]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let lines: Vec<&str> = err.trim().lines().collect();
    assert_eq!(lines.len(), 1, "expected one warning line: {err}");
    assert!(
        lines[0].starts_with("cubeforge: warning:")
            && lines[0].contains("bad.exr")
            && lines[0].contains("replaced 4 "),
        "{err}"
    );
    let fixed = read_image(&o);
    assert_eq!((fixed.width, fixed.height), (64, 32));
    for p in &fixed.pixels {
        assert!(
            p.is_finite() && p.min_element() >= 0.0,
            "bad value left: {p}"
        );
    }
    // Same size: each output texel is its input texel, so the repaired channels read 0.
    for (x, y, c) in bad {
        let v = fixed.get(x, y)[c];
        assert!(v.abs() < 1e-3, "({x}, {y}) channel {c} is {v}, not 0");
    }
    assert_eq!(listing(&s.path("out")), ["fixed.exr"], "stray files");
}

#[test]
fn info_counts_bad_values() {
    let s = Scratch::new();
    let (img, _) = bad_values_image();
    let p = raw_exr(&s.path("bad.exr"), &img);
    let out = run(["info".as_ref(), p.as_os_str(), "--json".as_ref()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(v["stats"]["nan"], 1, "{v}");
    assert_eq!(v["stats"]["inf"], 2, "{v}");
    assert_eq!(v["stats"]["negative"], 1, "{v}");
    let text = run(["info".as_ref(), p.as_os_str()]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("1 NaN, 2 Inf, 1 negative"));
}

// ---- output problems ----

#[test]
fn output_folder_missing() {
    // A missing output folder is created (the README's first command relies on it) ...
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    let o = s.out("no/such/dir/o.png");
    let out = run([
        "convert".as_ref(),
        p.as_os_str(),
        "-o".as_ref(),
        o.as_os_str(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(o.is_file());
    // ... but one that cannot be (a file stands in its way) is one clear error, nothing written.
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    let o = p.join("sub/o.png");
    let out = run([
        "convert".as_ref(),
        p.as_os_str(),
        "-o".as_ref(),
        o.as_os_str(),
    ]);
    assert_one_error_line(&out, "o.png");
    s.assert_no_output();
}

/// A face whose name is taken by a folder: the other five must not land either.
#[test]
fn faces_output_all_or_nothing() {
    let s = Scratch::new();
    let p = s.write("pano.png", &encode("a.png", &equirect(64, 32)));
    let dir = s.out("faces");
    std::fs::create_dir_all(dir.join("nz.png")).unwrap();
    let out = run([
        "convert".as_ref(),
        p.as_os_str(),
        "-o".as_ref(),
        dir.as_os_str(),
        "--to".as_ref(),
        "faces".as_ref(),
    ]);
    assert_one_error_line(&out, "nz.png");
    assert_eq!(listing(&dir), ["nz.png"], "partial output left");
}

/// A small EXR whose dataWindow attribute is patched to claim 200000 x 100000.
fn exr_claiming_huge() -> Vec<u8> {
    let mut bytes = encode("a.exr", &equirect(64, 32));
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|w| w == key)
        .expect("dataWindow attribute")
        + key.len()
        + 4; // attribute size
    for (i, v) in [0i32, 0, 199_999, 99_999].into_iter().enumerate() {
        bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    bytes
}

#[test]
fn hostile_exr_and_hdr_refused_by_size_limit() {
    let s = Scratch::new();
    let exr = s.write("huge.exr", &exr_claiming_huge());
    let hdr = s.write(
        "huge.hdr",
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 200000\n\x02\x02\x00\x00",
    );
    for (p, name) in [(&exr, "huge.exr"), (&hdr, "huge.hdr")] {
        let line = convert_fails(&s, p, "o.exr", &[], name);
        assert!(
            line.contains("200000x100000") && line.contains("limit"),
            "not refused by the size limit: {line}"
        );
    }
}
