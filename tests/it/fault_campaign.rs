//! Issue 26, the second fault campaign: each finding made again here (the hostile files built
//! by the test) and shown fixed: a PIZ block that panicked, memory budgets that held per face
//! but not per face set, escape sequences that reached the terminal, and writes that failed
//! silently. Its findings about outputs (folders, `-o -`, signals, long names) are in
//! `fault_outputs.rs`.

pub(crate) use crate::atomic_writes::tree;
use crate::common::{run, stderr};
use cubeforge::internals::image::Image;
use glam::Vec4;
use std::path::{Path, PathBuf};
use std::process::Command;

pub(crate) const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");
pub(crate) const BIN: &str = env!("CARGO_BIN_EXE_cubeforge");

/// A run that must fail with exactly one line that says `what` (and no internal error).
pub(crate) fn refused(out: &std::process::Output, what: &[&str]) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!err.contains("internal error"), "{err}");
    for w in what {
        assert!(err.contains(w), "'{w}' not in: {err}");
    }
    err
}

pub(crate) fn ok(out: &std::process::Output) {
    assert!(out.status.success(), "{}", stderr(out));
}

/// Runs cubeforge in `dir` (relative names resolve there).
pub(crate) fn run_in<I, S>(dir: &Path, args: I) -> std::process::Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    Command::new(BIN)
        .current_dir(dir)
        .args(args)
        .output()
        .expect("cubeforge runs")
}

/// Item 1: A PIZ block whose Huffman header puts its first symbol after its last: one line that
/// names the file, exit 1 (it was a panic, exit 101, no file named).
#[test]
fn a_piz_header_with_its_symbols_reversed_is_one_line() {
    use exr::prelude::*;
    let layer = Layer::new(
        (64, 48),
        LayerAttributes::default(),
        Encoding {
            compression: Compression::PIZ,
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        },
        SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let (x, y) = (x as f32, y as f32);
            (
                f16::from_f32((x * 0.21).sin() + 1.5),
                f16::from_f32(y * 0.1),
                f16::from_f32(x * y * 1e-3),
            )
        }),
    );
    let mut good = Vec::new();
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(std::io::Cursor::new(&mut good))
        .unwrap();
    // The first block: after the header and the offset table, its line number and size,
    // then the PIZ data.
    let table = header_end(&good) + 1;
    let first = u64::from_le_bytes(good[table..table + 8].try_into().unwrap()) as usize;
    let data = first + 8;
    let (lo, hi) = (
        u16::from_le_bytes([good[data], good[data + 1]]) as usize,
        u16::from_le_bytes([good[data + 2], good[data + 3]]) as usize,
    );
    let huffman = data + 4 + if lo <= hi { hi - lo + 1 } else { 0 } + 4;
    let mut bad = good.clone();
    bad[huffman..huffman + 4].copy_from_slice(&100u32.to_le_bytes());
    bad[huffman + 4..huffman + 8].copy_from_slice(&50u32.to_le_bytes());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("reversed.exr");
    std::fs::write(&path, &bad).unwrap();
    let out = run(["info".as_ref(), path.as_os_str()]);
    refused(&out, &["reversed.exr", "Huffman"]);
    let out = run([
        "convert".as_ref(),
        path.as_os_str(),
        "-o".as_ref(),
        dir.path().join("out.exr").as_os_str(),
    ]);
    refused(&out, &["reversed.exr"]);
    assert!(!dir.path().join("out.exr").exists());
    // The intact file reads.
    std::fs::write(&path, &good).unwrap();
    ok(&run(["info".as_ref(), path.as_os_str()]));
}

/// Where a single-part OpenEXR header ends: the NUL after its last attribute (each is
/// name\0 type\0 size value).
fn header_end(b: &[u8]) -> usize {
    let mut at = 8;
    while b[at] != 0 {
        let name_end = at + b[at..].iter().position(|&c| c == 0).unwrap();
        let type_end = name_end + 1 + b[name_end + 1..].iter().position(|&c| c == 0).unwrap();
        let size = u32::from_le_bytes(b[type_end + 1..type_end + 5].try_into().unwrap()) as usize;
        at = type_end + 5 + size;
    }
    at
}

/// Six faces of `n` px, one colour each, as small PNG files in `dir`.
pub(crate) fn faces(dir: &Path, n: usize) {
    std::fs::create_dir_all(dir).unwrap();
    for (i, name) in ["px", "nx", "py", "ny", "pz", "nz"].iter().enumerate() {
        let img = Image::from_fn(n, n, |_, _| Vec4::new(0.1 * i as f32, 0.5, 0.25, 1.0));
        crate::common::write_image(&dir.join(format!("{name}.png")), &img);
    }
}

