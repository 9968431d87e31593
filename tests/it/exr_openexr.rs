//! Files written by OpenEXR itself (its Python bindings, PyPI `OpenEXR` 3.5) as VFX tools
//! write them: ZSTD-compressed scan lines and tiles, read exactly as the same samples stored
//! with ZIP are; and a damaged ZSTD chunk refused in one line.

use crate::common;

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
        ("tiles", "RGB16F (ZSTD)"),
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
