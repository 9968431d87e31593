//! The campaign loop, the front door of image files, the budget and the sources' helpers.

use crate::images::png_fix_crcs;
use crate::mutator::{Field, Mutator};
use crate::LARGEST;
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{Decoded, FileFormat, Limits, ReadOptions, WriteOptions};
use glam::{Vec3, Vec4};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// The budget every mutated file is read with: a million pixels, 64 MiB.
pub fn limits() -> Limits {
    Limits {
        max_pixels: 1 << 20,
        max_dimension: 1 << 14,
        max_memory: 64 << 20,
        ..Limits::default()
    }
}

pub fn scale() -> usize {
    std::env::var("HOSTILE_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1)
}

pub fn verbose() -> bool {
    std::env::var_os("HOSTILE_VERBOSE").is_some()
}

/// What one source's campaign found.
#[derive(Default)]
pub struct Tally {
    read: usize,
    refused: usize,
    /// Refusals where a decoder panicked and cubeforge caught it ("corrupt data (...)").
    caught: usize,
    slowest: Duration,
    slowest_round: usize,
}

impl Tally {
    pub fn report(&self, what: &str) {
        println!(
            "{what}: {} read, {} refused ({} caught panics); slowest mutation {} took {:.1} ms",
            self.read,
            self.refused,
            self.caught,
            self.slowest_round,
            self.slowest.as_secs_f64() * 1e3
        );
    }
}

/// Checks one outcome of a front door: Ok (None), or an error of one line naming `name` (its
/// message). A panic fails the test, naming the mutation.
/// `text`: the file is text, which a message may quote (an unknown key holding a newline):
/// the command line puts such a message on one line (`cli::run`), so it may span several here.
pub fn check(
    outcome: std::thread::Result<cubeforge::Result<()>>,
    name: &str,
    text: bool,
    what: &dyn Fn() -> String,
) -> Option<String> {
    match outcome {
        Ok(Ok(())) => None,
        Ok(Err(e)) => {
            let e = e.to_string();
            assert!(
                e.contains(name),
                "{}: the error does not name {name}: {e}",
                what()
            );
            assert!(
                text || !e.contains('\n'),
                "{}: a message of several lines: {e}",
                what()
            );
            if verbose() {
                println!("{}: {e}", what());
            }
            Some(e)
        }
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            panic!("{}: panicked: {msg}", what())
        }
    }
}

/// Runs `rounds` (times `HOSTILE_ROUNDS`) mutations of `src` through `door`, which gets each
/// mutated file's bytes.
pub fn campaign(
    what: &str,
    src: &[u8],
    mut mutator: Mutator,
    rounds: usize,
    name: &str,
    door: &dyn Fn(&[u8]) -> cubeforge::Result<()>,
) -> Tally {
    let mut tally = Tally::default();
    for round in 0..rounds * scale() {
        let b = mutator.mutate(src);
        let start = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| door(&b)));
        let took = start.elapsed();
        if took > tally.slowest {
            tally.slowest = took;
            tally.slowest_round = round;
            if let Some(dir) = std::env::var_os("HOSTILE_KEEP") {
                let name: String = what
                    .chars()
                    .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                    .collect();
                std::fs::write(Path::new(&dir).join(format!("slowest-{name}")), &b).unwrap();
            }
        }
        let text = mutator.text;
        match check(outcome, name, text, &|| format!("{what}, mutation {round}")) {
            None => tally.read += 1,
            Some(e) => {
                tally.refused += 1;
                if e.contains("corrupt data (") {
                    tally.caught += 1;
                    println!("{what}, mutation {round}: a caught panic: {e}");
                }
            }
        }
    }
    tally.report(what);
    tally
}

/// The front door of image files: written to `dir/name`, then `io::read` with [`limits`]
/// (and, for containers, `info::describe`, which also reads their metadata and counts bad
/// values in every level).
pub fn image_door(dir: &Path, name: &str) -> impl Fn(&[u8]) -> cubeforge::Result<()> {
    let path = dir.join(name);
    move |bytes| {
        std::fs::write(&path, bytes).unwrap();
        let opts = ReadOptions {
            limits: limits(),
            linear: false,
            as_stored: false,
            ..Default::default()
        };
        let (decoded, _) = cubeforge::internals::convert::read(&path, &opts)?;
        match decoded {
            Decoded::Image(img) => assert_eq!(img.pixels.len(), img.width * img.height),
            Decoded::Cube(cube) => {
                for level in &cube.levels {
                    for f in level {
                        assert_eq!(f.pixels.len(), f.width * f.height);
                    }
                }
            }
        }
        if matches!(
            FileFormat::from_extension(&path),
            Some(FileFormat::Ktx2 | FileFormat::Dds | FileFormat::Ktx1 | FileFormat::Env)
        ) {
            cubeforge::internals::info::describe(&path, None, &opts)?;
        }
        Ok(())
    }
}

