//! Corrupt and hostile OpenEXR files: each is made here, from a real fixture
//! (../shared/fixtures/real, skipped when absent) or from a file the exr crate writes, and
//! must give a one-line error naming the file, never a panic or an abort.

use crate::common::XorShift;
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{Decoded, ReadOptions};
use exr::prelude::*;
use glam::Vec4;
use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn real(sub: &str) -> Option<Vec<PathBuf>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/fixtures/real")
        .join(sub);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        println!("skipped: {} not found", dir.display());
        return None;
    };
    let mut files: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    files.sort();
    Some(files)
}

/// Reads `bytes` as the file `name` through `cubeforge::internals::io::read`. A panic fails the test
/// (with `what` to say which file it was); the error, if any, comes back as its message.
fn read(dir: &Path, name: &str, bytes: &[u8], what: &str) -> std::result::Result<Image, String> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    match catch_unwind(AssertUnwindSafe(|| {
        cubeforge::internals::convert::read(&path, &ReadOptions::default())
    })) {
        Ok(Ok((Decoded::Image(img), _))) => Ok(img),
        Ok(Ok((Decoded::Cube(_), _))) => panic!("{what}: read as a cube map"),
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => panic!("{what}: the reader panicked"),
    }
}

/// Like `read`, but the file must be refused with a message that names it.
fn refused(dir: &Path, name: &str, bytes: &[u8], what: &str) -> String {
    match read(dir, name, bytes, what) {
        Ok(_) => panic!("{what}: decoded"),
        Err(e) => {
            assert!(e.contains(name), "{what}: {e}");
            assert!(!e.contains('\n'), "{what}: {e}");
            e
        }
    }
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// Where a single-part file's chunk table starts: after the 8-byte preamble and the header
/// (attributes of name, type name, i32 size and value, ended by an empty name).
fn table_start(b: &[u8]) -> usize {
    let mut at = 8;
    while b[at] != 0 {
        let name_end = at + b[at..].iter().position(|&c| c == 0).unwrap();
        let type_end = name_end + 1 + b[name_end + 1..].iter().position(|&c| c == 0).unwrap();
        at = type_end + 5 + u32_at(b, type_end + 1) as usize;
    }
    at + 1
}

/// The chunk offsets of a single-part file with `count` chunks.
fn offsets(b: &[u8], count: usize) -> Vec<usize> {
    let start = table_start(b);
    (0..count)
        .map(|i| u64_at(b, start + 8 * i) as usize)
        .collect()
}

/// A file the exr crate writes: 64 x 48 RGBA floats with some structure, in `blocks`
/// with `compression`.
fn written(blocks: Blocks, compression: Compression) -> Vec<u8> {
    let layer = Layer::new(
        (64, 48),
        LayerAttributes::default(),
        Encoding {
            compression,
            blocks,
            line_order: LineOrder::Increasing,
        },
        SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
            let (x, y) = (x as f32, y as f32);
            (
                (x * 0.21).sin() + 1.5,
                (y * 0.13).cos() * 2.0 + 2.5,
                x * y * 1e-3,
                0.25 + (x + y) / 256.0,
            )
        }),
    );
    let mut out = Vec::new();
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(Cursor::new(&mut out))
        .unwrap();
    out
}

/// A two-part file the exr crate writes, each part 40 x 30 RGB floats in 16 x 16 tiles
/// with mip levels (rounded up), the second with other values and compression.
fn two_mip_mapped_parts() -> Vec<u8> {
    use exr::math::RoundingMode;
    let size = Vec2(40, 30);
    let part = |name: &str, scale: f32, compression: Compression| {
        let levels = |c: usize| Levels::Mip {
            rounding_mode: RoundingMode::Up,
            level_data: exr::meta::mip_map_levels(RoundingMode::Up, size)
                .map(|(level, s)| {
                    FlatSamples::F32(
                        (0..s.area())
                            .map(|i| scale * (i * (c + 1) + level) as f32)
                            .collect(),
                    )
                })
                .collect(),
        };
        let channels = AnyChannels::sort(SmallVec::from_vec(vec![
            AnyChannel::new("R", levels(0)),
            AnyChannel::new("G", levels(1)),
            AnyChannel::new("B", levels(2)),
        ]));
        Layer::new(
            size,
            LayerAttributes::named(name),
            Encoding {
                compression,
                blocks: Blocks::Tiles(Vec2(16, 16)),
                line_order: LineOrder::Increasing,
            },
            channels,
        )
    };
    let image =
        exr::image::Image::empty(ImageAttributes::new(IntegerBounds::from_dimensions(size)))
            .with_layer(part("first", 0.5, Compression::ZIP16))
            .with_layer(part("second", 2.0, Compression::PIZ));
    let mut out = Vec::new();
    image.write().to_buffered(Cursor::new(&mut out)).unwrap();
    out
}

