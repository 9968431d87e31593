//! Hostile files at every front door: seeded mutations (bit flips, overwritten bytes, header
//! fields set to extreme values, numbers in text made huge, spans cut, repeated or inserted,
//! truncation) of small valid files that cubeforge's own encoders make here, and of the real
//! fixtures (../shared/fixtures/real, skipped when absent), read through `cubeforge::io::read`
//! with a small budget. Each must read or fail with a one-line error naming the file: never a
//! panic, an abort, or an allocation beyond the budget. The text front doors (control recipes,
//! material files, a control map's sidecar, a DDS chain's levels.json) get the same.
//!
//! The same seeds give the same files on every run. `HOSTILE_ROUNDS=n` runs n times as many
//! mutations (a long campaign), `HOSTILE_EXTRA=DIR` adds the files in DIR to it (say, progressive
//! JPEGs from another program; never commit them), `HOSTILE_KEEP=DIR` writes each source's
//! slowest mutation there, `HOSTILE_VERBOSE=1` prints every refusal, and every source prints its slowest mutation (for finding slow inputs by hand; no
//! test here depends on time).

#[path = "common/mod.rs"]
mod common;

use common::XorShift;
use cubeforge::control::{self, Size, Syntax};
use cubeforge::cube::CubeMap;
use cubeforge::image::Image;
use cubeforge::io::{self, Decoded, FileFormat, GpuFormat, Limits, ReadOptions, WriteOptions};
use glam::{Vec3, Vec4};
use std::alloc::{GlobalAlloc, Layout, System};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Single allocations over this are refused, which aborts the test binary (a failure that
/// cannot go unnoticed) instead of taking the machine's memory: with [`limits`] no reader
/// needs a tenth of it, so one that asks has trusted a size it should have checked.
const ALLOC_CAP: usize = 1 << 30;

/// The largest single allocation any test here made.
static LARGEST: AtomicUsize = AtomicUsize::new(0);

struct Capped;

impl Capped {
    fn admit(size: usize) -> bool {
        LARGEST.fetch_max(size, Ordering::Relaxed);
        if size > ALLOC_CAP {
            // No formatting (it could allocate): the size in hex, written by hand.
            let mut msg = *b"hostile_inputs: refused an allocation of 0x0000000000000000 bytes\n";
            let at = msg.iter().position(|&c| c == b'x').unwrap() + 1;
            for i in 0..16 {
                msg[at + i] = b"0123456789abcdef"[(size >> (60 - 4 * i)) & 15];
            }
            use std::io::Write;
            let _ = std::io::stderr().write_all(&msg);
            return false;
        }
        true
    }
}

// SAFETY: every call is passed on to the system allocator unchanged, or refused with null.
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !Self::admit(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !Self::admit(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if !Self::admit(new_size) {
            return std::ptr::null_mut();
        }
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static ALLOCATOR: Capped = Capped;

/// The budget every mutated file is read with: a million pixels, 64 MiB.
fn limits() -> Limits {
    Limits {
        max_pixels: 1 << 20,
        max_dimension: 1 << 14,
        max_memory: 64 << 20,
    }
}

fn scale() -> usize {
    std::env::var("HOSTILE_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1)
}

fn verbose() -> bool {
    std::env::var_os("HOSTILE_VERBOSE").is_some()
}

/// A header field the mutator may set to an extreme value: where, how many bytes (1, 2, 4 or
/// 8) and whether big-endian.
#[derive(Clone, Copy, Debug)]
struct Field {
    at: usize,
    len: usize,
    be: bool,
}

impl Field {
    fn le(at: usize, len: usize) -> Field {
        Field { at, len, be: false }
    }
    fn be(at: usize, len: usize) -> Field {
        Field { at, len, be: true }
    }
    fn get(&self, b: &[u8]) -> u64 {
        let mut v = 0u64;
        for i in 0..self.len {
            let byte = *b.get(self.at + i).unwrap_or(&0) as u64;
            v |= if self.be {
                byte << (8 * (self.len - 1 - i))
            } else {
                byte << (8 * i)
            };
        }
        v
    }
    fn set(&self, b: &mut [u8], v: u64) {
        for i in 0..self.len {
            let shift = if self.be {
                8 * (self.len - 1 - i)
            } else {
                8 * i
            };
            if let Some(byte) = b.get_mut(self.at + i) {
                *byte = (v >> shift) as u8;
            }
        }
    }
}

/// Values a size or count field is set to: the edges of its width, powers of two, and a
/// little off the true value.
fn extreme(rng: &mut XorShift, bits: u32, original: u64) -> u64 {
    let max = if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    let v = match rng.below(14) {
        0 => 0,
        1 => 1,
        2 => max,
        3 => max >> 1,
        4 => (max >> 1) + 1,
        5 => original.wrapping_add(1),
        6 => original.wrapping_sub(1),
        7 => original.wrapping_mul(2),
        8 => original << 8,
        9 => 1 << rng.below(bits as usize),
        10 => [16384, 16385, 65535, 65536, 46341, 32768][rng.below(6)],
        11 => original.wrapping_add(rng.below(64) as u64),
        12 => original / 2,
        _ => rng.next(),
    };
    v & max
}

/// Numbers a digit run in text becomes.
const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1e309",
    "-1e309",
    "nan",
    "inf",
    "-0.0",
    "1e-45",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999999999",
    "2147483647",
    "65537",
    "16384",
    "1e38",
    "0x7fffffff",
    "3.4028236e38",
    "0.5",
];

/// Makes mutated copies of one valid file.
struct Mutator {
    rng: XorShift,
    fields: Vec<Field>,
    /// Treat the file as text: also cut, repeat and nest lines and brackets.
    text: bool,
    /// Run on half the mutated files, to get past checksums (PNG's CRCs).
    fix: Option<fn(&mut [u8])>,
}

impl Mutator {
    fn new(seed: u64, fields: Vec<Field>, text: bool) -> Mutator {
        Mutator {
            rng: XorShift(seed | 1),
            fields,
            text,
            fix: None,
        }
    }

    fn fixed_by(mut self, fix: fn(&mut [u8])) -> Mutator {
        self.fix = Some(fix);
        self
    }

    /// A place to change: mostly in the first 512 bytes, where the headers are.
    fn place(&mut self, len: usize) -> usize {
        let span = if self.rng.below(4) == 0 {
            len
        } else {
            len.min(512)
        };
        self.rng.below(span)
    }

    fn mutate(&mut self, src: &[u8]) -> Vec<u8> {
        let mut b = src.to_vec();
        // Text breaks sooner: fewer changes get further into its parser.
        let changes = 1 + self.rng.below(if self.text { 2 } else { 4 });
        for _ in 0..changes {
            if b.is_empty() {
                b.push(0);
            }
            let at = self.place(b.len());
            match self.rng.below(if self.text { 14 } else { 10 }) {
                0 => b[at] ^= 1 << self.rng.below(8),
                1 => b[at] = self.rng.next() as u8,
                2 => b[at] = *self.rng.pick(&[0, 0xff, 0x7f, 0x80]),
                3 | 4 if !self.fields.is_empty() => {
                    let f = *self.rng.pick(&self.fields);
                    let v = extreme(&mut self.rng, 8 * f.len as u32, f.get(&b));
                    f.set(&mut b, v);
                }
                3..=5 => {
                    let len = *self.rng.pick(&[2, 4, 8]);
                    let f = Field {
                        at,
                        len,
                        be: self.rng.below(2) == 0,
                    };
                    let v = extreme(&mut self.rng, 8 * len as u32, f.get(&b));
                    f.set(&mut b, v);
                }
                6 => {
                    // Cut a span.
                    let n = (1 + self.rng.below(64)).min(b.len() - at);
                    b.drain(at..at + n);
                }
                7 => {
                    // Repeat a span (a chunk or a segment twice).
                    let n = (1 + self.rng.below(256)).min(b.len() - at);
                    let span = b[at..at + n].to_vec();
                    let to = self.place(b.len());
                    b.splice(to..to, span);
                }
                8 => {
                    let n = 1 + self.rng.below(16);
                    let junk: Vec<u8> = (0..n).map(|_| self.rng.next() as u8).collect();
                    b.splice(at..at, junk);
                }
                9 => self.number(&mut b, at),
                10 => self.number(&mut b, at),
                11 => {
                    // Cut or repeat a line.
                    let start = b[..at]
                        .iter()
                        .rposition(|&c| c == b'\n')
                        .map_or(0, |i| i + 1);
                    let end = b[at..]
                        .iter()
                        .position(|&c| c == b'\n')
                        .map_or(b.len(), |i| at + i + 1);
                    if self.rng.below(2) == 0 {
                        b.drain(start..end);
                    } else {
                        let line = b[start..end].to_vec();
                        b.splice(start..start, line);
                    }
                }
                12 => {
                    // Deep nesting: arrays or tables within each other.
                    let depth = *self.rng.pick(&[64, 200, 1000, 20_000]);
                    let (open, close): (&[u8], &[u8]) = match self.rng.below(3) {
                        0 => (b"[", b"]"),
                        1 => (b"{a=", b"}"),
                        _ => (b"{\"a\":", b"}"),
                    };
                    let mut s = Vec::new();
                    for _ in 0..depth {
                        s.extend_from_slice(open);
                    }
                    s.push(b'1');
                    if self.rng.below(2) == 0 {
                        for _ in 0..depth {
                            s.extend_from_slice(close);
                        }
                    }
                    b.splice(at..at, s);
                }
                _ => {
                    // A quote, bracket or separator where it does not belong.
                    let c = *self.rng.pick(b"\"'[]{}=,.\n#\\");
                    b.insert(at, c);
                }
            }
        }
        if self.rng.below(12) == 0 && !b.is_empty() {
            let keep = self.rng.below(b.len());
            b.truncate(keep);
        }
        if let Some(fix) = self.fix.filter(|_| self.rng.below(2) == 0) {
            fix(&mut b);
        }
        b
    }

    /// Replaces the digit run at or after `at` with an extreme number.
    fn number(&mut self, b: &mut Vec<u8>, at: usize) {
        let Some(start) = b[at..].iter().position(u8::is_ascii_digit).map(|i| at + i) else {
            return;
        };
        let end = b[start..]
            .iter()
            .position(|c| !(c.is_ascii_digit() || *c == b'.'))
            .map_or(b.len(), |i| start + i);
        let n = self.rng.pick(NUMBERS).as_bytes().to_vec();
        b.splice(start..end, n);
    }
}

/// What one source's campaign found.
#[derive(Default)]
struct Tally {
    read: usize,
    refused: usize,
    /// Refusals where a decoder panicked and cubeforge caught it ("corrupt data (...)").
    caught: usize,
    slowest: Duration,
    slowest_round: usize,
}

impl Tally {
    fn report(&self, what: &str) {
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
fn check(
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
fn campaign(
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
/// (and, for containers, `info::describe`, which also reads their metadata).
fn image_door(dir: &Path, name: &str) -> impl Fn(&[u8]) -> cubeforge::Result<()> {
    let path = dir.join(name);
    move |bytes| {
        std::fs::write(&path, bytes).unwrap();
        let opts = ReadOptions {
            limits: limits(),
            linear: false,
            as_stored: false,
        };
        let (decoded, _) = io::read(&path, &opts)?;
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
            Some(FileFormat::Ktx2 | FileFormat::Dds)
        ) {
            cubeforge::info::describe(&path, None, &opts)?;
        }
        Ok(())
    }
}

/// A small image with structure in every channel.
fn test_image(w: usize, h: usize) -> Image {
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

fn encoded(name: &str, img: &Image, opts: &WriteOptions) -> Vec<u8> {
    io::encode_image(Path::new(name), img, opts).unwrap()
}

fn test_cube(size: usize) -> CubeMap {
    CubeMap::from_fn(size, |d: Vec3| {
        Vec4::new(d.x.abs() * 3.0, d.y * 0.5 + 0.5, d.z.abs(), 1.0)
    })
    .with_box_mips(None)
}

fn be16(b: &[u8], at: usize) -> usize {
    u16::from_be_bytes([b[at], b[at + 1]]) as usize
}

/// PNG: IHDR's fields and every chunk's length.
fn png_fields(b: &[u8]) -> Vec<Field> {
    let mut f = vec![Field::be(24, 1), Field::be(25, 1), Field::be(28, 1)];
    let mut at = 8;
    while at + 8 <= b.len() {
        f.push(Field::be(at, 4));
        let len = u32::from_be_bytes(b[at..at + 4].try_into().unwrap()) as usize;
        if &b[at + 4..at + 8] == b"IHDR" {
            f.extend([Field::be(at + 8, 4), Field::be(at + 12, 4)]);
        }
        at += 12 + len;
    }
    f
}

/// Rewrites every PNG chunk's CRC that lies inside the file, so a mutation reaches the
/// decoder behind the checksum.
fn png_fix_crcs(b: &mut [u8]) {
    let mut at = 8;
    while at + 8 <= b.len() {
        let len = u32::from_be_bytes(b[at..at + 4].try_into().unwrap()) as usize;
        let Some(end) = (at + 8).checked_add(len).filter(|&e| e + 4 <= b.len()) else {
            return;
        };
        let crc = libdeflater::crc32(&b[at + 4..end]);
        b[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        at = end + 4;
    }
}

/// JPEG: every segment's length, the frame's sizes, component counts and sampling factors,
/// the restart interval and the scans' spectral selection and approximation.
fn jpeg_fields(b: &[u8]) -> Vec<Field> {
    let mut f = Vec::new();
    let mut at = 2;
    while at + 4 <= b.len() && b[at] == 0xff {
        let marker = b[at + 1];
        let len = be16(b, at + 2);
        f.push(Field::be(at + 2, 2));
        let body = at + 4;
        match marker {
            0xc0..=0xc2 => {
                f.extend([
                    Field::be(body, 1),
                    Field::be(body + 1, 2),
                    Field::be(body + 3, 2),
                    Field::be(body + 5, 1),
                ]);
                for c in 0..b[body + 5] as usize {
                    f.extend([
                        Field::be(body + 6 + 3 * c + 1, 1),
                        Field::be(body + 6 + 3 * c + 2, 1),
                    ]);
                }
            }
            0xdd => f.push(Field::be(body, 2)),
            0xda => {
                let n = b[body] as usize;
                f.push(Field::be(body, 1));
                for c in 0..n {
                    f.push(Field::be(body + 1 + 2 * c + 1, 1));
                }
                f.extend([
                    Field::be(body + 1 + 2 * n, 1),
                    Field::be(body + 2 + 2 * n, 1),
                    Field::be(body + 3 + 2 * n, 1),
                ]);
                break;
            }
            _ => {}
        }
        at += 2 + len;
    }
    f
}

/// TGA: every field of the 18-byte header.
fn tga_fields() -> Vec<Field> {
    let mut f: Vec<Field> = [0, 1, 2, 7, 16, 17].map(|at| Field::le(at, 1)).to_vec();
    f.extend([3, 5, 8, 10, 12, 14].map(|at| Field::le(at, 2)));
    f
}

/// Radiance HDR: the first scanline's header (its numbers in text are changed as text).
fn hdr_fields(b: &[u8]) -> Vec<Field> {
    let Some(line) = b.windows(4).position(|w| w == b"\n-Y ") else {
        return Vec::new();
    };
    let start = line + 1 + b[line + 1..].iter().position(|&c| c == b'\n').unwrap() + 1;
    vec![
        Field::be(start, 2),
        Field::be(start + 2, 2),
        Field::be(start, 4),
    ]
}

/// KTX2: the header's words, the index's, the level index, the first descriptor words and the
/// first key/value length.
fn ktx2_fields(b: &[u8]) -> Vec<Field> {
    let mut f: Vec<Field> = (0..13).map(|i| Field::le(12 + 4 * i, 4)).collect();
    f.extend([Field::le(64, 8), Field::le(72, 8)]);
    let levels = u32::from_le_bytes(b[40..44].try_into().unwrap()).max(1) as usize;
    for l in 0..levels {
        f.extend((0..3).map(|i| Field::le(80 + 24 * l + 8 * i, 8)));
    }
    let dfd = u32::from_le_bytes(b[48..52].try_into().unwrap()) as usize;
    f.extend((0..8).map(|i| Field::le(dfd + 4 * i, 4)));
    let kvd = u32::from_le_bytes(b[56..60].try_into().unwrap()) as usize;
    f.push(Field::le(kvd, 4));
    f
}

/// DDS: every word of the header and of the DX10 header.
fn dds_fields() -> Vec<Field> {
    (1..37).map(|i| Field::le(4 * i, 4)).collect()
}

fn real_files(sub: &str, ext: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/fixtures/real")
        .join(sub);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} not found", dir.display());
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    files
}

/// Files of extension `ext` in the folder `HOSTILE_EXTRA` names, if any: other programs'
/// files (progressive JPEG, Adam7 PNG, colour-mapped TGA) for a long campaign by hand.
fn extra_files(ext: &str) -> Vec<PathBuf> {
    let Some(dir) = std::env::var_os("HOSTILE_EXTRA") else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    files
}

/// Runs a campaign over each source (name, bytes, fields) of one format, the valid file read
/// first (it must decode), then over any `HOSTILE_EXTRA` files (which need not).
fn formats(
    mut sources: Vec<(String, Vec<u8>, Vec<Field>)>,
    ext: &str,
    seed: u64,
    rounds: usize,
    fields_of: fn(&[u8]) -> Vec<Field>,
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
        campaign(&what, &bytes, mutator, rounds, &name, &door);
    }
    println!(
        "largest single allocation so far, by any test here: {} MiB",
        LARGEST.load(Ordering::Relaxed) >> 20
    );
}

#[test]
fn png_mutations() {
    let img = test_image(40, 24);
    let mut sources = Vec::new();
    for (what, opts) in [
        ("PNG 8-bit", WriteOptions::default()),
        (
            "PNG 16-bit",
            WriteOptions {
                png16: true,
                ..WriteOptions::default()
            },
        ),
    ] {
        let b = encoded("x.png", &img, &opts);
        sources.push((what.to_string(), b.clone(), png_fields(&b)));
    }
    // Grey and palette files, as other programs write them.
    let grey = image::GrayImage::from_fn(33, 17, |x, y| image::Luma([(x * 7 + y * 3) as u8]));
    let mut b = Vec::new();
    grey.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Png)
        .unwrap();
    sources.push(("PNG grey".to_string(), b.clone(), png_fields(&b)));
    for path in real_files("png", "png").into_iter().take(1) {
        let b = std::fs::read(&path).unwrap();
        sources.push((path.display().to_string(), b.clone(), png_fields(&b)));
    }
    formats(sources, "png", 0x243f_6a88_85a3_08d3, 200, png_fields);
}

#[test]
fn jpeg_mutations() {
    let img = test_image(40, 24);
    let b = encoded("x.jpg", &img, &WriteOptions::default());
    let mut sources = vec![("JPEG".to_string(), b.clone(), jpeg_fields(&b))];
    let grey = image::GrayImage::from_fn(21, 13, |x, y| image::Luma([(x * 9 + y * 5) as u8]));
    let mut b = Vec::new();
    grey.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Jpeg)
        .unwrap();
    sources.push(("JPEG grey".to_string(), b.clone(), jpeg_fields(&b)));
    for path in real_files("faces/forest_ldr", "jpg").into_iter().take(2) {
        let b = std::fs::read(&path).unwrap();
        sources.push((path.display().to_string(), b.clone(), jpeg_fields(&b)));
    }
    formats(sources, "jpg", 0x1319_8a2e_0370_7344, 200, jpeg_fields);
}

#[test]
fn tga_mutations() {
    let img = test_image(40, 24);
    let b = encoded("x.tga", &img, &WriteOptions::default());
    let mut sources = vec![("TGA (run-length)".to_string(), b, tga_fields())];
    // Flat: cubeforge's encoder compresses; the image crate can leave it.
    let rgba = image::RgbaImage::from_fn(19, 11, |x, y| {
        image::Rgba([x as u8 * 13, y as u8 * 23, 7, 200])
    });
    let mut b = Vec::new();
    image::codecs::tga::TgaEncoder::new(&mut b)
        .disable_rle()
        .encode(rgba.as_raw(), 19, 11, image::ExtendedColorType::Rgba8)
        .unwrap();
    sources.push(("TGA (flat)".to_string(), b, tga_fields()));
    formats(sources, "tga", 0xa409_3822_299f_31d0, 200, |_| tga_fields());
}

#[test]
fn hdr_mutations() {
    let mut sources = Vec::new();
    // Run-length scanlines (widths 8 to 32767), and flat texels (narrower).
    for (w, h) in [(40, 24), (5, 7)] {
        let b = encoded("x.hdr", &test_image(w, h), &WriteOptions::default());
        sources.push((format!("HDR {w}x{h}"), b.clone(), hdr_fields(&b)));
    }
    for path in real_files("hdr", "hdr").into_iter().take(1) {
        let b = std::fs::read(&path).unwrap();
        sources.push((path.display().to_string(), b.clone(), hdr_fields(&b)));
    }
    formats(sources, "hdr", 0x082e_fa98_ec4e_6c89, 200, hdr_fields);
}

#[test]
fn exr_mutations() {
    // The thorough EXR campaign is tests/it/hostile_exr.rs; this one keeps it in the same loop.
    let b = encoded("x.exr", &test_image(40, 24), &WriteOptions::default());
    formats(
        vec![("EXR".to_string(), b, Vec::new())],
        "exr",
        0x4528_21e6_38d0_1377,
        150,
        |_| Vec::new(),
    );
}

#[test]
fn ktx2_mutations() {
    let mut sources = Vec::new();
    for format in [GpuFormat::Rgba16f, GpuFormat::Rgba8Srgb] {
        let b = io::ktx2::encode(&test_cube(8), format);
        sources.push((
            format!("KTX2 cube {}", format.name()),
            b.clone(),
            ktx2_fields(&b),
        ));
    }
    let levels: Vec<Image> = std::iter::successors(Some(test_image(16, 8)), |i| {
        (i.width > 1 || i.height > 1).then(|| i.downsample_2x())
    })
    .collect();
    let b = io::ktx2::encode_2d(&levels, GpuFormat::Rgba8);
    sources.push(("KTX2 2D".to_string(), b.clone(), ktx2_fields(&b)));
    formats(sources, "ktx2", 0xbe54_66cf_34e9_0c6c, 200, ktx2_fields);
}

#[test]
fn dds_mutations() {
    let mut sources = Vec::new();
    for format in [GpuFormat::Rgba32f, GpuFormat::Rgba8] {
        let b = io::dds::encode(&test_cube(8), format).unwrap();
        sources.push((format!("DDS cube {}", format.name()), b, dds_fields()));
    }
    formats(sources, "dds", 0xc0ac_29b7_c97c_50dd, 200, |_| dds_fields());
}

/// Control recipes (TOML and JSON) through `control::parse`, and baked at 16x16 when they
/// parse: the recipes in fixtures/control, and one that reads an image.
#[test]
fn recipe_mutations() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("recipes");
    std::fs::create_dir(&base).unwrap();
    let png = encoded("x.png", &test_image(12, 10), &WriteOptions::default());
    std::fs::write(dir.path().join("sky.png"), &png).unwrap();
    std::fs::write(base.join("small.png"), &png).unwrap();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/control");
    let mut sources: Vec<(String, String, Syntax)> = Vec::new();
    for name in [
        "chrome_and_paint.toml",
        "frosted_glass.toml",
        "wet_ground.json",
    ] {
        let path = fixtures.join(name);
        let syntax = Syntax::from_path(&path).unwrap();
        sources.push((name.into(), std::fs::read_to_string(&path).unwrap(), syntax));
    }
    sources.push((
        "image recipe".into(),
        "size = \"24x16\"\nmax_lod_bias = 3\n[reflectivity]\nimage = { path = \"small.png\", channel = \"r\", srgb = true }\ninvert = true\n[fresnel]\nimage = { path = \"small.png\", channel = \"luminance\" }\nremap = { in = [0.1, 0.9], out = [0, 1], gamma = 2 }\n[pack]\nr = \"fresnel\"\ng = \"reflectivity\"\n"
            .into(),
        Syntax::Toml,
    ));
    let origin = Path::new("recipe-under-test");
    let door = |text: &[u8], syntax: Syntax| -> cubeforge::Result<()> {
        let text = String::from_utf8_lossy(text);
        let recipe = control::parse(&text, syntax, origin, &base, &limits())?;
        recipe.bake(Some(Size::new(16, 16).unwrap()), &limits())?;
        Ok(())
    };
    for (i, (what, text, syntax)) in sources.into_iter().enumerate() {
        door(text.as_bytes(), syntax).unwrap_or_else(|e| panic!("{what}: the valid recipe: {e}"));
        let mutator = Mutator::new(0x3f84_d5b5_b547_0917 + i as u64, Vec::new(), true);
        campaign(
            &what,
            text.as_bytes(),
            mutator,
            150,
            "recipe-under-test",
            &|b| door(b, syntax),
        );
    }
}

/// Material files through `material::parse_toml`: every preset as written by `to_toml`.
#[test]
fn material_mutations() {
    use cubeforge::preview::material;
    let path = Path::new("material-under-test.toml");
    for (i, (preset, _)) in material::presets().into_iter().enumerate() {
        let text = material::to_toml(&preset);
        let mutator = Mutator::new(0x9216_d5d9_8979_fb1b + i as u64, Vec::new(), true);
        campaign(
            &format!("material {}", preset.name),
            text.as_bytes(),
            mutator,
            60,
            "material-under-test",
            &|b| material::parse_toml(&String::from_utf8_lossy(b), path).map(drop),
        );
    }
}

/// A control map's sidecar (`MAP.json`) through `preview::read_control`, and a DDS chain's
/// `NAME.dds.levels.json` through `info::describe`.
#[test]
fn sidecar_mutations() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("map.png");
    std::fs::write(
        &map,
        encoded("x.png", &test_image(8, 8), &WriteOptions::default()),
    )
    .unwrap();
    let side = dir.path().join("map.png.json");
    let text = br#"{ "max_lod_bias": 6.0, "pack": { "r": "reflectivity", "g": "transmittance", "b": "blur", "a": "fresnel" } }"#;
    let mutator = Mutator::new(0xd131_0ba6_98df_b5ac, Vec::new(), true);
    campaign(
        "control sidecar",
        text,
        mutator,
        100,
        "map.png.json",
        &|b| {
            std::fs::write(&side, b).unwrap();
            match cubeforge::preview::read_control(&map, 4.0) {
                // A bad sidecar must be named, not the map.
                Err(e) if !e.to_string().contains("map.png.json") => Err(cubeforge::Error::file(
                    &side,
                    format!("blamed on the map: {e}"),
                )),
                r => r.map(drop),
            }
        },
    );

    let dds = dir.path().join("chain.dds");
    std::fs::write(
        &dds,
        io::dds::encode(&test_cube(4), GpuFormat::Rgba16f).unwrap(),
    )
    .unwrap();
    let levels = dir.path().join("chain.dds.levels.json");
    let text = br#"{"levels":[{"level":0,"size":4,"roughness":0.0},{"level":1,"size":2,"roughness":0.5},{"level":2,"size":1,"roughness":1.0}]}"#;
    let mutator = Mutator::new(0x2ffd_72db_d01a_dfb7, Vec::new(), true);
    let opts = ReadOptions {
        limits: limits(),
        linear: false,
        as_stored: false,
    };
    campaign("levels.json", text, mutator, 100, "chain.dds", &|b| {
        std::fs::write(&levels, b).unwrap();
        cubeforge::info::describe(&dds, None, &opts).map(drop)
    });
}

/// Limits that let a claimed size through, so that only the file's own checks can stop it.
fn generous() -> Limits {
    Limits {
        max_pixels: 1 << 30,
        max_dimension: 1 << 16,
        max_memory: u64::MAX,
    }
}

fn read_with(path: &Path, bytes: &[u8], limits: Limits) -> cubeforge::Result<Image> {
    std::fs::write(path, bytes).unwrap();
    let opts = ReadOptions {
        limits,
        ..ReadOptions::default()
    };
    match io::read(path, &opts)?.0 {
        Decoded::Image(img) => Ok(img),
        Decoded::Cube(_) => panic!("{}: a cube map", path.display()),
    }
}

/// Where a JPEG's frame header keeps its height (its width follows).
fn jpeg_size_at(b: &[u8]) -> usize {
    let mut at = 2;
    while !(0xc0..=0xc2).contains(&b[at + 1]) {
        at += 2 + be16(b, at + 2);
    }
    at + 5
}

/// Item 2: a 1 KB JPEG whose header claims up to 16384x16384 pixels (within the pixel limit,
/// the memory budget lifted) is refused from its size, before the decoder runs over blocks it
/// has no data for; a blank JPEG, the least data a real one needs per pixel, still reads.
#[test]
fn a_tiny_jpeg_claiming_a_huge_size_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("claims.jpg");
    let small = encoded("x.jpg", &test_image(16, 16), &WriteOptions::default());
    assert!(small.len() < 2048, "{} bytes", small.len());
    let at = jpeg_size_at(&small);
    for (w, h) in [
        (16384u16, 16384u16),
        (65500, 4096),
        (4096, 4096),
        (2048, 1024),
    ] {
        let mut b = small.clone();
        b[at..at + 2].copy_from_slice(&h.to_be_bytes());
        b[at + 2..at + 4].copy_from_slice(&w.to_be_bytes());
        let e = read_with(&path, &b, generous()).unwrap_err().to_string();
        assert!(
            e.contains("claims.jpg") && e.contains("too few"),
            "{w}x{h}: {e}"
        );
        assert!(e.contains(&format!("{w}x{h}")), "{e}");
    }
    // Blank: one DC code and an end-of-block per block, 16 times the floor or more.
    let blank = encoded(
        "x.jpg",
        &Image::filled(1024, 768, Vec4::splat(0.5)),
        &WriteOptions::default(),
    );
    println!("blank 1024x768 JPEG: {} bytes", blank.len());
    let img = read_with(&path, &blank, generous()).unwrap();
    assert_eq!((img.width, img.height), (1024, 768));
    // The same file cut to an eighth still reads (the rest grey), as it did.
    let img = read_with(&path, &blank[..blank.len() / 8], generous()).unwrap();
    assert_eq!((img.width, img.height), (1024, 768));
}

/// A grey PNG made here: `rows` (each starting with its filter byte) deflated into one IDAT.
fn png_file(w: u32, h: u32, bit_depth: u8, interlace: u8, rows: &[u8]) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        let crc = libdeflater::crc32(&out[start..]);
        out.extend_from_slice(&crc.to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[bit_depth, 0, 0, 0, interlace]);
    chunk(b"IHDR", &ihdr);
    let mut z = libdeflater::Compressor::new(libdeflater::CompressionLvl::best());
    let mut idat = vec![0u8; z.zlib_compress_bound(rows.len())];
    let n = z.zlib_compress(rows, &mut idat).unwrap();
    chunk(b"IDAT", &idat[..n]);
    chunk(b"IEND", &[]);
    out
}

