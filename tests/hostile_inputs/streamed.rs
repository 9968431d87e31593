//! The streamed paths (issue 47): an OpenEXR or Radiance .hdr panorama decoded in bands and
//! folded as it is read (`info`'s statistics, `ibl`'s reduced copy), under the same mutations
//! as the whole reads, plus headers that claim a 16K panorama over the small file's body and
//! cuts at every header boundary. Each mutated panorama goes through `info::describe` (every
//! size streamed: `CUBEFORGE_STREAM_TEXELS=0`), `ibl --target bevy --size 8` (a 256 x 128
//! panorama reduced by 2 as it is decoded) and `prefilter` (the whole read), with a small
//! budget: a one-line error naming the file, or outputs whose every value is finite; a
//! refused job leaves no output behind. UltraHDR's campaign (cubeforge's own file and the
//! real fixtures) goes through the front door of images.

use crate::harness::{self, campaign, check, image_door, real_files, test_image};
use crate::images::jpeg_fields;
use crate::mutator::{Field, Mutator};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{Decoded, Limits, ReadOptions, WriteOptions};
use cubeforge::{Destination, Engine, IblJob, IblOptions, Job, PrefilterJob};
use exr::prelude::*;
use std::io::Cursor;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Streams `info` of any size, as the tests of `info::stream` do; set once, before any read
/// here (no other test of this binary reads a file that streams).
fn stream_every_size() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| std::env::set_var("CUBEFORGE_STREAM_TEXELS", "0"));
}

/// The budget of the streamed doors: the default sizes (a claimed 16K panorama passes them,
/// so the bands are what must stop it), memory enough for a 16K panorama's bands and its
/// reduced copy (`ibl`'s plan: 129 MiB on 2 threads), not for one read whole (2 GiB).
fn limits() -> Limits {
    Limits {
        max_memory: 192 << 20,
        ..Limits::default()
    }
}

fn read_options() -> ReadOptions {
    ReadOptions {
        limits: limits(),
        ..ReadOptions::default()
    }
}

/// A 256 x 128 panorama with a sun: the reduction's second pass (the peaks) runs too.
pub fn panorama() -> Image {
    let mut img = test_image(256, 128);
    for y in 30..33 {
        for x in 100..103 {
            img.set(x, y, glam::Vec4::new(4000.0, 3500.0, 3000.0, 1.0));
        }
    }
    img
}