/// Values for a u64 size field: huge (the reported abort came from one) and a little over
/// the original.
fn hostile_sizes(original: u64) -> Vec<u64> {
    vec![
        u64::MAX,
        1 << 63,
        i64::MAX as u64,
        50_665_495_807_930_014,
        1 << 40,
        u32::MAX as u64 + 1,
        original + 1,
        original + 8,
        original * 2 + 1,
        original + 100_000,
    ]
}

/// Every size field of the first DWA chunk (and the chunk's byte count) set to huge values
/// and to values a little over the true ones: always an error naming the file.
fn corrupt_dwa_sizes(bytes: &[u8], chunks: usize, dir: &Path, what: &str) -> usize {
    let first = offsets(bytes, chunks)[0];
    let data = first + 8; // after y and the byte count
    let mut cases = 0;
    // The 11 counters: version, UNKNOWN raw/packed, AC/DC/RLE packed, RLE tokens/raw, AC
    // count, DC count, AC coder. The version and the coder are not sizes, but must not
    // crash either.
    for field in 0..11 {
        let at = data + 8 * field;
        for value in hostile_sizes(u64_at(bytes, at)) {
            let mut b = bytes.to_vec();
            b[at..at + 8].copy_from_slice(&value.to_le_bytes());
            let what = format!("{what}: DWA field {field} = {value}");
            let e = refused(dir, "dwa_field.exr", &b, &what);
            assert!(e.contains("cannot decode OpenEXR"), "{what}: {e}");
            cases += 1;
        }
    }
    // The chunk's byte count, and the channel rules' size.
    for (at, values) in [
        (
            first + 4,
            vec![u32::MAX, i32::MAX as u32, u32_at(bytes, first + 4) + 1],
        ),
        (data + 88, vec![0, 1, 0xffff, 0x1000]),
    ] {
        for value in values {
            let mut b = bytes.to_vec();
            if at == data + 88 {
                b[at..at + 2].copy_from_slice(&(value as u16).to_le_bytes());
            } else {
                b[at..at + 4].copy_from_slice(&value.to_le_bytes());
            }
            let what = format!("{what}: u32 at {at} = {value}");
            refused(dir, "dwa_size.exr", &b, &what);
            cases += 1;
        }
    }
    cases
}

/// (a) The real DWAB panoramas with the size fields of their chunk corrupted.
#[test]
fn corrupt_dwab_sizes_are_refused() {
    let Some(files) = real("dwab") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut cases = 0;
    for path in files.iter().take(4) {
        let bytes = std::fs::read(path).unwrap();
        // 512 x 256 in one 256-line DWAB chunk.
        let header = exr::meta::MetaData::read_from_buffered(Cursor::new(&bytes), false).unwrap();
        let chunks = header.headers[0].chunk_count;
        cases += corrupt_dwa_sizes(&bytes, chunks, dir.path(), &path.display().to_string());
    }
    assert!(cases > 100);
}

/// (a) The same for DWAA and DWAB files the crate writes (32- and 256-line chunks, with an
/// alpha channel in the RLE section), fixtures or not.
#[test]
fn corrupt_dwa_sizes_of_written_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (compression, chunks) in [(Compression::DWAA(None), 2), (Compression::DWAB(None), 1)] {
        let bytes = written(Blocks::ScanLines, compression);
        // The file itself reads.
        read(dir.path(), "dwa.exr", &bytes, "valid DWA").unwrap();
        corrupt_dwa_sizes(&bytes, chunks, dir.path(), &format!("{compression:?}"));
    }
}

