//! The block-compressed and packed GPU formats (BC6H, BC7, E5B9G9R9, B10G11R11) and KTX2
//! Zstandard supercompression: quality on the real panoramas, round trips through `info` and
//! `convert`, independent readers (ktx-parse, nvddsinfo, texture2ddecoder, python zstandard),
//! padding of small mips, thread-count independence, clamping of negatives.

use crate::common;
use cubeforge::internals::convert;
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, dds, gpu, ktx2, Decoded, GpuFormat, Limits, ReadOptions};
use cubeforge::internals::resample::Resampler;
use glam::Vec4;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The formats this module covers (tests/it/containers.rs has the plain ones).
const NEW: [GpuFormat; 5] = [
    GpuFormat::Bc6h,
    GpuFormat::Bc7,
    GpuFormat::Bc7Srgb,
    GpuFormat::Rgb9e5,
    GpuFormat::Rg11b10,
];

/// BC6H against the uncompressed map, level 0 of a 256-face cube from each real panorama, by
/// [`gpu::psnr`] (RGB after v / (1 + v), peak 1). Measured: 45.1 (esplanade, the sun) to
/// 57.3 dB (studio). Bound: 42 dB.
pub const BC6H_PSNR_BOUND: f64 = 42.0;
/// Every box-mip level of the same cubes: tiny faces put a whole bright sky into one block.
/// Measured: at least 28.1 dB (esplanade, 4x4 faces). Bound: 25 dB.
pub const BC6H_MIP_PSNR_BOUND: f64 = 25.0;