/// A file the exr crate writes: the panorama as RGBA halves in `compression`.
pub fn exr_written(compression: Compression) -> Vec<u8> {
    let img = panorama();
    let layer = Layer::new(
        (img.width, img.height),
        LayerAttributes::default(),
        exr::image::Encoding {
            compression,
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        },
        SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
            let p = img.get(x, y);
            (
                f16::from_f32(p.x),
                f16::from_f32(p.y),
                f16::from_f32(p.z),
                f16::from_f32(p.w),
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

/// Where an OpenEXR attribute's value starts (`name\0type\0size` before it), if present.
pub fn attribute(b: &[u8], name: &str) -> Option<usize> {
    let key = format!("{name}\0");
    let at = b.windows(key.len()).position(|w| w == key.as_bytes())?;
    let ty = at + key.len();
    let end = ty + b[ty..].iter().position(|&c| c == 0)?;
    Some(end + 1 + 4)
}

/// The end of an OpenEXR header (its null byte) and where the offset table starts.
pub fn exr_table(b: &[u8]) -> Option<usize> {
    let mut at = 8;
    while *b.get(at)? != 0 {
        let name_end = at + b[at..].iter().position(|&c| c == 0)?;
        let ty_end = name_end + 1 + b[name_end + 1..].iter().position(|&c| c == 0)?;
        let size = u32::from_le_bytes(b.get(ty_end + 1..ty_end + 5)?.try_into().ok()?);
        at = ty_end + 5 + size as usize;
    }
    Some(at + 1)
}

/// OpenEXR: the data and display windows' corners, the first offsets of the table, and the
/// first chunk's row and byte count.
pub fn exr_fields(b: &[u8]) -> Vec<Field> {
    let mut f = Vec::new();
    for name in ["dataWindow", "displayWindow"] {
        if let Some(at) = attribute(b, name) {
            f.extend((0..4).map(|i| Field::le(at + 4 * i, 4)));
        }
    }
    if let Some(table) = exr_table(b) {
        f.extend((0..4).map(|i| Field::le(table + 8 * i, 8)));
        if let Some(first) = b.get(table..table + 8) {
            let first = u64::from_le_bytes(first.try_into().unwrap()) as usize;
            f.extend([Field::le(first, 4), Field::le(first + 4, 4)]);
        }
    }
    f
}

/// The header boundaries of a file: every attribute's end (OpenEXR) or line (.hdr), and the
/// table's and first scanline's.
fn boundaries(b: &[u8]) -> Vec<usize> {
    let mut cuts = vec![0, 1, 4, 8];
    if b.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        let mut at = 8;
        while at < b.len() && b[at] != 0 {
            let Some(n) = b[at..].iter().position(|&c| c == 0) else {
                break;
            };
            let ty = at + n + 1;
            let Some(t) = b[ty..].iter().position(|&c| c == 0) else {
                break;
            };
            cuts.extend([at + n, ty + t + 1, ty + t + 5]);
            let size = u32::from_le_bytes(b[ty + t + 1..ty + t + 5].try_into().unwrap());
            at = ty + t + 5 + size as usize;
            cuts.push(at);
        }
        if let Some(table) = exr_table(b) {
            cuts.extend([table, table + 4, table + 8, table + 16]);
            let first = u64::from_le_bytes(b[table..table + 8].try_into().unwrap()) as usize;
            cuts.extend([first, first + 4, first + 8, first + 9, first + 100]);
        }
    } else {
        cuts.extend(
            b.iter()
                .enumerate()
                .take(256)
                .filter(|(_, &c)| c == b'\n')
                .flat_map(|(i, _)| [i, i + 1, i + 3, i + 5]),
        );
    }
    cuts.extend([b.len() / 2, b.len() - 1]);
    cuts.retain(|&c| c < b.len());
    cuts.sort();
    cuts.dedup();
    cuts
}

/// The same bytes with the header claiming `w` x `h` texels: OpenEXR's data and display
/// windows, or the .hdr's resolution line.
fn claiming(b: &[u8], w: i64, h: i64) -> Vec<u8> {
    let mut out = b.to_vec();
    if b.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        for name in ["dataWindow", "displayWindow"] {
            if let Some(at) = attribute(b, name) {
                for (i, v) in [0, 0, w - 1, h - 1].into_iter().enumerate() {
                    out[at + 4 * i..at + 4 * i + 4].copy_from_slice(&(v as i32).to_le_bytes());
                }
            }
        }
        return out;
    }
    let line = b.windows(4).position(|w| w == b"\n-Y ").unwrap() + 1;
    let end = line + b[line..].iter().position(|&c| c == b'\n').unwrap();
    out.splice(line..end, format!("-Y {h} +X {w}").into_bytes());
    out
}

/// The claims: a 16K panorama and others over the small body, sizes at the edges of
/// the fields and of the limits, negative and empty windows.
fn claims(b: &[u8]) -> Vec<(String, Vec<u8>)> {
    let sizes: &[(i64, i64)] = &[
        (16384, 8192),
        (8192, 4096),
        (2048, 1024),
        (512, 256),
        (258, 128),
        (256, 129),
        (256, 127),
        (254, 128),
        (2, 1),
        (1, 1),
        (0, 0),
        (-256, 128),
        (256, -128),
        (1 << 31, 2),
        (65536, 32768),
        (i32::MAX as i64, i32::MAX as i64),
        (32768, 16384),
    ];
    sizes
        .iter()
        .map(|&(w, h)| (format!("claiming {w} x {h}"), claiming(b, w, h)))
        .collect()
}

/// The outputs written, all of whose values must be finite.
fn check_finite(files: &[PathBuf], what: &dyn Fn() -> String) {
    let opts = ReadOptions {
        as_stored: true,
        ..ReadOptions::default()
    };
    for f in files {
        let Ok((decoded, _)) = cubeforge::internals::convert::read(f, &opts) else {
            continue; // not an image (a snippet, a sidecar)
        };
        let finite = |img: &Image| img.pixels.iter().all(|p| p.is_finite());
        let ok = match decoded {
            Decoded::Image(img) => finite(&img),
            Decoded::Cube(c) => c.levels.iter().flatten().all(finite),
        };
        assert!(
            ok,
            "{}: {} holds a value that is not finite",
            what(),
            f.display()
        );
    }
}

/// A job's outcome checked beyond [`check`]: a refused job leaves nothing at `out`, a
/// finished one only finite values.
fn job_outcome(
    result: cubeforge::Result<Vec<PathBuf>>,
    out: &Path,
    what: &dyn Fn() -> String,
) -> cubeforge::Result<()> {
    match result {
        Ok(written) => {
            check_finite(&written, what);
            Ok(())
        }
        Err(e) => {
            let left =
                out.exists() && (!out.is_dir() || std::fs::read_dir(out).unwrap().next().is_some());
            assert!(
                !left,
                "{}: refused ({e}) but left {}",
                what(),
                out.display()
            );
            Err(e)
        }
    }
}

/// The streamed front door: `info` (streamed), `ibl --target bevy --size 8` (reduced as it is
/// decoded) and, with `whole`, `prefilter` (the whole read) of the bytes written as
/// `dir/name`.
pub fn streamed_door(
    dir: &Path,
    name: &str,
    whole: bool,
) -> impl Fn(&[u8]) -> cubeforge::Result<()> {
    stream_every_size();
    let path = dir.join(name);
    let ibl_out = dir.join("ibl");
    let ktx2 = dir.join("chain.ktx2");
    let name = name.to_string();
    move |bytes| {
        let _ = std::fs::remove_dir_all(&ibl_out);
        let _ = std::fs::remove_file(&ktx2);
        std::fs::write(&path, bytes).unwrap();
        let what = || format!("{name} ({} bytes)", bytes.len());
        let read = read_options();
        let info = cubeforge::internals::info::describe(&path, None, &read).map(|_| ());
        let mut ibl = IblJob::new(vec![path.clone()], ibl_out.clone(), Engine::Bevy);
        ibl.options = IblOptions {
            specular_size: Some(8),
            samples: Some(4),
            ..IblOptions::default()
        };
        ibl.read = read;
        let ibl = job_outcome(ibl.run(&()).map(|r| r.written), &ibl_out, &what);
        let mut pre = PrefilterJob::new(vec![path.clone()], Destination::Path(ktx2.clone()));
        pre.size = Some(8);
        pre.read = read;
        let pre = match whole {
            true => job_outcome(pre.run(&()).map(|r| r.written), &ktx2, &what),
            false => Ok(()),
        };
        // Each must name the file on its own; the first refusal is the door's.
        for r in [&info, &ibl, &pre] {
            if let Err(e) = r {
                let e = e.to_string();
                assert!(e.contains(&name) && !e.contains('\n'), "{}: {e}", what());
            }
        }
        info.and(ibl).and(pre)
    }
}

/// Runs `door` on each of `files`, as [`campaign`] runs its mutations.
fn each(
    what: &str,
    files: Vec<(String, Vec<u8>)>,
    name: &str,
    door: &dyn Fn(&[u8]) -> cubeforge::Result<()>,
) {
    let (mut read, mut refused) = (0, 0);
    for (label, b) in files {
        let outcome = catch_unwind(AssertUnwindSafe(|| door(&b)));
        match check(outcome, name, false, &|| format!("{what}, {label}")) {
            None => read += 1,
            Some(e) => {
                refused += 1;
                if harness::verbose() {
                    println!("{what}, {label}: {e}");
                }
            }
        }
    }
    println!("{what}: {read} read, {refused} refused");
}

/// Claims and cuts of one source, then its mutations.
fn streamed_campaign(
    what: &str,
    src: &[u8],
    ext: &str,
    fields: Vec<Field>,
    seed: u64,
    rounds: usize,
) {
    let dir = tempfile::tempdir().unwrap();
    let name = format!("pano.{ext}");
    let door = streamed_door(dir.path(), &name, true);
    door(src).unwrap_or_else(|e| panic!("{what}: the valid file: {e}"));
    let cuts = boundaries(src)
        .into_iter()
        .map(|at| (format!("cut at {at}"), src[..at].to_vec()))
        .collect();
    each(&format!("{what}, cut"), cuts, &name, &door);
    let mut claimed = claims(src);
    // A claimed 16K panorama cut at each header boundary as well.
    let big = claiming(src, 16384, 8192);
    claimed.extend(
        boundaries(&big)
            .into_iter()
            .map(|at| (format!("claiming 16K, cut at {at}"), big[..at].to_vec())),
    );
    each(&format!("{what}, claims"), claimed, &name, &door);
    let mutator = Mutator::new(seed, fields, false);
    campaign(what, src, mutator, rounds, &name, &door);
}

#[test]
fn streamed_exr_mutations() {
    let compressions = [
        ("ZIP", Compression::ZIP16),
        ("ZIPS", Compression::ZIP1),
        ("PIZ", Compression::PIZ),
        ("RLE", Compression::RLE),
        ("none", Compression::Uncompressed),
        ("PXR24", Compression::PXR24),
        ("B44", Compression::B44),
    ];
    for (i, (label, c)) in compressions.into_iter().enumerate() {
        let b = exr_written(c);
        let fields = exr_fields(&b);
        let seed = 0x51a7_e3d0_11c4_0001 ^ (i as u64) << 40;
        streamed_campaign(
            &format!("streamed EXR {label}"),
            &b,
            "exr",
            fields,
            seed,
            12,
        );
    }
    // cubeforge's own EXR (half ZIP), as `convert` writes it.
    let b = harness::encoded("x.exr", &panorama(), &WriteOptions::default());
    streamed_campaign(
        "streamed EXR (cubeforge's)",
        &b,
        "exr",
        exr_fields(&b),
        0x77e1,
        12,
    );
}

#[test]
fn streamed_hdr_mutations() {
    let b = harness::encoded("x.hdr", &panorama(), &WriteOptions::default());
    let fields = crate::images::hdr_fields(&b);
    streamed_campaign("streamed HDR", &b, "hdr", fields, 0x3c6e_f372_fe94_f82b, 24);
}

/// UltraHDR: cubeforge's own (three.js's reader, its comment mark) and the real fixtures, through
/// the image door (`convert::read`).
#[test]
fn ultrahdr_mutations() {
    let dir = tempfile::tempdir().unwrap();
    let name = "mutated.jpg";
    let door = image_door(dir.path(), name);
    let mut sources: Vec<(String, Vec<u8>)> = Vec::new();
    // cubeforge's own, from a small panorama.
    let src = dir.path().join("src.exr");
    std::fs::write(
        &src,
        harness::encoded("x.exr", &panorama(), &WriteOptions::default()),
    )
    .unwrap();
    let out = dir.path().join("own.jpg");
    let job = cubeforge::ConvertJob {
        encoding: cubeforge::Encoding {
            ultrahdr: true,
            ..Default::default()
        },
        ..cubeforge::ConvertJob::new(vec![src], Destination::Path(out.clone()))
    };
    job.run(&()).unwrap();
    sources.push((
        "UltraHDR (cubeforge's)".to_string(),
        std::fs::read(&out).unwrap(),
    ));
    for path in real_files("ultrahdr", "jpg") {
        sources.push((path.display().to_string(), std::fs::read(&path).unwrap()));
    }
    for (i, (what, b)) in sources.into_iter().enumerate() {
        door(&b).unwrap_or_else(|e| panic!("{what}: the valid file: {e}"));
        let mutator = Mutator::new(0x6a09_e667_f3bc_c908 ^ i as u64, jpeg_fields(&b), false);
        campaign(&what, &b, mutator, 40, name, &door);
    }
}

/// Found by the sweep: a header claiming a 16K panorama over a small body, given a budget too
/// small for its plan, was refused by `ibl`, `prefilter`, `irradiance` and `convert` without
/// naming the file ("`size` 8 and `diffuse_size` 32 needs about 129 MiB of memory, over the
/// budget of 48 MiB"). Each job's plan names its input now.
#[test]
fn a_claimed_16k_panorama_over_the_budget_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let read = ReadOptions {
        limits: Limits {
            max_memory: 48 << 20,
            ..Limits::default()
        },
        ..ReadOptions::default()
    };
    let exr = harness::encoded("x.exr", &panorama(), &WriteOptions::default());
    let hdr = harness::encoded("x.hdr", &panorama(), &WriteOptions::default());
    for (name, src) in [("claims16k.exr", exr), ("claims16k.hdr", hdr)] {
        let path = dir.path().join(name);
        std::fs::write(&path, claiming(&src, 16384, 8192)).unwrap();
        let out = dir.path().join("out");
        let mut ibl = IblJob::new(vec![path.clone()], out.clone(), Engine::Bevy);
        ibl.options.specular_size = Some(8);
        ibl.read = read;
        let mut pre = PrefilterJob::new(vec![path.clone()], Destination::Path(out.join("c.ktx2")));
        pre.size = Some(8);
        pre.read = read;
        let mut irr =
            cubeforge::IrradianceJob::new(vec![path.clone()], Destination::Path(out.join("i.exr")));
        irr.read = read;
        let mut conv =
            cubeforge::ConvertJob::new(vec![path.clone()], Destination::Path(out.join("c.exr")));
        conv.read = read;
        let jobs: [(&str, &dyn Job); 4] = [
            ("ibl", &ibl),
            ("prefilter", &pre),
            ("irradiance", &irr),
            ("convert", &conv),
        ];
        for (what, job) in jobs {
            let e = job.run(&()).expect_err(what).to_string();
            assert!(
                e.contains(name) && e.contains("over the budget"),
                "{what}: {e}"
            );
            assert!(!out.exists(), "{what} left {}", out.display());
        }
    }
}