/// Item 2: The budget holds for a face set, not face by face: six 1024 px faces need 32 MiB each
/// to decode, 96 MiB kept together; 80M refuses them before any is decoded.
#[test]
fn a_face_set_is_checked_whole_against_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("set");
    faces(&set, 1024);
    let files: Vec<PathBuf> = ["px", "nx", "py", "ny", "pz", "nz"]
        .iter()
        .map(|n| set.join(format!("{n}.png")))
        .collect();
    // Each face alone fits.
    ok(&run([
        "info".as_ref(),
        files[0].as_os_str(),
        "--max-memory".as_ref(),
        "80M".as_ref(),
    ]));
    let out = run([
        "info".as_ref(),
        set.as_os_str(),
        "--max-memory".as_ref(),
        "80M".as_ref(),
    ]);
    refused(&out, &["6 input files", "--max-memory"]);
    // Six files named one by one, and every command that reads them.
    for (cmd, out_name) in [
        ("convert", "out.exr"),
        ("prefilter", "out.ktx2"),
        ("irradiance", "irr.exr"),
        ("ibl", "ibl"),
    ] {
        let out_path = dir.path().join(out_name);
        let mut args: Vec<std::ffi::OsString> = vec![cmd.into()];
        args.extend(files.iter().map(|f| f.clone().into_os_string()));
        args.extend(["-o".into(), out_path.into_os_string()]);
        match cmd {
            "prefilter" => args.extend(["--filter".into(), "box".into()]),
            "ibl" => args.extend(["--target".into(), "gltf".into()]),
            _ => {}
        }
        args.extend(["--max-memory".into(), "80M".into()]);
        let out = run(&args);
        refused(&out, &["--max-memory"]);
    }
    assert_eq!(
        tree(dir.path())
            .iter()
            .filter(|e| !e.starts_with("set"))
            .count(),
        0
    );
}

/// Item 2: A chain folder's levels count together (`info` read them level by level), and a
/// chain's one level read alone (`--level`) counts alone.
#[test]
fn a_chain_folder_is_checked_whole_against_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let chain = dir.path().join("chain");
    ok(&run([
        "prefilter".as_ref(),
        SKY.as_ref(),
        "-o".as_ref(),
        chain.as_os_str(),
        "--filter".as_ref(),
        "box".as_ref(),
        "--size".as_ref(),
        "512".as_ref(),
        "--format".as_ref(),
        "png".as_ref(),
    ]));
    // Level 0 alone takes 24 MiB kept (48 MiB while its faces decode); all ten, a third more.
    let out = run([
        "info".as_ref(),
        chain.as_os_str(),
        "--max-memory".as_ref(),
        "30M".as_ref(),
    ]);
    refused(&out, &["--max-memory"]);
    ok(&run([
        "info".as_ref(),
        chain.as_os_str(),
        "--max-memory".as_ref(),
        "100M".as_ref(),
    ]));
    ok(&run([
        "convert".as_ref(),
        chain.as_os_str(),
        "--level".as_ref(),
        "3".as_ref(),
        "-o".as_ref(),
        dir.path().join("l3.png").as_os_str(),
        "--max-memory".as_ref(),
        "30M".as_ref(),
    ]));
}

/// Item 2: `ibl --diffuse-size` counts (it ran at 3.1 GB under a 100M budget).
#[test]
fn ibl_diffuse_size_is_inside_the_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let out = run([
        "ibl".as_ref(),
        SKY.as_ref(),
        "-o".as_ref(),
        dir.path().join("o").as_os_str(),
        "--target".as_ref(),
        "gltf".as_ref(),
        "--size".as_ref(),
        "64".as_ref(),
        "--diffuse-size".as_ref(),
        "4096".as_ref(),
        "--max-memory".as_ref(),
        "100M".as_ref(),
    ]);
    refused(&out, &["--diffuse-size 4096", "--max-memory"]);
    assert!(tree(dir.path()).is_empty(), "{:?}", tree(dir.path()));
}

/// Item 7: What a file holds is quoted escaped: a Radiance header's escape sequence, bell and
/// bidirectional override reach the terminal written out, never as the bytes.
#[test]
fn file_contents_reach_the_terminal_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("evil.hdr");
    std::fs::write(
        &path,
        b"#?RADIANCE\nFORMAT=32-bit_rle_\x1b[31mxyz\x07\xe2\x80\xae\n\n-Y 2 +X 5\n\0\0\0\0",
    )
    .unwrap();
    for cmd in ["info", "convert"] {
        let mut args = vec![cmd.as_ref(), path.as_os_str()];
        let o = dir.path().join("o.png");
        if cmd == "convert" {
            args.extend(["-o".as_ref(), o.as_os_str()]);
        }
        let out = run(args);
        let err = refused(&out, &["evil.hdr", "\\x1b[31m", "\\x07"]);
        assert!(
            !out.stderr.iter().any(|&b| b < 0x20 && b != b'\n'),
            "control bytes reached standard error: {err}"
        );
    }
    // A name that holds them is written out too, a bidirectional override with them.
    let odd = dir.path().join("a\x1b]0;title\x07b\u{202e}c.hdr");
    std::fs::write(&odd, b"#?RADIANCE\n").unwrap();
    let out = run(["info".as_ref(), odd.as_os_str()]);
    refused(&out, &["\\x1b]0;title\\x07b\\u{202e}c.hdr"]);
    assert!(!out.stderr.iter().any(|&b| b < 0x20 && b != b'\n'));
}