/// PNG's counterpart: a 200-byte PNG claiming 16384x16384 (1-bit grey, plain and interlaced)
/// holds a few rows, and the decoder stops where they end, having inflated no more than the
/// file holds (deflate expands at most about 1032 times). A blank 2048x2048 PNG of a few
/// thousand bytes, more pixels per byte than any JPEG, is genuine and reads.
#[test]
fn a_tiny_png_claiming_a_huge_size_stops_where_its_data_ends() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("claims.png");
    for interlace in [0, 1] {
        let rows = vec![0u8; 8 * (1 + 16384 / 8)];
        let b = png_file(16384, 16384, 1, interlace, &rows);
        assert!(b.len() < 256, "{} bytes", b.len());
        let e = read_with(&path, &b, generous()).unwrap_err().to_string();
        assert!(e.contains("claims.png"), "{e}");
        println!("{e}");
    }
    let rows: Vec<u8> = (0..2048)
        .flat_map(|_| std::iter::once(0).chain(std::iter::repeat_n(0xff, 2048 / 8)))
        .collect();
    let b = png_file(2048, 2048, 1, 0, &rows);
    assert!(b.len() < 4096, "{} bytes", b.len());
    let img = read_with(&path, &b, generous()).unwrap();
    assert_eq!((img.width, img.height), (2048, 2048));
    assert_eq!(img.get(2047, 2047), Vec4::ONE);
}