fn cli(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::Output {
    common::run(args.iter().map(|a| a.as_ref()))
}

fn ok(out: &std::process::Output, what: &str) {
    assert!(out.status.success(), "{what}: {}", common::stderr(out));
}

fn cube_of(d: Decoded) -> CubeMap {
    match d {
        Decoded::Cube(c) => c,
        Decoded::Image(_) => panic!("expected a cube map"),
    }
}

fn decode(bytes: &[u8]) -> (Decoded, io::Meta) {
    let name = Path::new("t");
    if bytes.starts_with(b"DDS ") {
        dds::decode(bytes, name, &Limits::default()).unwrap()
    } else {
        ktx2::decode(bytes, name, &Limits::default()).unwrap()
    }
}

/// An 8-face HDR cube with detail in every block, values from 0.01 to 40, alpha 1.
fn test_cube(size: usize) -> CubeMap {
    CubeMap::from_fn(size, |d| {
        let v = |x: f32| 0.01 + 40.0 * x.max(0.0).powi(6);
        Vec4::new(
            v(d.x),
            v(d.y) + 0.2,
            v(d.z) + 0.1 * (d.x * 9.0).sin().abs(),
            1.0,
        )
    })
    .with_box_mips(None)
}

/// The real panoramas (.hdr), or none when the fixtures are absent.
pub(crate) fn panoramas() -> Vec<PathBuf> {
    let Some(real) = common::real_dir() else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(real.join("hdr"))
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    files.retain(|p| p.extension().is_some_and(|e| e == "hdr"));
    files.sort();
    files
}

#[test]
fn bc6h_keeps_real_panoramas_within_the_stated_psnr() {
    let mut cells = Vec::new();
    for pano in panoramas() {
        let loaded = convert::load(std::slice::from_ref(&pano), None, &ReadOptions::default())
            .expect("loads");
        let cube = convert::to_cube(&loaded, 256, &Resampler::default()).with_box_mips(None);
        for kind in ["ktx2", "dds"] {
            let bytes = match kind {
                "ktx2" => ktx2::encode(&cube, GpuFormat::Bc6h),
                _ => dds::encode(&cube, GpuFormat::Bc6h).unwrap(),
            };
            let back = cube_of(decode(&bytes).0);
            assert_eq!(back.levels.len(), cube.levels.len());
            let p = gpu::psnr(GpuFormat::Bc6h, &cube.levels[0], &back.levels[0]);
            println!("{} BC6H {kind}: {p:.2} dB", pano.display());
            if kind == "ktx2" {
                let light = |c: &CubeMap| {
                    let faces: Vec<&cubeforge::internals::image::Image> =
                        c.levels[0].iter().collect();
                    cubeforge::internals::flux::mean_radiance(
                        cubeforge::internals::flux::Grid::Cube(c.size()),
                        &faces,
                    )
                };
                let (a, b) = (light(&cube), light(&back));
                let off = (0..3)
                    .map(|c| (b[c] / a[c] - 1.0).abs())
                    .fold(0.0, f64::max);
                let name = pano.file_stem().unwrap_or_default().to_string_lossy();
                cells.push(format!("{p:.1} dB / {:.2}% ({name})", off * 100.0));
            }
            assert!(
                p >= BC6H_PSNR_BOUND,
                "{}: BC6H {p:.2} dB < {BC6H_PSNR_BOUND}",
                pano.display()
            );
            // The other levels (box means of level 0) hold as well.
            for l in 1..cube.levels.len() {
                let p = gpu::psnr(GpuFormat::Bc6h, &cube.levels[l], &back.levels[l]);
                assert!(p >= BC6H_MIP_PSNR_BOUND, "level {l}: {p:.2} dB");
            }
        }
    }
    if !cells.is_empty() {
        let text = format!("`bc6h` PSNR / light: {}", cells.join(", "));
        crate::figures::check("docs/formats.md", "bc6h real", &text);
    }
}

#[test]
fn every_new_format_round_trips_through_info_and_convert() {
    let Some(pano) = panoramas().into_iter().next() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // The uncompressed sibling each is compared with, and the least PSNR (measured on
    // esplanade's 64-face cube, read back as an EXR cross): BC7 against RGBA8 as stored, the
    // HDR formats after v / (1 + v).
    let cases = [
        (GpuFormat::Bc6h, "rgba32f", 38.0),       // 41.7 dB
        (GpuFormat::Bc7, "rgba8", 37.0),          // 40.5 dB
        (GpuFormat::Bc7Srgb, "rgba8-srgb", 38.0), // 41.9 dB
        (GpuFormat::Rgb9e5, "rgba32f", 65.0),     // 71.2 dB
        (GpuFormat::Rg11b10, "rgba32f", 60.0),    // 66.4 dB
    ];
    let mut figures = Vec::new();
    for (format, plain, bound) in cases {
        let flag = format!("{format:?}")
            .to_lowercase()
            .replace("srgb", "-srgb");
        for ext in ["ktx2", "dds"] {
            let out = dir.path().join(format!("{flag}.{ext}"));
            let reference = dir.path().join(format!("{flag}-ref.{ext}"));
            for (path, f) in [(&out, flag.as_str()), (&reference, plain)] {
                ok(
                    &cli(&[
                        &"convert",
                        &pano,
                        &"-o",
                        path,
                        &"--size",
                        &"64",
                        &"--gpu-format",
                        &f,
                    ]),
                    f,
                );
            }
            // info names the format and counts the levels.
            let o = cli(&[&"info", &"--json", &out]);
            ok(&o, "info");
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(v["pixel_format"], format.name(), "{v}");
            assert_eq!(v["mip_levels"], 7, "{v}");
            assert_eq!(v["face_size"], 64, "{v}");
            // convert reads it: to an EXR cross, compared with the uncompressed sibling's.
            let exr = |src: &Path, name: &str| {
                let e = dir.path().join(name);
                ok(
                    &cli(&[&"convert", &src, &"-o", &e, &"--to", &"hcross"]),
                    name,
                );
                common::read_image(&e)
            };
            let got = exr(&out, "got.exr");
            let want = exr(&reference, "want.exr");
            let p = gpu::psnr(format, [&want], [&got]);
            println!("{} {ext}: {p:.2} dB", format.name());
            if ext == "ktx2" {
                figures.push(format!("{} {p:.1} dB", format.name()));
            }
            assert!(p >= bound, "{} {ext}: {p:.2} dB < {bound}", format.name());
            // Container to container: read compressed, write compressed again.
            let again = dir.path().join(format!("again.{ext}"));
            ok(
                &cli(&[&"convert", &out, &"-o", &again, &"--gpu-format", &flag]),
                "again",
            );
            let o = cli(&[&"info", &"--json", &again]);
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
            assert_eq!(v["pixel_format"], format.name(), "{v}");
        }
    }
    let text = format!(
        "Through `convert` and back to EXR at 64 faces: {}",
        figures.join(", ")
    );
    crate::figures::check("docs/formats.md", "gpu round trips", &text);
}

/// Level sizes in whole 4x4 blocks: an 8x8 cube's 2x2 and 1x1 levels take a block per face.
#[test]
fn small_mips_take_whole_blocks() {
    let cube = test_cube(8);
    for format in [GpuFormat::Bc6h, GpuFormat::Bc7] {
        let k = ktx2::encode(&cube, format);
        for (l, want) in [(0, 6 * 4 * 16u64), (1, 6 * 16), (2, 6 * 16), (3, 6 * 16)] {
            let entry = 80 + 24 * l;
            let len = u64::from_le_bytes(k[entry + 8..entry + 16].try_into().unwrap());
            assert_eq!(len, want, "{format:?} level {l}");
        }
        let d = dds::encode(&cube, format).unwrap();
        assert_eq!(d.len() as u64, 148 + 6 * (4 + 1 + 1 + 1) * 16);
        // The small levels decode to their own size, close to what was written.
        for bytes in [k, d] {
            let back = cube_of(decode(&bytes).0);
            for l in 1..4 {
                assert_eq!(back.levels[l][0].width, 8 >> l);
                let p = gpu::psnr(format, &cube.levels[l], &back.levels[l]);
                assert!(p > 30.0, "{format:?} level {l}: {p:.1} dB");
            }
        }
    }
}

/// ktx-parse (independent) reads every new format, plain and Zstandard-supercompressed:
/// vkFormat, typeSize, scheme, level sizes (compressed and not), DFD, and writes it back to the
/// same bytes.
#[test]
fn ktx_parse_reads_new_formats_and_zstd() {
    let Some(tools) = common::ktx_parse() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let cube = test_cube(16);
    for format in NEW.into_iter().chain([GpuFormat::Rgba16f]) {
        for zstd in [None, Some(3), Some(19)] {
            let path = dir.path().join("t.ktx2");
            std::fs::write(
                &path,
                ktx2::encode_cube_with(&cube, format, zstd, &[]).unwrap(),
            )
            .unwrap();
            let v = common::ktx_check(&tools, &path, &format!("{format:?} {zstd:?}"));
            let (vk, type_size, model, bytes_plane, samples) = match format {
                GpuFormat::Bc6h => (143, 1, 133, 16, 1),
                GpuFormat::Bc7 => (145, 1, 134, 16, 1),
                GpuFormat::Bc7Srgb => (146, 1, 134, 16, 1),
                GpuFormat::Rgb9e5 => (123, 4, 1, 4, 6),
                GpuFormat::Rg11b10 => (122, 4, 1, 4, 3),
                _ => (97, 2, 1, 8, 4),
            };
            assert_eq!(v["vkFormat"], vk, "{v}");
            assert_eq!(v["typeSize"], type_size, "{v}");
            assert_eq!(
                v["supercompressionScheme"],
                if zstd.is_some() { 2 } else { 0 }
            );
            assert_eq!(v["dfd"]["colorModel"], model, "{v}");
            // The DFD is the plain format's, supercompressed or not.
            assert_eq!(v["dfd"]["bytesPlane0"], bytes_plane, "{v}");
            assert_eq!(
                v["dfd"]["samples"].as_array().unwrap().len(),
                samples,
                "{v}"
            );
            assert_eq!(
                v["dfd"]["transferFunction"],
                if format.is_srgb() { 2 } else { 1 }
            );
            let plain: Vec<u64> = (0..5)
                .map(|l| 6 * format.image_bytes(16 >> l, 16 >> l).unwrap())
                .collect();
            assert_eq!(v["uncompressedLevels"], serde_json::json!(plain), "{v}");
            if zstd.is_none() {
                assert_eq!(v["levels"], serde_json::json!(plain), "{v}");
            }
            assert_eq!(v["rewriteIdentical"], true, "{format:?} {zstd:?}: {v}");
        }
    }
}

/// NVIDIA's DDS parser names the DXGI format of each new DDS output (it has no names for the
/// BC6H/BC7 codes but prints the numbers).
#[test]
fn nvddsinfo_reads_new_dxgi_formats() {
    if !common::nvddsinfo() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cube = test_cube(8);
    for (format, dxgi) in [
        (GpuFormat::Bc6h, "DXGI Format: 95"),
        (GpuFormat::Bc7, "DXGI Format: 98"),
        (GpuFormat::Bc7Srgb, "DXGI Format: 99"),
        (GpuFormat::Rgb9e5, "DXGI Format: 67 (R9G9B9E5_SHAREDEXP)"),
        (GpuFormat::Rg11b10, "DXGI Format: 26 (R11G11B10_FLOAT)"),
    ] {
        let path = dir.path().join("t.dds");
        std::fs::write(&path, dds::encode(&cube, format).unwrap()).unwrap();
        let out = Command::new("nvddsinfo").arg(&path).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{format:?}: {text}");
        for want in [dxgi, "Mipmap count: 4", "DDSCAPS2_CUBEMAP_ALL_FACES"] {
            assert!(text.contains(want), "{format:?}: no {want:?} in {text}");
        }
    }
}

/// texture2ddecoder (Perfare's C++ decoders, independent of bcdec_rs) decodes our BC6H and
/// BC7 blocks to the same texels: it gives 8-bit BGRA, so ours are compared clamped and
/// rounded (BC6H within 1 step: its half-to-8-bit conversion rounds its own way).
#[test]
fn texture2ddecoder_agrees_with_our_block_decoding() {
    if !common::texture2ddecoder() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Values within [0, 1] so 8 bits can tell.
    let cube = CubeMap::from_fn(16, |d| {
        Vec4::new(
            d.x * 0.5 + 0.5,
            d.y * 0.4 + 0.5,
            (d.z * 7.0).sin() * 0.5 + 0.5,
            1.0,
        )
    });
    let script = "import sys, json, texture2ddecoder as t\n\
                  data = open(sys.argv[1], 'rb').read()\n\
                  f = t.decode_bc6 if sys.argv[2] == 'bc6' else t.decode_bc7\n\
                  print(json.dumps(list(f(data, 16, 16))))";
    for format in [GpuFormat::Bc6h, GpuFormat::Bc7, GpuFormat::Bc7Srgb] {
        let face = &cube.levels[0][0];
        let blocks = format.encode_image(face).unwrap();
        let path = dir.path().join("blocks.bin");
        std::fs::write(&path, &blocks).unwrap();
        let kind = if format == GpuFormat::Bc6h {
            "bc6"
        } else {
            "bc7"
        };
        let out = Command::new("python3")
            .args(["-c", script])
            .arg(&path)
            .arg(kind)
            .output()
            .expect("run python3");
        assert!(
            out.status.success(),
            "texture2ddecoder: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let theirs: Vec<u8> = serde_json::from_slice::<Vec<u64>>(&out.stdout)
            .unwrap()
            .into_iter()
            .map(|v| v as u8)
            .collect();
        let ours = format.decode_image(&blocks, 16, 16).unwrap();
        let tolerance = if format == GpuFormat::Bc6h { 1 } else { 0 };
        for (i, (p, t)) in ours.pixels.iter().zip(theirs.chunks_exact(4)).enumerate() {
            let stored = |v: f32| {
                let v = if format.is_srgb() {
                    cubeforge::internals::image::linear_to_srgb(v)
                } else {
                    v
                };
                io::unorm8(v) as i32
            };
            // BGRA from them; alpha only where the format has it.
            let pairs = [(p.x, t[2]), (p.y, t[1]), (p.z, t[0])];
            for (c, (v, b)) in pairs.into_iter().enumerate() {
                let d = (stored(v) - b as i32).abs();
                assert!(
                    d <= tolerance,
                    "{format:?} texel {i} channel {c}: ours {v} theirs {b}"
                );
            }
        }
    }
}

/// Every Zstandard level inflates with python's zstandard (the reference libzstd, not the
/// crate we compress with) to exactly the plain file's level.
#[test]
fn zstd_levels_inflate_with_an_independent_tool() {
    if !common::zstandard() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cube = test_cube(16);
    let plain = ktx2::encode_cube_with(&cube, GpuFormat::Bc6h, None, &[]).unwrap();
    let packed = ktx2::encode_cube_with(&cube, GpuFormat::Bc6h, Some(19), &[]).unwrap();
    assert!(packed.len() < plain.len());
    let path = dir.path().join("z.ktx2");
    std::fs::write(&path, &packed).unwrap();
    // Prints, level by level, the inflated bytes' hex.
    let script = "import sys, struct, json, zstandard\n\
                  b = open(sys.argv[1], 'rb').read()\n\
                  n = struct.unpack_from('<I', b, 40)[0]\n\
                  out = []\n\
                  for l in range(n):\n\
                  \x20   off, ln, un = struct.unpack_from('<QQQ', b, 80 + 24 * l)\n\
                  \x20   d = zstandard.ZstdDecompressor().decompress(b[off:off + ln], max_output_size=un)\n\
                  \x20   assert len(d) == un\n\
                  \x20   out.append(d.hex())\n\
                  print(json.dumps(out))";
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(&path)
        .output()
        .expect("run python3");
    assert!(
        out.status.success(),
        "zstandard: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let levels: Vec<String> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(levels.len(), 5);
    for (l, hex) in levels.iter().enumerate() {
        let entry = 80 + 24 * l;
        let field =
            |o: usize| u64::from_le_bytes(plain[entry + o..entry + o + 8].try_into().unwrap());
        let (off, len) = (field(0) as usize, field(8) as usize);
        let want: String = plain[off..off + len]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(hex, &want, "level {l}");
    }
    // And our reader reads both to the same texels.
    let a = cube_of(decode(&plain).0);
    let b = cube_of(decode(&packed).0);
    assert_eq!(a.levels[0][3].pixels, b.levels[0][3].pixels);
}

/// The same bytes on 1 and 3 threads, for every new format, KTX2 (with zstd) and DDS.
#[test]
fn outputs_do_not_depend_on_thread_count() {
    let cube = test_cube(32);
    let run = |threads: usize, format: GpuFormat| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                (
                    ktx2::encode_cube_with(&cube, format, Some(9), &[]).unwrap(),
                    dds::encode(&cube, format).unwrap(),
                )
            })
    };
    for format in NEW {
        assert!(run(1, format) == run(3, format), "{format:?}");
    }
}