/// Item 8: Help, the version and an output into a full disk, and an output to a closed standard
/// output: non-zero with one line (they exited 0 having written nothing).
#[cfg(unix)]
#[test]
fn writes_that_fail_say_so() {
    let full = |args: &[&str]| {
        Command::new(BIN)
            .args(args)
            .stdout(
                std::fs::OpenOptions::new()
                    .write(true)
                    .open("/dev/full")
                    .unwrap(),
            )
            .output()
            .unwrap()
    };
    if Path::new("/dev/full").exists() {
        for args in [
            &["--help"][..],
            &["--version"],
            &["convert", "--help"],
            &["info", SKY],
            &["convert", SKY, "-o", "-", "--format", "png", "--size", "8"],
        ] {
            refused(&full(args), &["standard output"]);
        }
    }
    // Standard output closed by the shell (`>&-`); `> /dev/null` stays fine.
    let closed = |args: &str, redirect: &str| {
        Command::new("sh")
            .arg("-c")
            .arg(format!("exec \"$0\" {args} {redirect}"))
            .arg(BIN)
            .output()
            .unwrap()
    };
    for args in [
        format!("convert {SKY} -o - --format ktx2 --size 8"),
        format!("info {SKY}"),
        "--help".to_string(),
    ] {
        refused(&closed(&args, ">&-"), &["standard output", "closed"]);
        ok(&closed(&args, ">/dev/null"));
    }
}

/// Item 2: what a header claims ([`cubeforge::internals::io::claim`], read before any decode) is what
/// the decoder then gives, for every format cubeforge reads; a file past the first MiB (a
/// noisy PNG) and a JPEG whose size comes after 1.1 MB of metadata are claimed right too.
#[test]
fn claims_match_what_decoding_gives() {
    use cubeforge::internals::cube::CubeMap;
    use cubeforge::internals::io::{self, Decoded, GpuFormat, ReadOptions, WriteOptions};
    let dir = tempfile::tempdir().unwrap();
    let opts = ReadOptions::default();
    let img = Image::from_fn(24, 12, |x, y| {
        Vec4::new(x as f32 / 24.0, y as f32 / 12.0, 0.5, 1.0)
    });
    let mut files = Vec::new();
    for ext in ["png", "jpg", "tga", "hdr", "exr"] {
        let p = dir.path().join(format!("i.{ext}"));
        std::fs::write(
            &p,
            cubeforge::internals::output::encode_image(&p, &img, &WriteOptions::default()).unwrap(),
        )
        .unwrap();
        files.push(p);
    }
    let faces: [Image; 6] = std::array::from_fn(|f| {
        Image::from_fn(16, 16, |x, _| {
            Vec4::new(f as f32 / 6.0, x as f32 / 16.0, 0.25, 1.0)
        })
    });
    let cube = CubeMap::from_faces(faces).unwrap().with_box_mips(None);
    for ext in ["ktx2", "dds", "ktx", "env"] {
        let p = dir.path().join(format!("c.{ext}"));
        std::fs::write(
            &p,
            cubeforge::internals::output::encode_cube(&p, &cube, GpuFormat::Rgba16f).unwrap(),
        )
        .unwrap();
        files.push(p);
    }
    // Noise does not compress: a 1024 x 1024 PNG of 4 MB.
    let noise = Image::from_fn(1024, 1024, |x, y| {
        let v = crate::common::XorShift((x * 1031 + y * 7 + 1) as u64).next();
        Vec4::new(
            (v & 255) as f32 / 255.0,
            (v >> 8 & 255) as f32 / 255.0,
            0.5,
            1.0,
        )
    });
    let big = dir.path().join("noise.png");
    std::fs::write(
        &big,
        cubeforge::internals::output::encode_image(&big, &noise, &WriteOptions::default()).unwrap(),
    )
    .unwrap();
    assert!(std::fs::metadata(&big).unwrap().len() > 1 << 20);
    files.push(big);
    // A JPEG with 17 APP15 segments of 64 KiB before its frame header.
    let jpg = std::fs::read(&files[1]).unwrap();
    let mut padded = jpg[..2].to_vec();
    for _ in 0..17 {
        padded.extend([0xff, 0xef, 0xff, 0xff]);
        padded.extend(std::iter::repeat_n(0u8, 0xfffd));
    }
    padded.extend(&jpg[2..]);
    let late = dir.path().join("late.jpg");
    std::fs::write(&late, padded).unwrap();
    files.push(late);
    for p in &files {
        let c = io::claim(p, &opts)
            .unwrap_or_else(|e| panic!("{e}"))
            .expect("a file has a claim");
        let (w, h, cube) = match cubeforge::internals::convert::read(p, &opts).unwrap().0 {
            Decoded::Image(i) => (i.width, i.height, false),
            Decoded::Cube(c) => (c.size(), c.size(), true),
        };
        assert_eq!(
            (c.width, c.height, c.cube),
            (w as u64, h as u64, cube),
            "{}",
            p.display()
        );
        let len = std::fs::metadata(p).unwrap().len();
        assert!(c.decode_bytes >= c.held_bytes + len, "{}", p.display());
    }
    // A damaged file is refused at its claim, before anything is decoded.
    let bad = dir.path().join("bad.exr");
    std::fs::write(&bad, b"v/1\x01not much").unwrap();
    let e = io::claim(&bad, &opts).unwrap_err().to_string();
    assert!(e.contains("bad.exr"), "{e}");
}

