//! The OpenEXR reader and writer against the crate, OpenEXR-written files and damaged ones.

use super::*;

/// The fast path's texels, None where it declines the file.
fn fast(bytes: &[u8]) -> Option<Image> {
    let (meta, start, _) = read_meta(bytes).unwrap();
    let layout = fast_layout(&meta)?;
    let chunks = read_chunks(bytes, &meta, start).unwrap();
    Some(
        blocks::decode_blocks(&meta, &layout, chunks, false, false)
            .unwrap()
            .0,
    )
}

/// The crate's pixel reader on the checked chunks.
fn slow(bytes: &[u8]) -> Image {
    let (meta, start, _) = read_meta(bytes).unwrap();
    read_layer(&meta, read_chunks(bytes, &meta, start).unwrap(), false).unwrap()
}

fn crate_reader(bytes: &[u8]) -> Image {
    super::crate_reader(bytes).unwrap()
}

fn both(bytes: &[u8], what: &str) {
    let fast = fast(bytes).unwrap_or_else(|| panic!("{what}: declined"));
    let slow = slow(bytes);
    assert_eq!(fast, slow, "{what}");
    assert_eq!(slow, crate_reader(bytes), "{what}");
}

/// A `w` x `h` file the crate writes with `compression`, channels R G B (A) of the sample
/// types `types` names (h half, f float; "+zu" adds a float Z and an integer id channel),
/// holding negative, small, large and fractional values.
fn written(size: (usize, usize), compression: Compression, types: &str) -> Vec<u8> {
    let (w, h) = size;
    let value = |i: usize, c: usize| {
        let (x, y) = ((i % w) as f32, (i / w) as f32);
        match c {
            0 => x * 0.37 - 3.0,
            1 => (y * 0.61).sin() * 1000.0,
            2 => (x * y + 1.0).recip(),
            _ => 0.25 + x / 64.0,
        }
    };
    let samples = |c: usize, t: u8| match t {
        b'h' => FlatSamples::F16((0..w * h).map(|i| f16::from_f32(value(i, c))).collect()),
        b'f' => FlatSamples::F32((0..w * h).map(|i| value(i, c)).collect()),
        _ => FlatSamples::U32((0..w * h).map(|i| i as u32 * 7919).collect()),
    };
    let (colours, extra) = types.split_once('+').unwrap_or((types, ""));
    let mut list: Vec<AnyChannel<FlatSamples>> = colours
        .bytes()
        .enumerate()
        .map(|(c, t)| AnyChannel::new(["R", "G", "B", "A"][c], samples(c, t)))
        .collect();
    if !extra.is_empty() {
        list.push(AnyChannel::new("Z", samples(0, b'f')));
        list.push(AnyChannel::new("id", samples(0, b'u')));
    }
    let layer = Layer::new(
        size,
        LayerAttributes::default(),
        Encoding {
            compression,
            ..Encoding::SMALL_LOSSLESS
        },
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    let mut out = Vec::new();
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(Cursor::new(&mut out))
        .unwrap();
    out
}

/// The block-parallel reader gives the crate reader's texels bit for bit.
#[test]
fn blocks_match_the_crate_reader() {
    let img = Image::from_fn(37, 41, |x, y| {
        Vec4::new(
            x as f32 * 0.3,
            y as f32 * 7.0,
            (x * y) as f32 * 1e-3,
            (x % 5) as f32 / 4.0,
        )
    });
    both(&encode(&img, false).unwrap(), "ours, RGBA half");
    let opaque = Image::from_fn(37, 41, |x, y| img.get(x, y).truncate().extend(1.0));
    both(&encode(&opaque, false).unwrap(), "ours, RGB half");
    // Full floats keep what half cannot: a sun of 2e5, and 1e-9.
    let sun = Image::from_fn(37, 41, |x, y| {
        let v = if (x, y) == (3, 4) {
            2.0e5
        } else {
            x as f32 * 1e-9 + y as f32
        };
        Vec4::new(v, v * 0.5, v * 0.25, if x == 0 { 0.5 } else { 1.0 })
    });
    let bytes = encode(&sun, true).unwrap();
    both(&bytes, "ours, RGBA float");
    assert_eq!(crate_reader(&bytes), sun);
    let opaque_sun = Image::from_fn(37, 41, |x, y| sun.get(x, y).truncate().extend(1.0));
    assert_eq!(
        crate_reader(&encode(&opaque_sun, true).unwrap()),
        opaque_sun
    );
    // Noise that does not shrink: its blocks are stored as they are.
    let noisy = |x: usize, y: usize, c: usize| {
        let mut h = (((x * 131 + y) * 4 + c) as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        h ^= h >> 29;
        h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h ^= h >> 32;
        f16::from_bits(h as u16 & 0x7bff).to_f32()
    };
    let noise = Image::from_fn(33, 17, |x, y| {
        Vec4::new(
            noisy(x, y, 0),
            noisy(x, y, 1),
            noisy(x, y, 2),
            noisy(x, y, 3),
        )
    });
    let bytes = encode(&noise, false).unwrap();
    assert!(bytes.len() > 33 * 17 * 8, "stored, not compressed");
    both(&bytes, "ours, noise");
    assert_eq!(crate_reader(&bytes), noise);
    // Every compression the crate writes, of half and full floats (and both in one file,
    // with channels that are skipped), in sizes whose last block is partial.
    for (w, h) in [(37, 41), (1, 19), (300, 5)] {
        for compression in [
            Compression::Uncompressed,
            Compression::RLE,
            Compression::ZIP1,
            Compression::ZIP16,
            Compression::PIZ,
            Compression::PXR24,
            Compression::B44,
            Compression::B44A,
            Compression::DWAA(None),
            Compression::DWAB(None),
        ] {
            for types in ["hhhh", "fff", "hfhf", "hhh+zu"] {
                let out = written((w, h), compression, types);
                both(&out, &format!("{w}x{h} {types} {compression:?}"));
            }
        }
    }
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real");
    for sub in ["zip", "dwab", "ball", "faces/city"] {
        let Ok(dir) = std::fs::read_dir(real.join(sub)) else {
            continue;
        };
        for f in dir.flatten() {
            if f.path().extension().is_some_and(|e| e == "exr") {
                both(
                    &std::fs::read(f.path()).unwrap(),
                    &f.path().display().to_string(),
                );
            }
        }
    }
}

/// Sanitizing while decoding replaces what `Image::sanitize` replaces, and counts as many.
#[test]
fn sanitized_as_it_decodes() {
    let odd = [
        f32::NAN,
        f32::INFINITY,
        -2.0,
        3e30,
        -0.0,
        1e28,
        0.5,
        f32::NEG_INFINITY,
    ];
    let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let at = |c: usize| odd[(x * 3 + y * 5 + c) % odd.len()];
        (at(0), at(1), at(2), at(3))
    });
    for (blocks, compression) in [
        (Blocks::ScanLines, Compression::ZIP16),
        (Blocks::ScanLines, Compression::RLE),
        (Blocks::ScanLines, Compression::PIZ),
        (Blocks::Tiles(Vec2(16, 16)), Compression::ZIP16),
    ] {
        let layer = Layer::new(
            (37, 21),
            LayerAttributes::default(),
            Encoding {
                compression,
                blocks,
                ..Encoding::SMALL_LOSSLESS
            },
            channels.clone(),
        );
        let mut out = Vec::new();
        exr::image::Image::from_layer(layer)
            .write()
            .to_buffered(Cursor::new(&mut out))
            .unwrap();
        let mut want = crate_reader(&out);
        let count = want.sanitize();
        let (Decoded::Image(got), meta) =
            decode_with(&out, Path::new("t.exr"), &Default::default(), true).unwrap()
        else {
            unreachable!()
        };
        let what = format!("{blocks:?} {compression:?}");
        assert!(count > 0, "{what}");
        assert_eq!(meta.replaced_values, count, "{what}");
        let bits = |img: &Image| -> Vec<[u32; 4]> {
            img.pixels
                .iter()
                .map(|p| p.to_array().map(f32::to_bits))
                .collect()
        };
        assert_eq!(bits(&got), bits(&want), "{what}");
    }
}

