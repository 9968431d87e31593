//! 16K panoramas in a small file: an OpenEXR of 16384 x 8192 whose ZIP blocks are all the
//! same few hundred bytes, and a Radiance .hdr whose scanlines are runs, both a megabyte or
//! so, made here byte by byte. Read whole they would take 2 GiB; the streamed paths (`info`,
//! `ibl`) fold them in bands within the budget. The valid files must go through; their
//! mutations (the chunk table, the block headers, the runs: what only a file this large has
//! in such numbers) must be refused naming the file or read, within the budget.
//! `#[ignore]`d: each read decodes 134 million texels (seconds on 2 cores); run by hand with
//! `cargo test --release --test hostile_inputs -- --ignored big_`.

use crate::harness::campaign;
use crate::mutator::{Field, Mutator};
use crate::streamed::{attribute, exr_table, streamed_door};

const W: usize = 16384;
const H: usize = 8192;
/// Lines per ZIP block (ZIP16).
const LINES: usize = 16;

/// OpenEXR's ZIP predictor and interleave, forwards: what the decoder undoes.
fn zip_forward(raw: &[u8]) -> Vec<u8> {
    let half = raw.len().div_ceil(2);
    let mut t = vec![0u8; raw.len()];
    for (i, &b) in raw.iter().enumerate() {
        t[if i % 2 == 0 { i / 2 } else { half + i / 2 }] = b;
    }
    let mut out = t.clone();
    for i in 1..t.len() {
        out[i] = t[i].wrapping_sub(t[i - 1]).wrapping_add(128);
    }
    out
}

/// One ZIP block of `LINES` rows of RGBA halves (channels in A B G R order), each texel
/// `value`, but for `sun` (a column range of bright texels) where given.
fn zip_block(value: [u16; 4], sun: Option<std::ops::Range<usize>>) -> Vec<u8> {
    let mut raw = Vec::with_capacity(LINES * W * 8);
    for _ in 0..LINES {
        for (c, &v) in value.iter().enumerate() {
            for x in 0..W {
                let bright = c > 0 && sun.as_ref().is_some_and(|s| s.contains(&x));
                let v = if bright { 0x7000 } else { v }; // 8192
                raw.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let data = zip_forward(&raw);
    let mut z = libdeflater::Compressor::new(libdeflater::CompressionLvl::new(6).unwrap());
    let mut out = vec![0u8; z.zlib_compress_bound(data.len())];
    let n = z.zlib_compress(&data, &mut out).unwrap();
    out.truncate(n);
    out
}

/// A 16384 x 8192 RGBA half ZIP16 OpenEXR: the header of a small file the exr crate writes,
/// its windows enlarged, then a full chunk table and one block per 16 rows (a sun in one).
pub fn big_exr() -> Vec<u8> {
    let small = crate::streamed::exr_written(exr::prelude::Compression::ZIP16);
    let table = exr_table(&small).unwrap();
    let mut b = small[..table].to_vec();
    for name in ["dataWindow", "displayWindow"] {
        let at = attribute(&b, name).unwrap();
        for (i, v) in [0, 0, W as i32 - 1, H as i32 - 1].into_iter().enumerate() {
            b[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
    let blocks = H / LINES;
    if let Some(at) = attribute(&b, "chunkCount") {
        b[at..at + 4].copy_from_slice(&(blocks as i32).to_le_bytes());
    }
    // Sky blue (A 1, B 0.8, G 0.5, R 0.25), and a sun 40 texels wide in block 100.
    let value = [0x3c00, 0x3a66, 0x3800, 0x3400];
    let plain = zip_block(value, None);
    let sunny = zip_block(value, Some(9000..9040));
    let mut offset = (b.len() + 8 * blocks) as u64;
    let mut chunks = Vec::new();
    for i in 0..blocks {
        let data = if i == 100 { &sunny } else { &plain };
        b.extend_from_slice(&offset.to_le_bytes());
        chunks.extend_from_slice(&((i * LINES) as i32).to_le_bytes());
        chunks.extend_from_slice(&(data.len() as i32).to_le_bytes());
        chunks.extend_from_slice(data);
        offset += 8 + data.len() as u64;
    }
    b.extend_from_slice(&chunks);
    b
}

/// A 16384 x 8192 Radiance .hdr of run-length scanlines (a sun in a few rows).
pub fn big_hdr() -> Vec<u8> {
    let mut b = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {H} +X {W}\n").into_bytes();
    let runs = |b: &mut Vec<u8>, value: u8, n: usize| {
        let mut left = n;
        while left > 0 {
            let k = left.min(127);
            b.extend_from_slice(&[128 + k as u8, value]);
            left -= k;
        }
    };
    for y in 0..H {
        b.extend_from_slice(&[2, 2, (W >> 8) as u8, (W & 255) as u8]);
        let sun = (3000..3004).contains(&y);
        // R G B E: a sky of (64, 128, 200) * 2^(128 - 136), a sun of 255 * 2^(140 - 136).
        for (c, (sky, bright)) in [(64, 255), (128, 250), (200, 240), (128, 140)]
            .into_iter()
            .enumerate()
        {
            if sun {
                runs(&mut b, sky, 9000);
                runs(&mut b, bright, 40);
                runs(&mut b, sky, W - 9040);
            } else {
                runs(&mut b, if c == 3 { 128 } else { sky }, W);
            }
        }
    }
    b
}

/// The chunk table's first and last entries and the first blocks' headers.
fn big_exr_fields(b: &[u8]) -> Vec<Field> {
    let table = exr_table(b).unwrap();
    let blocks = H / LINES;
    let mut f: Vec<Field> = [0, 1, 2, 100, blocks - 1]
        .iter()
        .map(|i| Field::le(table + 8 * i, 8))
        .collect();
    let first = u64::from_le_bytes(b[table..table + 8].try_into().unwrap()) as usize;
    f.extend([Field::le(first, 4), Field::le(first + 4, 4)]);
    f.extend(crate::streamed::exr_fields(b));
    f
}

fn big_campaign(what: &str, src: &[u8], ext: &str, fields: Vec<Field>, seed: u64) {
    let dir = tempfile::tempdir().unwrap();
    let name = format!("big.{ext}");
    let door = streamed_door(dir.path(), &name, false);
    println!("{what}: {} bytes", src.len());
    door(src).unwrap_or_else(|e| panic!("{what}: the valid file: {e}"));
    let mutator = Mutator::new(seed, fields, false);
    campaign(what, src, mutator, 6, &name, &door);
}

#[test]
#[ignore]
fn big_exr_mutations() {
    let b = big_exr();
    big_campaign(
        "16K EXR",
        &b,
        "exr",
        big_exr_fields(&b),
        0x1f83_d9ab_fb41_bd6b,
    );
}

#[test]
#[ignore]
fn big_hdr_mutations() {
    let b = big_hdr();
    let fields = crate::images::hdr_fields(&b);
    big_campaign("16K HDR", &b, "hdr", fields, 0x5be0_cd19_137e_2179);
}
