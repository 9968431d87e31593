//! Tests of the fast paths against their plain definitions: run finding, texels, line forms,
//! run-length slots and shared exponents.

use super::runs::{equal_bytes, next_run, run_length};
use super::texels::texel;
use super::write::to_rgbe;
use super::*;
use glam::Vec4;

/// Runs and their lengths found sixteen bytes at a time are the plain loops': every start
/// and end of lines of runs and literals of many lengths.
#[test]
fn runs_found_at_once_match_the_plain_scan() {
    let mut data = Vec::new();
    for k in 0..300usize {
        let len = 1 + (k * 37) % 41;
        let v = (k % 7) as u8;
        data.extend(std::iter::repeat_n(v, len));
        data.extend((0..k % 5).map(|i| (100 + i) as u8));
    }
    let n = data.len();
    for from in 0..n {
        let plain =
            (from..n.saturating_sub(3)).find(|&p| data[p + 1..p + 4].iter().all(|&v| v == data[p]));
        assert_eq!(next_run(&data, from), plain, "from {from}");
        for end in [from + 1, (from + 127).min(n), n] {
            let count = data[from..end]
                .iter()
                .take_while(|&&v| v == data[from])
                .count();
            assert_eq!(equal_bytes(&data, from, end), count, "{from}..{end}");
        }
    }
}

/// The four-at-a-time texels are `texel`'s, bit for bit: every exponent, mantissas
/// from 0 to 255, a line whose width is not a multiple of four.
#[test]
fn texels_match_texel() {
    let w = 256 * 3 + 5;
    let plane = |k: usize| -> Vec<u8> {
        (0..w)
            .map(|x| ((x * (7 + 2 * k) + k) % 256) as u8)
            .collect()
    };
    let (r, g, b) = (plane(0), plane(1), plane(2));
    let e: Vec<u8> = (0..w).map(|x| (x % 256) as u8).collect();
    let mut row = vec![Vec4::ZERO; w];
    texels(&r, &g, &b, &e, &mut row);
    for x in 0..w {
        let want = texel([r[x], g[x], b[x], e[x]]);
        assert_eq!(
            row[x].to_array().map(f32::to_bits),
            want.to_array().map(f32::to_bits),
            "texel {x}"
        );
    }
}

/// Every line form decodes into the planes as it should: old-style flat texels and
/// (1, 1, 1, n) repeats, and run-length lines of literals and runs (round trip).
#[test]
fn every_line_form_decodes() {
    let t = [
        [10u8, 20, 30, 129],
        [40, 50, 60, 130],
        [70, 80, 90, 128],
        [1, 2, 3, 140],
    ];
    let mut file = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 5\n".to_vec();
    // Line 0 flat; line 1: one texel, three repeats of it, then another.
    for k in [0, 1, 2, 3, 0] {
        file.extend_from_slice(&t[k]);
    }
    file.extend_from_slice(&t[1]);
    file.extend_from_slice(&[1, 1, 1, 3]);
    file.extend_from_slice(&t[3]);
    let opts = crate::io::ReadOptions::default();
    let (img, _) = decode(&file, Path::new("old.hdr"), &opts).unwrap().unwrap();
    let want = [0, 1, 2, 3, 0, 1, 1, 1, 1, 3].map(|k| texel(t[k]));
    assert_eq!(img.pixels, want);
    // Run-length lines: literals and runs in every channel.
    let src = Image::from_fn(40, 3, |x, y| {
        let v = if x % 10 < 5 {
            1.5
        } else {
            (x * 7 + y) as f32 * 0.25
        };
        Vec4::new(v, 2.0 * v, 0.5, 1.0)
    });
    let file = encode(&src);
    let (img, _) = decode(&file, Path::new("rle.hdr"), &opts).unwrap().unwrap();
    for (a, b) in img.pixels.iter().zip(&src.pixels) {
        assert!(
            (*a - *b).abs().max_element() <= b.max_element() / 128.0,
            "{a} vs {b}"
        );
    }
}