/// `count` copies of `bytes`, each with a few bytes changed (most near the start, where
/// the headers, the chunk table and the first chunk's header and DWA counters are), read
/// through `cubeforge::internals::io::read`: Ok or Err, but no panic.
/// HOSTILE_EXR_ROUNDS=n runs n times as many (for a longer search by hand).
fn mutate(bytes: &[u8], seed: u64, count: usize, dir: &Path, what: &str) -> (usize, usize) {
    let scale: usize = std::env::var("HOSTILE_EXR_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let count = count * scale;
    let mut rng = XorShift(seed);
    let (mut ok, mut err) = (0, 0);
    for round in 0..count {
        let mut b = bytes.to_vec();
        for _ in 0..1 + rng.below(4) {
            let span = if rng.below(4) == 0 {
                b.len()
            } else {
                b.len().min(1024)
            };
            let at = rng.below(span);
            match rng.below(5) {
                0 => b[at] ^= 1 << rng.below(8),
                1 => b[at] = rng.next() as u8,
                2 => b[at] = 0xff,
                3 => b[at] = 0,
                _ => {
                    // A whole little-endian word: a size made huge or slightly off.
                    let end = (at + 8).min(b.len());
                    let word = rng.next().to_le_bytes();
                    b[at..end].copy_from_slice(&word[..end - at]);
                }
            }
        }
        if rng.below(16) == 0 {
            let keep = rng.below(b.len());
            b.truncate(keep);
        }
        match read(dir, "mutated.exr", &b, &format!("{what}, mutation {round}")) {
            Ok(_) => ok += 1,
            Err(e) => {
                assert!(e.contains("mutated.exr"), "{e}");
                if std::env::var_os("HOSTILE_EXR_VERBOSE").is_some() {
                    println!("{what}, mutation {round}: {e}");
                }
                err += 1;
            }
        }
    }
    (ok, err)
}

/// (b) Seeded byte mutations of a real DWAB and a real ZIP panorama and of small files the
/// crate writes: tiled PIZ, two mip-mapped parts, DWAA, scan-line RLE and ZIP.
#[test]
fn mutated_files_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let tiled = written(Blocks::Tiles(Vec2(16, 16)), Compression::PIZ);
    let (ok, err) = mutate(&tiled, 0x9e37_79b9_7f4a_7c15, 300, dir.path(), "tiled PIZ");
    println!("tiled PIZ: {ok} read, {err} refused");
    let parts = two_mip_mapped_parts();
    let (ok, err) = mutate(&parts, 0x5851_f42d_4c95_7f2d, 200, dir.path(), "two parts");
    println!("two mip-mapped parts: {ok} read, {err} refused");
    let dwaa = written(Blocks::ScanLines, Compression::DWAA(None));
    let (ok, err) = mutate(&dwaa, 0x2545_f491_4f6c_dd1d, 200, dir.path(), "DWAA");
    println!("DWAA: {ok} read, {err} refused");
    // Scan-line RLE and ZIP, which cubeforge unpacks itself.
    for (compression, seed) in [
        (Compression::RLE, 0x6a09_e667_f3bc_c909),
        (Compression::ZIP1, 0xbb67_ae85_84ca_a73b),
    ] {
        let bytes = written(Blocks::ScanLines, compression);
        let what = format!("{compression:?}");
        let (ok, err) = mutate(&bytes, seed, 200, dir.path(), &what);
        println!("{what}: {ok} read, {err} refused");
    }
    for (sub, seed) in [
        ("dwab", 0x1234_5678_9abc_def1),
        ("zip", 0x0fed_cba9_8765_4321),
    ] {
        let Some(files) = real(sub) else {
            continue;
        };
        let path = &files[0];
        let bytes = std::fs::read(path).unwrap();
        let what = path.display().to_string();
        let (ok, err) = mutate(&bytes, seed, 300, dir.path(), &what);
        println!("{what}: {ok} read, {err} refused");
    }
}

/// (c) A tiled file in which two chunks carry one tile's coordinates (so another tile is
/// missing) is refused, whichever the compression; so is one whose chunk table points at
/// one chunk twice, one with a missing chunk, and a scan-line file with two blocks at one
/// position.
#[test]
fn duplicate_and_missing_blocks_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mentions = |e: &str| {
        ["overlapping", "duplicate", "missing"]
            .iter()
            .any(|w| e.contains(w))
    };
    for compression in [
        Compression::PIZ,
        Compression::ZIP16,
        Compression::Uncompressed,
    ] {
        let bytes = written(Blocks::Tiles(Vec2(16, 16)), compression);
        let what = format!("tiled {compression:?}");
        let good = read(dir.path(), "tiled.exr", &bytes, &what).unwrap();
        assert_eq!(good, crate_reader(&bytes), "{what}");
        // 4 x 3 tiles; each chunk: tile x, tile y, level x, level y, byte count, data.
        let table = offsets(&bytes, 12);
        for (from, to) in [(0, 1), (5, 4), (11, 0), (3, 7)] {
            let mut b = bytes.clone();
            let coordinates = bytes[table[from]..table[from] + 16].to_vec();
            b[table[to]..table[to] + 16].copy_from_slice(&coordinates);
            let what = format!("{what}: tile {to} claims tile {from}");
            let e = refused(dir.path(), "duplicate_tile.exr", &b, &what);
            assert!(mentions(&e), "{what}: {e}");
        }
        // Two table entries for one chunk.
        let mut b = bytes.clone();
        let start = table_start(&bytes);
        b[start + 8 * 2..start + 8 * 3].copy_from_slice(&(table[6] as u64).to_le_bytes());
        let e = refused(dir.path(), "table.exr", &b, &format!("{what}: table"));
        assert!(mentions(&e), "{what}: {e}");
        // A missing chunk (an incomplete file's zero offset).
        let mut b = bytes.clone();
        b[start + 8 * 9..start + 8 * 10].fill(0);
        let e = refused(dir.path(), "missing.exr", &b, &format!("{what}: missing"));
        assert!(e.contains("missing"), "{what}: {e}");
    }
    // Scan lines: 48 lines in 16-line ZIP blocks; block 2 claims block 1's lines.
    for compression in [Compression::ZIP16, Compression::PIZ, Compression::RLE] {
        let bytes = written(Blocks::ScanLines, compression);
        let count = 48usize.div_ceil(compression.scan_lines_per_block());
        if count < 2 {
            continue;
        }
        let table = offsets(&bytes, count);
        let mut b = bytes.clone();
        let y = bytes[table[0]..table[0] + 4].to_vec();
        b[table[count - 1]..table[count - 1] + 4].copy_from_slice(&y);
        let what = format!("scan lines {compression:?}");
        let e = refused(dir.path(), "duplicate_lines.exr", &b, &what);
        assert!(mentions(&e), "{what}: {e}");
    }
}

