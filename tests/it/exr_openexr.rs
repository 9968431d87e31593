//! Files written by OpenEXR itself as VFX tools write them: ZSTD-compressed scan lines and
//! tiles (its Python bindings, PyPI `OpenEXR` 3.5), read exactly as the same samples stored
//! with ZIP are, and a damaged ZSTD chunk refused in one line; multi-part files (`--part`);
//! mip-mapped tiles from `exrmaketiled` (`info`'s level count, `convert --level`);
//! luminance/chroma images from `RgbaOutputFile`, read as its `RgbaInputFile` reads them; and
//! 2D textures that `info` does not take for environments.

use crate::common;
use std::ffi::OsStr;
use std::path::Path;

/// cubeforge's output and error text for `args`, asserting success.
fn ok(args: &[&OsStr]) -> String {
    let o = common::run(args);
    assert!(o.status.success(), "{}", common::stderr(&o));
    String::from_utf8_lossy(&o.stdout).into_owned() + &common::stderr(&o)
}

/// cubeforge's one-line error for `args`, asserting failure.
fn refused(args: &[&OsStr]) -> String {
    let o = common::run(args);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    err
}

/// `info FILE ARGS`' text.
fn info(file: &Path, args: &[&str]) -> String {
    let mut all: Vec<&OsStr> = vec!["info".as_ref(), file.as_os_str()];
    all.extend(args.iter().map(OsStr::new));
    ok(&all)
}

/// `convert FILE --to equirect -o OUT ARGS`, read back.
fn convert(file: &Path, out: &Path, args: &[&str]) -> (cubeforge::internals::image::Image, String) {
    let mut all: Vec<&OsStr> = vec![
        "convert".as_ref(),
        file.as_os_str(),
        "--to".as_ref(),
        "equirect".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ];
    all.extend(args.iter().map(OsStr::new));
    let text = ok(&all);
    (common::read_image(out), text)
}

/// Writes, into the folder given, each image twice: `NAME.exr` with ZSTD and `NAME_zip.exr`
/// with ZIP (the same samples): float RGB scan lines, mixed half and float channels with
/// alpha, and half tiles; radiance up to 3 with a bright spot of 5000 (a sun).
const ZSTD_FILES: &str = r#"
import sys, OpenEXR, numpy as np
d = sys.argv[1]
h, w = 64, 128
y, x = np.mgrid[0:h, 0:w]
rgb = np.stack([x / w * 3, y / h, (x + y) / 100 + 0.5], -1).astype('float32')
rgb[20:23, 40:44] = 5000.0
def both(name, header, channels):
    for c, suffix in [(OpenEXR.ZSTD_COMPRESSION, ''), (OpenEXR.ZIP_COMPRESSION, '_zip')]:
        header['compression'] = c
        OpenEXR.File(header, channels).write(f'{d}/{name}{suffix}.exr')
both('float', {'type': OpenEXR.scanlineimage}, {'RGB': rgb})
both('mixed', {'type': OpenEXR.scanlineimage},
     {'R': rgb[..., 0].astype('float16'), 'G': rgb[..., 1], 'B': rgb[..., 2],
      'A': np.ones((h, w), 'float16')})
t = OpenEXR.TileDescription()
t.xSize, t.ySize, t.mode, t.roundingMode = 16, 16, OpenEXR.ONE_LEVEL, OpenEXR.ROUND_DOWN
both('tiles', {'type': OpenEXR.tiledimage, 'tiles': t}, {'RGB': rgb.astype('float16')})
"#;

#[test]
fn zstd_files_read_as_their_zip_twins() {
    if !common::openexr_python() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    common::openexr_script(ZSTD_FILES, dir.path());
    for (name, format) in [
        ("float", "RGB32F (ZSTD)"),
        ("mixed", "R16F G32F B32F A16F (ZSTD)"),
        ("tiles", "RGB16F (ZSTD, tiles 16x16)"),
    ] {
        let zstd = dir.path().join(format!("{name}.exr"));
        let zip = dir.path().join(format!("{name}_zip.exr"));
        let o = common::run([std::ffi::OsStr::new("info"), zstd.as_os_str()]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains(format), "{name}: {text}");
        // The same samples: the same bytes out, through the same conversion.
        let mut outs = Vec::new();
        for (input, tag) in [(&zstd, "a"), (&zip, "b")] {
            let out = dir.path().join(format!("{name}_{tag}_out.exr"));
            let o = common::run([
                "convert".as_ref(),
                input.as_os_str(),
                "--to".as_ref(),
                "equirect".as_ref(),
                "--output".as_ref(),
                out.as_os_str(),
            ]);
            assert!(o.status.success(), "{}", common::stderr(&o));
            outs.push(std::fs::read(out).unwrap());
        }
        assert!(outs[0] == outs[1], "{name}: ZSTD and ZIP read differently");
    }
    // The sun survives (float samples, no clamp).
    let img = common::read_image(&dir.path().join("float.exr"));
    assert_eq!(img.get(41, 21).x, 5000.0);
}

