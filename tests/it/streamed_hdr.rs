//! Issue 47: a Radiance .hdr read in bands (`io::bands`). Its bands hold the whole read's
//! texels bit for bit; hostile files (truncated, bad run lengths, a FIFO, an orientation the
//! reader does not take) give `info` and `ibl` on the streamed path one clear line naming
//! the file, never a panic or an output.

use crate::common;
use common::write_image;
use cubeforge::internals::convert;
use cubeforge::internals::io::{bands, Decoded};
use cubeforge::{Image, ReadOptions};
use glam::Vec4;
use std::path::Path;
use std::process::Command;

/// A 256 x 128 sky with a bright spot, as a run-length .hdr.
fn sky_hdr(path: &Path) {
    let (w, h) = (256, 128);
    let img = Image::from_fn(w, h, |x, y| {
        let v = 0.2 + (x as f32 * 0.37).sin().abs() + y as f32 / h as f32;
        let sun = if (x, y) == (w / 3, h / 4) { 5e3 } else { 0.0 };
        Vec4::new(v + sun, 0.5 * v, 0.25 * v, 1.0)
    });
    write_image(path, &img);
}

/// The bands, on 1 and 3 threads and in bands of 1 and 32 rows, are the whole read's texels.
#[test]
fn hdr_bands_are_the_whole_reads_texels() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.hdr");
    sky_hdr(&path);
    let opts = ReadOptions::default();
    let Decoded::Image(whole) = convert::read_raw(&path, &opts).expect("reads").0 else {
        panic!("one image");
    };
    let shape = bands::shape(&path, &opts).unwrap().expect("offered");
    assert_eq!(
        (shape.width, shape.height, shape.block_lines),
        (256, 128, 1)
    );
    for (threads, lines) in [(1, 32), (3, 1), (3, 32)] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let texels = pool.install(|| {
            bands::with_bands(&path, &opts, |b| {
                assert_eq!(b.size(), (256, 128));
                let (got, replaced) = b.map(&path, lines, &|_| true, &|_, rows| rows.to_vec())?;
                assert_eq!(replaced, 0);
                Ok(got.into_iter().flatten().flatten().collect::<Vec<Vec4>>())
            })
            .unwrap()
            .expect("offered")
        });
        assert!(
            texels == whole.pixels,
            "{threads} threads, bands of {lines}"
        );
    }
}

/// `cubeforge ARGS` with the streamed path forced on any size.
fn streamed(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(args)
        .env("CUBEFORGE_STREAM_TEXELS", "0")
        .output()
        .unwrap()
}

/// One line naming the file, a failure status, no panic, nothing written.
fn one_clear_line(out: &std::process::Output, file: &Path, what: &str, out_dir: &Path) {
    let err = common::stderr(out);
    assert!(!out.status.success(), "{what}: succeeded");
    assert!(!err.contains("panicked"), "{what}: {err}");
    assert_eq!(err.trim().lines().count(), 1, "{what}: {err}");
    let name = file.file_name().unwrap().to_str().unwrap();
    assert!(err.contains(name), "{what}: {err}");
    assert!(!out_dir.exists(), "{what}: wrote {}", out_dir.display());
}

#[test]
fn hostile_hdr_on_the_streamed_path_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.hdr");
    sky_hdr(&good);
    let bytes = std::fs::read(&good).unwrap();
    let pixels = bytes.windows(2).position(|p| p == b"\n-").unwrap();
    let header_end = pixels
        + bytes[pixels + 1..]
            .iter()
            .position(|&b| b == b'\n')
            .unwrap()
        + 2;
    let mut cases: Vec<(&str, Vec<u8>)> = vec![
        ("truncated.hdr", bytes[..bytes.len() * 2 / 3].to_vec()),
        ("header_only.hdr", bytes[..header_end].to_vec()),
    ];
    // A run length past the line's end in the middle scanline's first channel.
    let mut bad = bytes.clone();
    let mid = header_end + (bytes.len() - header_end) / 2;
    let key = [2u8, 2, 1, 0];
    let at = mid + bytes[mid..].windows(4).position(|k| k == key).unwrap();
    bad[at + 4] = 255;
    cases.push(("bad_rle.hdr", bad));
    // Flipped rows: the reader takes only -Y +X.
    let text = String::from_utf8_lossy(&bytes[..header_end]).replace("-Y 128", "+Y 128");
    let mut flipped = text.into_bytes();
    flipped.extend_from_slice(&bytes[header_end..]);
    cases.push(("flipped.hdr", flipped));
    for (name, data) in &cases {
        let path = dir.path().join(name);
        std::fs::write(&path, data).unwrap();
        let p = path.to_str().unwrap();
        let out_dir = dir.path().join(format!("{name}.out"));
        let info = streamed(&["info", p, "--json"]);
        one_clear_line(&info, &path, &format!("info {name}"), &out_dir);
        let o = out_dir.to_str().unwrap();
        let ibl = streamed(&["ibl", p, "--target", "bevy", "-o", o]);
        one_clear_line(&ibl, &path, &format!("ibl {name}"), &out_dir);
    }
    // A FIFO is left to the whole read, which refuses it without blocking.
    let fifo = dir.path().join("pipe.hdr");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let out_dir = dir.path().join("pipe.out");
        let info = streamed(&["info", fifo.to_str().unwrap()]);
        one_clear_line(&info, &fifo, "info fifo", &out_dir);
        assert!(bands::shape(&fifo, &ReadOptions::default())
            .unwrap()
            .is_none());
    }
}