/// The same for the other formats whose header states a size: a TGA (run-length and flat)
/// claiming 8192x8192 and a Radiance HDR claiming 16384x16384 in a few dozen bytes stop
/// where their data ends.
#[test]
fn tiny_tga_and_hdr_files_claiming_a_huge_size_stop_where_their_data_ends() {
    let dir = tempfile::tempdir().unwrap();
    for image_type in [2u8, 10] {
        let path = dir.path().join(format!("claims{image_type}.tga"));
        let mut b = vec![0, 0, image_type, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        // 8192x8192 (the image crate's buffer, 256 MiB, is allocated before reading).
        b.extend_from_slice(&8192u16.to_le_bytes());
        b.extend_from_slice(&8192u16.to_le_bytes());
        b.extend_from_slice(&[32, 8]);
        // One run of 128 texels, or 8 flat texels.
        b.extend_from_slice(&[0xff, 1, 2, 3, 4]);
        b.extend_from_slice(&[9; 28]);
        let e = read_with(&path, &b, generous()).unwrap_err().to_string();
        assert!(e.contains(&format!("claims{image_type}.tga")), "{e}");
    }
    let path = dir.path().join("claims.hdr");
    let mut b = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 16384\n".to_vec();
    b.extend_from_slice(&[2, 2, 0x40, 0]);
    for _ in 0..4 {
        b.extend_from_slice(&[128 + 127, 7]);
    }
    let e = read_with(&path, &b, generous()).unwrap_err().to_string();
    assert!(e.contains("claims.hdr") && e.contains("scanline 1"), "{e}");
}