/// Unsigned formats clamp negatives to 0 (and NaN), counted by the clamp warning over the RGB
/// they store; values above the largest are counted too.
#[test]
fn unsigned_formats_clamp_negatives_with_a_counted_warning() {
    let img = Image {
        width: 4,
        height: 4,
        pixels: (0..16)
            .map(|i| match i {
                0 => Vec4::new(-1.0, 0.5, 0.5, -1.0), // 1 (alpha not stored)
                1 => Vec4::new(f32::NAN, -0.1, 0.5, 1.0), // 2
                2 => Vec4::new(1e6, 0.5, 0.5, 1.0),   // 1
                _ => Vec4::new(0.5, 0.25, 0.125, 1.0),
            })
            .collect(),
    };
    for format in [GpuFormat::Bc6h, GpuFormat::Rgb9e5, GpuFormat::Rg11b10] {
        let w = io::clamp_warning(Path::new("o.ktx2"), io::FileFormat::Ktx2, format, [&img])
            .expect("a warning");
        assert!(w.starts_with("o.ktx2: 4 values negative or beyond"), "{w}");
        assert!(w.contains(format.name()), "{w}");
        let back = format
            .decode_image(&format.encode_image(&img).unwrap(), 4, 4)
            .unwrap();
        for p in &back.pixels {
            assert!(p.is_finite() && p.min_element() >= 0.0, "{format:?}: {p}");
        }
        assert_eq!(back.pixels[0].x, 0.0, "{format:?}");
    }
    // Plain half floats count only magnitudes beyond 65504 and NaN, as before.
    let w = io::clamp_warning(
        Path::new("o.ktx2"),
        io::FileFormat::Ktx2,
        GpuFormat::Rgba16f,
        [&img],
    )
    .unwrap();
    assert!(w.starts_with("o.ktx2: 2 values beyond 65504"), "{w}");
}