/// The exr crate's own reader, for comparison.
fn crate_reader(bytes: &[u8]) -> Image {
    cubeforge::internals::io::exr::crate_reader(bytes).unwrap()
}

/// (d) The real fixtures, and files of every layout the crate writes, decode exactly as the
/// exr crate's own reader decodes them.
#[test]
fn valid_files_decode_as_the_crate_reads_them() {
    let opts = ReadOptions::default();
    for sub in ["zip", "dwab", "ball", "faces/city"] {
        let Some(files) = real(sub) else {
            continue;
        };
        for path in files {
            let bytes = std::fs::read(&path).unwrap();
            let Decoded::Image(img) = cubeforge::internals::convert::read_raw(&path, &opts)
                .unwrap()
                .0
            else {
                panic!("{}: a cube map", path.display());
            };
            assert!(img == crate_reader(&bytes), "{}", path.display());
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let bytes = two_mip_mapped_parts();
    let path = dir.path().join("parts.exr");
    std::fs::write(&path, &bytes).unwrap();
    let Decoded::Image(img) = cubeforge::internals::convert::read_raw(&path, &opts)
        .unwrap()
        .0
    else {
        panic!("two parts: a cube map");
    };
    assert_eq!((img.width, img.height), (40, 30));
    assert_eq!(img.get(39, 29), Vec4::new(599.5, 1199.0, 1798.5, 1.0));
    assert!(img == crate_reader(&bytes), "two parts");
    for blocks in [Blocks::ScanLines, Blocks::Tiles(Vec2(16, 16))] {
        for compression in [
            Compression::Uncompressed,
            Compression::RLE,
            Compression::ZIP1,
            Compression::ZIP16,
            Compression::PIZ,
            Compression::PXR24,
            Compression::B44,
            Compression::DWAA(None),
            Compression::DWAB(None),
        ] {
            let bytes = written(blocks, compression);
            let what = format!("{blocks:?} {compression:?}");
            let path = dir.path().join("valid.exr");
            std::fs::write(&path, &bytes).unwrap();
            let Decoded::Image(img) = cubeforge::internals::convert::read_raw(&path, &opts)
                .unwrap_or_else(|e| panic!("{what}: {e}"))
                .0
            else {
                panic!("{what}: a cube map");
            };
            assert!(img == crate_reader(&bytes), "{what}");
        }
    }
}

#[test]
fn newer_compressions_are_named_not_called_invalid() {
    let dir = tempfile::tempdir().unwrap();
    let plain = written(Blocks::ScanLines, Compression::Uncompressed);
    let key = b"compression\0compression\0";
    let at = plain
        .windows(key.len())
        .position(|w| w == key)
        .expect("a compression attribute")
        + key.len()
        + 4;
    // OpenEXR 3.5's numbers past DWAB (9) that are not decoded (13, ZSTD, is), and one no
    // version has.
    for (method, name) in [
        (10u8, "HTJ2K256"),
        (11, "HTJ2K32"),
        (12, "LJ2K"),
        (200, "unknown"),
    ] {
        let mut bytes = plain.clone();
        bytes[at] = method;
        let e = refused(dir.path(), "new.exr", &bytes, name);
        assert!(
            e.contains(&format!(
                "unsupported compression ({name}, method {method})"
            )),
            "{e}"
        );
    }
}