#[test]
fn a_damaged_zstd_chunk_is_refused_in_one_line() {
    if !common::openexr_python() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    common::openexr_script(ZSTD_FILES, dir.path());
    let good = std::fs::read(dir.path().join("float.exr")).unwrap();
    // Every zstd frame's first bytes after its magic number, overwritten.
    let mut bad = good.clone();
    let frames: Vec<usize> = good
        .windows(8)
        .enumerate()
        .filter(|(_, w)| w == b"zstd-exr")
        .map(|(i, _)| i)
        .collect();
    assert!(frames.len() > 10, "{} ZSTD chunks", frames.len());
    for &at in &frames {
        bad[at + 24..at + 32].copy_from_slice(&[0xff; 8]);
    }
    let path = dir.path().join("bad.exr");
    std::fs::write(&path, &bad).unwrap();
    let out = dir.path().join("out.exr");
    let o = common::run([
        "convert".as_ref(),
        path.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    let err = common::stderr(&o);
    assert!(!o.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("bad.exr") && err.contains("ZSTD chunk is corrupt"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Two named parts (beauty, ZIP; diffuse, PIZ, twice as bright) and a third without a name.
const PARTS: &str = r#"
import sys, OpenEXR, numpy as np
d = sys.argv[1]
h, w = 32, 64
y, x = np.mgrid[0:h, 0:w]
a = np.stack([x / w, y / h, np.full((h, w), 0.5)], -1).astype('float32')
parts = [
    OpenEXR.Part({'type': OpenEXR.scanlineimage, 'compression': OpenEXR.ZIP_COMPRESSION}, {'RGB': a}, name='beauty'),
    OpenEXR.Part({'type': OpenEXR.scanlineimage, 'compression': OpenEXR.PIZ_COMPRESSION}, {'RGB': 2 * a}, name='diffuse'),
    OpenEXR.Part({'type': OpenEXR.scanlineimage, 'compression': OpenEXR.ZSTD_COMPRESSION}, {'RGB': 3 * a}, name='spec'),
]
OpenEXR.File(parts).write(f'{d}/parts.exr')
"#;

#[test]
fn multi_part_files_say_which_part_and_read_the_one_chosen() {
    if !common::openexr_python() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    common::openexr_script(PARTS, dir.path());
    let file = dir.path().join("parts.exr");
    let text = info(&file, &[]);
    assert!(
        text.contains("part:         0 \"beauty\" of 3 (choose another with --part N or NAME)"),
        "{text}"
    );
    assert!(info(&file, &["--part", "diffuse"]).contains("part:         1 \"diffuse\" of 3"));
    let out = dir.path().join("out.exr");
    // Without --part: part 0, and a warning that says so.
    let (first, said) = convert(&file, &out, &[]);
    assert!(
        said.contains("warning") && said.contains("read part 0 \"beauty\" of 3"),
        "{said}"
    );
    for (choice, scale) in [("1", 2.0), ("diffuse", 2.0), ("spec", 3.0), ("2", 3.0)] {
        let (img, said) = convert(&file, &out, &["--part", choice]);
        assert!(!said.contains("warning"), "{said}");
        for (a, b) in first.pixels.iter().zip(&img.pixels) {
            assert!(
                (*a * scale - *b).truncate().abs().max_element() <= 2e-3 * scale,
                "{a} {b}"
            );
        }
    }
    for (choice, says) in [
        (
            "5",
            "no part 5: the file holds 3 parts (0 \"beauty\", 1 \"diffuse\", 2 \"spec\")",
        ),
        (
            "nope",
            "no part named \"nope\": its parts are 0 \"beauty\", 1 \"diffuse\", 2 \"spec\"",
        ),
    ] {
        let err = refused(&[
            "convert".as_ref(),
            file.as_os_str(),
            "-o".as_ref(),
            out.with_extension("png").as_os_str(),
            "--part".as_ref(),
            choice.as_ref(),
        ]);
        assert!(err.contains("parts.exr") && err.contains(says), "{err}");
    }
    // A name needs an OpenEXR file to look it up in.
    let png = dir.path().join("a.png");
    common::write_image(&png, &first);
    let err = refused(&[
        "info".as_ref(),
        png.as_os_str(),
        "--part".as_ref(),
        "x".as_ref(),
    ]);
    assert!(
        err.contains("only an OpenEXR file has named parts"),
        "{err}"
    );
}

#[test]
fn exrmaketiled_mip_levels_are_counted_and_each_is_read() {
    // exrmaketiled comes with exrenvmap (Debian's openexr).
    if !common::exrenvmap() || !common::oiiotool() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // A float equirect, 128 x 64, made into tiles with a mip chain by OpenEXR's own tool.
    let flat = dir.path().join("flat.exr");
    let mut img = cubeforge::internals::image::Image::new(128, 64);
    for (i, p) in img.pixels.iter_mut().enumerate() {
        let (x, y) = ((i % 128) as f32, (i / 128) as f32);
        *p = glam::Vec4::new(x / 128.0, y / 64.0, ((x + 3.0 * y) % 7.0) / 7.0, 1.0);
    }
    common::write_image(&flat, &img);
    let mip = dir.path().join("mip.exr");
    let o = std::process::Command::new("exrmaketiled")
        .args([
            "-m".as_ref(),
            "-z".as_ref(),
            "zip".as_ref(),
            flat.as_os_str(),
            mip.as_os_str(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(info(&mip, &[]).contains("mip levels:   8"));
    let out = dir.path().join("out.exr");
    let (base, _) = convert(&mip, &out, &[]);
    assert_eq!((base.width, base.height), (128, 64));
    // Each level as OpenImageIO reads it (`--selectmip`), within float rounding.
    for (level, size) in [(1, (64, 32)), (2, (32, 16)), (4, (8, 4))] {
        let (ours, _) = convert(
            &mip,
            &out,
            &["--level", &level.to_string(), "--from", "equirect"],
        );
        assert_eq!((ours.width, ours.height), size);
        let theirs = dir.path().join(format!("oiio_{level}.exr"));
        let o = std::process::Command::new("oiiotool")
            .arg(&mip)
            .args(["--selectmip", &level.to_string(), "-o"])
            .arg(&theirs)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let theirs = common::read_image(&theirs);
        let worst = common::max_abs_error(&ours, &theirs);
        assert!(worst < 1e-4, "level {level}: {worst}");
    }
    let err = refused(&[
        "convert".as_ref(),
        mip.as_os_str(),
        "--level".as_ref(),
        "8".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(
        err.contains("mip.exr") && err.contains("no level 8: it holds 8 levels"),
        "{err}"
    );
}

#[test]
fn luminance_and_chroma_read_as_openexrs_rgba_input_file_reads_them() {
    if !common::openexr_cxx() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let tool = common::build_openexr_tool("openexr_yc", dir.path());
    for (mode, format, bound) in [
        ("yc", "Y RY BY16F, chroma 2x2 (ZIP, 16 lines)", 5e-3),
        ("y", "Y16F (ZIP, 16 lines)", 1e-5),
    ] {
        let file = dir.path().join(format!("{mode}.exr"));
        let raw = dir.path().join(format!("{mode}.raw"));
        let o = std::process::Command::new(&tool)
            .args([file.as_os_str(), raw.as_os_str(), mode.as_ref()])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(info(&file, &[]).contains(format), "{}", info(&file, &[]));
        let reference: Vec<f32> = std::fs::read(&raw)
            .unwrap()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect();
        let (img, _) = convert(
            &file,
            &dir.path().join(format!("{mode}_out.exr")),
            &["--exr-float", "f32"],
        );
        let mut worst = 0.0f32;
        for (p, want) in img.pixels.iter().zip(reference.chunks_exact(3)) {
            for c in 0..3 {
                worst = worst.max((p[c] - want[c]).abs() / want[c]);
            }
        }
        println!("{mode}: {worst:.5} of the value at worst");
        if mode == "yc" {
            let text = format!("Within {:.2}% of `RgbaInputFile`'s result", 100.0 * worst);
            crate::figures::check("docs/conventions.md", "yc", &text);
        }
        // Measured: 0.0026 with chroma (OpenEXR's filters; its saturation fix is not
        // applied), 5e-6 for luminance alone (the conversion's float rounding).
        assert!(worst <= bound, "{mode}: {worst}");
    }
}

#[test]
fn two_d_textures_are_not_described_as_environments() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["dfg.ktx2", "dfg.exr"] {
        let file = dir.path().join(name);
        ok(&[
            "lut".as_ref(),
            "-o".as_ref(),
            file.as_os_str(),
            "--samples".as_ref(),
            "64".as_ref(),
        ]);
        let text = info(&file, &[]);
        assert!(text.contains("layout:       2D texture ("), "{text}");
        assert!(
            !text.contains("flux") && !text.contains("face size"),
            "{text}"
        );
        let json = info(&file, &["--json"]);
        assert!(
            json.contains("\"texture\"") && !json.contains("\"flux\": ["),
            "{json}"
        );
    }
    // An environment keeps its layout and flux.
    let sky = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/sky.exr");
    let text = info(&sky, &[]);
    assert!(
        text.contains("layout:       equirect") && text.contains("flux:"),
        "{text}"
    );
}