#[test]
fn zstd_is_refused_for_dds_and_damaged_levels_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("in.exr");
    common::write_image(
        &src,
        &Image {
            width: 32,
            height: 16,
            pixels: vec![Vec4::new(0.5, 0.4, 0.3, 1.0); 512],
        },
    );
    let dds = dir.path().join("o.dds");
    let o = cli(&[&"convert", &src, &"-o", &dds, &"--zstd"]);
    assert!(!o.status.success());
    assert!(
        common::stderr(&o).contains("--zstd supercompresses KTX2 only"),
        "{}",
        common::stderr(&o)
    );
    assert!(!dds.exists());
    let o = cli(&[
        &"prefilter",
        &src,
        &"-o",
        &dds,
        &"--filter",
        &"box",
        &"--zstd=3",
    ]);
    assert!(common::stderr(&o).contains("--zstd supercompresses KTX2 only"));

    // A KTX2 whose zstd level is damaged, or whose uncompressed length lies.
    let good = ktx2::encode_cube_with(&test_cube(8), GpuFormat::Bc7, Some(5), &[]).unwrap();
    let off = u64::from_le_bytes(good[80..88].try_into().unwrap()) as usize;
    let mut bad = good.clone();
    for b in &mut bad[off..off + 8] {
        *b ^= 0xA5;
    }
    let name = Path::new("bad.ktx2");
    let e = ktx2::decode(&bad, name, &Limits::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.ktx2") && e.contains("Zstandard"), "{e}");
    let mut bad = good.clone();
    bad[96..104].copy_from_slice(&12345u64.to_le_bytes());
    let e = ktx2::decode(&bad, name, &Limits::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("level 0 claims"), "{e}");
}