/// No channel's run-length form is longer than the slot `encode` gives it: its bytes, a
/// count per 128 literals and one more, for the shapes that cost most (literals cut by
/// short runs, runs just too short, runs cut at 127) and for noise.
#[test]
fn run_length_fits_its_slot() {
    let mut seed = 12345u32;
    let mut noise = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 24) as u8
    };
    for w in [8usize, 9, 127, 128, 129, 255, 256, 1000, 1024, 4097] {
        let shapes: Vec<Vec<u8>> = vec![
            (0..w).map(|i| if i % 5 == 4 { 1 } else { 0 }).collect(),
            (0..w).map(|i| (i / 3) as u8).collect(),
            (0..w)
                .map(|i| if i % 6 < 4 { 7 } else { i as u8 })
                .collect(),
            (0..w)
                .map(|i| if i % 132 < 128 { 9 } else { (i % 256) as u8 })
                .collect(),
            (0..w).map(|i| i as u8).collect(),
            vec![3; w],
            (0..w).map(|_| noise() & 3).collect(),
            (0..w).map(|_| noise()).collect(),
        ];
        for data in shapes {
            let mut out = Vec::new();
            run_length(&data, &mut out);
            assert!(out.len() <= w + w.div_ceil(128) + 1, "{w}: {}", out.len());
        }
    }
}

/// The shared exponent the plain way: frexp, then a multiply in f64 and rounding (one
/// exponent higher where the largest channel would round to 256).
fn reference(p: Vec4) -> [u8; 4] {
    let [r, g, b] = [p.x, p.y, p.z].map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
    let max = r.max(g).max(b);
    if max < f32::MIN_POSITIVE {
        return [0; 4];
    }
    if max >= 1.7e38 {
        return [255; 4];
    }
    let mut e = (max as f64).log2().floor() as i32 + 1;
    if (max as f64 * 2f64.powi(8 - e) + 0.5).floor() >= 256.0 {
        e += 1;
    }
    if e + 128 > 255 {
        return [255; 4];
    }
    let scale = 2f64.powi(8 - e);
    let q = |v: f32| (v as f64 * scale + 0.5).floor() as u8;
    [q(r), q(g), q(b), (e + 128) as u8]
}

/// The run-length form by its definition: the first run of four or more, greedily.
fn naive(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < data.len() {
        let run = (i..data.len())
            .find(|&p| p + 4 <= data.len() && data[p..p + 4].iter().all(|&v| v == data[p]))
            .unwrap_or(data.len());
        for chunk in data[i..run].chunks(128) {
            out.push(chunk.len() as u8);
            out.extend_from_slice(chunk);
        }
        i = run;
        if run < data.len() {
            let len = data[run..]
                .iter()
                .take(127)
                .take_while(|&&v| v == data[run])
                .count();
            out.extend_from_slice(&[128 + len as u8, data[run]]);
            i += len;
        }
    }
    out
}

#[test]
fn shared_exponents_match_the_plain_formula() {
    // Every binade, subnormals, exact powers of two, channels far apart, specials.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let specials = [
        0.0,
        -1.0,
        f32::NAN,
        f32::INFINITY,
        f32::MIN_POSITIVE,
        1e-40,
        0.5,
        1.0,
        255.0 / 256.0,
        255.75 / 256.0,
        1.6985e38,
        1.7e38,
        f32::MAX,
    ];
    for i in 0..200_000 {
        let mut v = [0.0f32; 3];
        for c in &mut v {
            let bits = next();
            *c = if bits % 7 == 0 {
                specials[(bits >> 8) as usize % specials.len()]
            } else {
                f32::from_bits((bits >> 32) as u32 & 0x7fff_ffff)
            };
        }
        let p = Vec4::new(v[0], v[1], v[2], 1.0);
        assert_eq!(to_rgbe(p), reference(p), "{i}: {p}");
    }
}

#[test]
fn runs_are_coded_as_the_definition_says() {
    let mut state = 7u32;
    for len in [
        0, 1, 3, 4, 5, 8, 9, 15, 16, 17, 100, 127, 128, 129, 300, 1024,
    ] {
        for density in [2u32, 4, 16, 256] {
            // Few distinct values make runs of every length, up to past 127.
            let data: Vec<u8> = (0..len)
                .map(|_| {
                    state = state.wrapping_mul(1_103_515_245).wrapping_add(12345);
                    let v = (state >> 16) % density;
                    if v < density / 2 {
                        0
                    } else {
                        v as u8
                    }
                })
                .collect();
            let mut out = Vec::new();
            run_length(&data, &mut out);
            assert_eq!(out, naive(&data), "length {len}, {density} values");
        }
    }
    let long = vec![9u8; 300];
    let mut out = Vec::new();
    run_length(&long, &mut out);
    assert_eq!(out, [255, 9, 255, 9, 128 + 46, 9]);
}