/// Tiled files go to the crate's pixel reader.
#[test]
fn tiles_are_left_to_the_crate() {
    let channels = SpecificChannels::rgb(|Vec2(x, y)| (x as f32, y as f32, 0.5f32));
    let layer = Layer::new(
        (40, 30),
        LayerAttributes::default(),
        Encoding {
            blocks: Blocks::Tiles(Vec2(16, 16)),
            ..Encoding::SMALL_LOSSLESS
        },
        channels,
    );
    let mut out = Vec::new();
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(Cursor::new(&mut out))
        .unwrap();
    assert!(fast(&out).is_none());
    let img = slow(&out);
    assert_eq!(img.get(39, 29), Vec4::new(39.0, 29.0, 0.5, 1.0));
    assert_eq!(img, crate_reader(&out));
}

/// Corrupt PIZ blocks (the headers and code table changed byte by byte, every 7th byte
/// after; cut short at as many lengths) give an image or an error, never a panic; intact
/// ones read as the crate reads them.
#[test]
fn corrupt_piz_blocks_are_errors() {
    let limits = Limits::default();
    for types in ["fff", "hhhh"] {
        let good = written((64, 33), Compression::PIZ, types);
        both(&good, types);
        let (meta, start, _) = read_meta(&good).unwrap();
        let chunks = read_chunks(&good, &meta, start).unwrap();
        let data = chunks[0].data;
        let stored = 64 * 32 * if types == "fff" { 12 } else { 8 };
        assert!(
            data.len() < stored,
            "{types}: a PIZ block, not a stored one"
        );
        let at = data.as_ptr() as usize - good.as_ptr() as usize;
        let path = Path::new("t.exr");
        // Every byte of the headers (bitmap, lengths, code table), every 7th after.
        let picked = (0..data.len()).filter(|&i| i < 160 || i % 7 == 0);
        for i in picked.clone().map(|i| at + i) {
            for v in [0u8, 0xff, good[i] ^ 0x10, good[i].wrapping_add(1)] {
                let mut bad = good.clone();
                bad[i] = v;
                let _ = decode(&bad, path, &limits);
            }
        }
        for n in picked {
            // The chunk's size field keeps its length: the file is cut inside the block.
            let _ = decode(&good[..at + n], path, &limits);
        }
    }
}