/// A control map in BC7 with Zstandard: written, described by `info`, read by `convert`.
#[test]
fn control_maps_in_bc7_with_zstd() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("c.toml");
    std::fs::write(
        &recipe,
        "size = \"64x32\"\nmax_lod_bias = 6\nreflectivity = 0.9\ntransmittance = 0.25\nfresnel = 1\n\
         [blur]\nlinear_gradient = { from = [0, 0], to = [1, 0] }\n",
    )
    .unwrap();
    let out = dir.path().join("m.ktx2");
    let o = cli(&[
        &"-v",
        &"control",
        &recipe,
        &"-o",
        &out,
        &"--gpu-format",
        &"bc7",
        &"--zstd=9",
    ]);
    ok(&o, "control");
    let err = common::stderr(&o);
    assert!(err.contains("BC7 UNORM quality: PSNR"), "{err}");
    let o = cli(&[&"info", &"--json", &out]);
    ok(&o, "info");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        v["pixel_format"], "BC7 UNORM, Zstandard supercompressed",
        "{v}"
    );
    assert_eq!(v["mip_levels"], 7, "{v}");
    let (decoded, _) = cubeforge::internals::convert::read(&out, &ReadOptions::default()).unwrap();
    let Decoded::Image(img) = decoded else {
        panic!("a 2D texture reads as an image")
    };
    assert_eq!((img.width, img.height), (64, 32));
    // Reflectivity 0.9 and transmittance 0.25 survive BC7 within 1/255.
    let mean = img.pixels.iter().copied().sum::<Vec4>() / img.pixels.len() as f32;
    assert!((mean.x - 0.9).abs() < 1.5 / 255.0, "{mean}");
    assert!((mean.y - 0.25).abs() < 1.5 / 255.0, "{mean}");
}