/// Item 2: under an address-space cap (`ulimit -v`), where an allocation past it aborts the
/// process, the default budget is half the cap: a plan over it is one line, exit 1, never
/// "memory allocation failed" and SIGABRT.
#[cfg(unix)]
#[test]
fn an_address_space_cap_lowers_the_default_budget() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.exr");
    let capped = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1000000 && exec \"$0\" convert \"$1\" -o \"$2\" --size 2048")
        .arg(BIN)
        .arg(SKY)
        .arg(&out)
        .output()
        .unwrap();
    refused(&capped, &["over the budget of", "--max-memory"]);
    assert!(!out.exists());
}

/// Item 2: a preview's textures (decal, control map, a material's decal) are read within the
/// command's budget and counted in its estimate (they were read with the default limits).
#[test]
fn preview_textures_are_inside_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let decal = dir.path().join("decal.png");
    let img = Image::from_fn(2048, 2048, |_, _| Vec4::new(0.5, 0.4, 0.3, 1.0));
    crate::common::write_image(&decal, &img);
    let out = dir.path().join("p.png");
    for flag in ["--decal", "--control"] {
        let args = [
            "preview".as_ref(),
            SKY.as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
            "--size".as_ref(),
            "32".as_ref(),
            flag.as_ref(),
            decal.as_os_str(),
            "--max-memory".as_ref(),
            "100M".as_ref(),
        ];
        refused(&run(args), &["decal.png", "--max-memory"]);
        ok(&run(&args[..8]));
    }
    assert!(out.exists());
}

/// Item 2: a control-map recipe's images count together, each checked before it is decoded:
/// two 2048 px masks fit 150M one at a time, not together.
#[test]
fn a_recipes_images_count_together() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.png", "b.png"] {
        let img = Image::from_fn(2048, 2048, |_, _| Vec4::new(0.5, 0.4, 0.3, 1.0));
        crate::common::write_image(&dir.path().join(name), &img);
    }
    let recipe = dir.path().join("r.toml");
    let run_recipe = |text: &str| {
        std::fs::write(&recipe, text).unwrap();
        run([
            "control".as_ref(),
            recipe.as_os_str(),
            "-o".as_ref(),
            dir.path().join("c.png").as_os_str(),
            "--size".as_ref(),
            "16".as_ref(),
            "--max-memory".as_ref(),
            "150M".as_ref(),
        ])
    };
    ok(&run_recipe(
        "[reflectivity]\nimage = { path = \"a.png\", channel = \"r\" }\n",
    ));
    let both = run_recipe(
        "[reflectivity]\nimage = { path = \"a.png\", channel = \"r\" }\n[transmittance]\nimage = { path = \"b.png\", channel = \"g\" }\n",
    );
    refused(
        &both,
        &["b.png", "recipe's other images", "over the budget"],
    );
}

/// Item 2: `lut --size` is inside a budget too (it had none).
#[test]
fn lut_size_is_inside_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("l.png");
    let args = |size: &'static str| {
        [
            "lut".as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
            "--size".as_ref(),
            size.as_ref(),
            "--max-memory".as_ref(),
            "100M".as_ref(),
        ]
    };
    refused(&run(args("4096")), &["--size 4096", "--max-memory"]);
    assert!(!out.exists());
    ok(&run(args("32")));
}