/// A panic inside a guarded call is a message, not an unwinding thread.
#[test]
fn panics_become_messages() {
    let e = guarded::<()>(|| panic!("capacity overflow")).unwrap_err();
    assert!(e.contains("capacity overflow"), "{e}");
    let e = guarded::<()>(|| Err(exr::error::Error::Invalid("thing".into()))).unwrap_err();
    assert!(e.contains("thing"), "{e}");
}

/// Where a PIZ block's Huffman header starts: after the bitmap's bounds, the bitmap and the
/// coded length.
fn piz_header_at(block: &[u8]) -> usize {
    let (lo, hi) = (
        u16::from_le_bytes([block[0], block[1]]) as usize,
        u16::from_le_bytes([block[2], block[3]]) as usize,
    );
    4 + if lo <= hi { hi - lo + 1 } else { 0 } + 4
}

/// The reported case: a Huffman header whose first symbol lies above the last symbol + 1
/// (it panicked with "slice index starts at 100 but ends at 51"). An error naming the file,
/// for every such pair and for a first symbol just one above the last.
#[test]
fn piz_first_symbol_after_the_last_is_an_error() {
    let good = written((64, 33), Compression::PIZ, "hhhh");
    let (meta, start, _) = read_meta(&good).unwrap();
    let chunks = read_chunks(&good, &meta, start).unwrap();
    let data = chunks[0].data;
    let at = data.as_ptr() as usize - good.as_ptr() as usize + piz_header_at(data);
    for (first, last) in [
        (100u32, 50u32),
        (51, 50),
        (65536, 0),
        (65536, 65535),
        (1, 0),
    ] {
        let mut bad = good.clone();
        bad[at..at + 4].copy_from_slice(&first.to_le_bytes());
        bad[at + 4..at + 8].copy_from_slice(&last.to_le_bytes());
        let e = decode(&bad, Path::new("t.exr"), &Limits::default())
            .err()
            .unwrap_or_else(|| panic!("symbols {first} to {last} read"))
            .to_string();
        assert!(e.contains("t.exr") && e.contains("Huffman"), "{e}");
    }
}