/// A small image with structure in every channel.
pub fn test_image(w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let (x, y) = (x as f32, y as f32);
        Vec4::new(
            (x * 0.37).sin() * 0.5 + 0.5,
            (y * 0.21).cos() * 0.5 + 0.5,
            ((x + y) * 0.05).fract() * 4.0,
            0.25 + ((x * y) * 0.01).fract() * 0.75,
        )
    })
}

pub fn encoded(name: &str, img: &Image, opts: &WriteOptions) -> Vec<u8> {
    cubeforge::internals::output::encode_image(Path::new(name), img, opts).unwrap()
}

pub fn test_cube(size: usize) -> CubeMap {
    CubeMap::from_fn(size, |d: Vec3| {
        Vec4::new(d.x.abs() * 3.0, d.y * 0.5 + 0.5, d.z.abs(), 1.0)
    })
    .with_box_mips(None)
}

pub fn be16(b: &[u8], at: usize) -> usize {
    u16::from_be_bytes([b[at], b[at + 1]]) as usize
}

pub fn real_files(sub: &str, ext: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/fixtures/real")
        .join(sub);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} not found", dir.display());
        return Vec::new();
    };
    with_extension(entries, ext)
}

/// Files of extension `ext` in the folder `HOSTILE_EXTRA` names, if any: other programs'
/// files (progressive JPEG, Adam7 PNG, colour-mapped TGA) for a long campaign by hand.
pub fn extra_files(ext: &str) -> Vec<PathBuf> {
    let Some(dir) = std::env::var_os("HOSTILE_EXTRA") else {
        return Vec::new();
    };
    with_extension(std::fs::read_dir(dir).unwrap(), ext)
}

/// A folder's files of extension `ext`, sorted.
fn with_extension(entries: std::fs::ReadDir, ext: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    files
}

/// Runs a campaign over each source (name, bytes, fields) of one format, the valid file read
/// first (it must decode), then over any `HOSTILE_EXTRA` files (which need not).
pub fn formats(
    sources: Vec<(String, Vec<u8>, Vec<Field>)>,
    ext: &str,
    seed: u64,
    rounds: usize,
    fields_of: fn(&[u8]) -> Vec<Field>,
) {
    formats_with(sources, ext, seed, rounds, fields_of, &|m, _| m);
}

/// [`formats`], each source's mutator tuned by `tune` (given the source's bytes) as well.
pub fn formats_with(
    mut sources: Vec<(String, Vec<u8>, Vec<Field>)>,
    ext: &str,
    seed: u64,
    rounds: usize,
    fields_of: fn(&[u8]) -> Vec<Field>,
    tune: &dyn Fn(Mutator, &[u8]) -> Mutator,
) {
    let extra = extra_files(ext).into_iter().map(|path| {
        let b = std::fs::read(&path).unwrap();
        let fields = fields_of(&b);
        (format!("extra {}", path.display()), b, fields)
    });
    sources.extend(extra);
    let dir = tempfile::tempdir().unwrap();
    let name = format!("mutated.{ext}");
    let door = image_door(dir.path(), &name);
    for (i, (what, bytes, fields)) in sources.into_iter().enumerate() {
        if !what.starts_with("extra ") {
            door(&bytes).unwrap_or_else(|e| panic!("{what}: the valid file: {e}"));
        }
        // The real fixtures are larger and slower to read: a fifth as many by default.
        let rounds = if what.contains("fixtures/real") {
            rounds / 5
        } else {
            rounds
        };
        let mut mutator = Mutator::new(seed.wrapping_add(0x9e37_79b9 * i as u64), fields, false);
        if ext == "png" {
            mutator = mutator.fixed_by(png_fix_crcs);
        }
        let mutator = tune(mutator, &bytes);
        campaign(&what, &bytes, mutator, rounds, &name, &door);
    }
    println!(
        "largest single allocation so far, by any test here: {} MiB",
        LARGEST.load(Ordering::Relaxed) >> 20
    );
}