/// The hand-written PIZ decoder's own mutation loop: seeded changes aimed at each part of a
/// block (the Huffman header's five words set to extremes, the code table's bits, the
/// bitmap's bounds, the coded length, any byte, cuts), in files of half, float and mixed
/// channels with partial blocks. Every mutated file is an image or an error naming the
/// file, never a panic. `PIZ_ROUNDS=n` runs n times as many.
#[test]
fn piz_mutations_never_panic() {
    let scale: usize = std::env::var("PIZ_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mut rng = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    let limits = Limits::default();
    let (mut read_ok, mut refused) = (0, 0);
    for (size, types) in [
        ((64, 33), "hhhh"),
        ((37, 41), "fff"),
        ((300, 5), "hfhf"),
        ((16, 70), "hhh+zu"),
    ] {
        let good = written(size, Compression::PIZ, types);
        let (meta, start, _) = read_meta(&good).unwrap();
        let chunks = read_chunks(&good, &meta, start).unwrap();
        let blocks: Vec<(usize, usize)> = chunks
            .iter()
            .map(|c| {
                (
                    c.data.as_ptr() as usize - good.as_ptr() as usize,
                    c.data.len(),
                )
            })
            .collect();
        for round in 0..2500 * scale {
            let mut bad = good.clone();
            let (at, len) = blocks[next() as usize % blocks.len()];
            let huf = at + piz_header_at(&good[at..at + len]);
            if huf + 20 > at + len {
                continue; // a stored block: nothing of PIZ's to change
            }
            let stream = (at + len - huf - 20) as u64;
            let mut cut = None;
            for _ in 0..1 + (next() % 3 == 0) as usize {
                match next() % 7 {
                    0 | 1 => {
                        let word = huf + 4 * (next() as usize % 5);
                        let old = u32::from_le_bytes(bad[word..word + 4].try_into().unwrap());
                        let v = [
                            0,
                            1,
                            old.wrapping_sub(1),
                            old.wrapping_add(1),
                            65535,
                            65536,
                            65537,
                            u32::MAX,
                            i32::MAX as u32,
                            stream as u32,
                            8 * stream as u32,
                            8 * stream as u32 + 1,
                            next() as u32 % 65538,
                        ][next() as usize % 13];
                        bad[word..word + 4].copy_from_slice(&v.to_le_bytes());
                    }
                    2 => {
                        // A bit of the code table (its first bytes, after the header).
                        let span = (stream as usize).clamp(1, 64);
                        let i = huf + 20 + next() as usize % span;
                        if i < at + len {
                            bad[i] ^= 1 << (next() % 8);
                        }
                    }
                    3 => {
                        let i = at + next() as usize % 4;
                        bad[i] = next() as u8;
                    }
                    4 => {
                        let i = huf - 4;
                        let v = [0i32, -1, i32::MIN, i32::MAX, len as i32, next() as i32 % 99];
                        bad[i..i + 4].copy_from_slice(&v[next() as usize % 6].to_le_bytes());
                    }
                    5 => {
                        let i = at + next() as usize % len;
                        bad[i] = next() as u8;
                    }
                    _ => cut = Some(at + next() as usize % len),
                }
            }
            let bad = &bad[..cut.unwrap_or(bad.len())];
            let what = format!("{types} {size:?}, mutation {round}");
            let outcome =
                std::panic::catch_unwind(|| decode(bad, Path::new("t.exr"), &limits).map(|_| ()));
            match outcome {
                Err(_) => panic!("{what}: the PIZ decoder panicked"),
                Ok(Ok(())) => read_ok += 1,
                Ok(Err(e)) => {
                    let e = e.to_string();
                    assert!(e.contains("t.exr"), "{what}: {e}");
                    refused += 1;
                }
            }
        }
    }
    assert!(
        refused > 1000 && read_ok > 0,
        "{read_ok} read, {refused} refused"
    );
}
