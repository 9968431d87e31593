//! Issue 26, the second fault campaign: each finding made again here (the hostile files built
//! by the test) and shown fixed: a PIZ block that panicked, memory budgets that held per face
//! but not per face set, folders that merged, `-o -` that made a folder named `-`, signals
//! that left temporaries, long names that failed, escape sequences that reached the terminal,
//! and writes that failed silently.

use crate::common::{run, stderr};
use cubeforge::image::Image;
use glam::Vec4;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");
const BIN: &str = env!("CARGO_BIN_EXE_cubeforge");

/// Every entry under `dir`, relative, sorted.
fn tree(dir: &Path) -> Vec<String> {
    fn walk(d: &Path, root: &Path, out: &mut Vec<String>) {
        let Ok(rd) = std::fs::read_dir(d) else { return };
        for e in rd.flatten() {
            let p = e.path();
            out.push(p.strip_prefix(root).unwrap().display().to_string());
            if p.is_dir() && !p.is_symlink() {
                walk(&p, root, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// A run that must fail with exactly one line that says `what` (and no internal error).
fn refused(out: &std::process::Output, what: &[&str]) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!err.contains("internal error"), "{err}");
    for w in what {
        assert!(err.contains(w), "'{w}' not in: {err}");
    }
    err
}

fn ok(out: &std::process::Output) {
    assert!(out.status.success(), "{}", stderr(out));
}

/// Runs cubeforge in `dir` (relative names resolve there).
fn run_in<I, S>(dir: &Path, args: I) -> std::process::Output
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
fn faces(dir: &Path, n: usize) {
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

fn prefilter(out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args: Vec<&std::ffi::OsStr> = vec![
        "prefilter".as_ref(),
        SKY.as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
        "--filter".as_ref(),
        "box".as_ref(),
        "--size".as_ref(),
        "16".as_ref(),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    run(args)
}

/// Item 3: A chain written where a longer one was, or faces of another format: the folder holds
/// the new output alone, and cubeforge reads it back.
#[test]
fn a_folder_output_replaces_the_old_one_whole() {
    let dir = tempfile::tempdir().unwrap();
    let chain = dir.path().join("chain");
    ok(&prefilter(&chain, &[]));
    assert!(chain.join("m4").is_dir());
    ok(&prefilter(&chain, &["--levels", "3", "--format", "png"]));
    let mut want = vec!["levels.json".to_string()];
    for k in 0..3 {
        want.push(format!("m{k}"));
        for f in ["nx", "ny", "nz", "px", "py", "pz"] {
            want.push(format!("m{k}/{f}.png"));
        }
    }
    want.sort();
    assert_eq!(tree(&chain), want);
    let info = run(["info".as_ref(), chain.as_os_str()]);
    ok(&info);
    assert!(String::from_utf8_lossy(&info.stdout).contains("folders m0 to m2"));
    // Faces over a chain, then faces of another type over those.
    for format in ["exr", "png"] {
        ok(&run([
            "convert".as_ref(),
            SKY.as_ref(),
            "-o".as_ref(),
            chain.as_os_str(),
            "--to".as_ref(),
            "faces".as_ref(),
            "--size".as_ref(),
            "8".as_ref(),
            "--format".as_ref(),
            format.as_ref(),
        ]));
        let names = tree(&chain);
        assert_eq!(names.len(), 6, "{names:?}");
        assert!(names.iter().all(|n| n.ends_with(format)), "{names:?}");
        ok(&run(["info".as_ref(), chain.as_os_str()]));
    }
    assert_eq!(
        tree(dir.path()).len(),
        7,
        "no temporaries left: {:?}",
        tree(dir.path())
    );
}

/// Item 3: A folder that holds what cubeforge did not write is refused before the work, and left
/// as it was; so is one that holds the input.
#[test]
fn a_folder_cubeforge_did_not_write_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), "keep me").unwrap();
    std::fs::write(mine.join("px.png"), "not really").unwrap();
    let out = prefilter(&mine, &[]);
    refused(&out, &["mine", "notes.txt", "did not write"]);
    let out = run([
        "convert".as_ref(),
        SKY.as_ref(),
        "-o".as_ref(),
        mine.as_os_str(),
        "--to".as_ref(),
        "faces".as_ref(),
    ]);
    refused(&out, &["notes.txt"]);
    assert_eq!(tree(&mine), ["notes.txt", "px.png"]);
    assert_eq!(
        std::fs::read_to_string(mine.join("px.png")).unwrap(),
        "not really"
    );
    // The input's own folder: its faces would go with it.
    let set = dir.path().join("set");
    faces(&set, 8);
    let out = run([
        "convert".as_ref(),
        set.as_os_str(),
        "-o".as_ref(),
        set.as_os_str(),
        "--format".as_ref(),
        "exr".as_ref(),
    ]);
    refused(&out, &["holds the input"]);
    assert_eq!(tree(&set).len(), 6);
    // An empty folder, and desktop litter, are fine.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    std::fs::write(empty.join(".DS_Store"), "").unwrap();
    ok(&prefilter(&empty, &[]));
    assert!(empty.join("levels.json").is_file() && !empty.join(".DS_Store").exists());
}

/// Item 3: Two writers into one new folder (and into one that exists) at the same moment end with
/// one writer's whole result: one format, one chain length, never a mix.
#[test]
fn concurrent_folder_writers_leave_one_whole_result() {
    let dir = tempfile::tempdir().unwrap();
    let spawn = |out: &Path, levels: &str, format: &str| {
        Command::new(BIN)
            .args(["prefilter", SKY, "-o"])
            .arg(out)
            .args(["--filter", "box", "--size", "16", "--levels", levels])
            .args(["--format", format])
            .env("CUBEFORGE_TEST_PAUSE_BEFORE_COMMIT_MS", "300")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("cubeforge runs")
    };
    for round in 0..6 {
        let out = dir.path().join(format!("chain{round}"));
        if round % 2 == 1 {
            ok(&prefilter(&out, &[]));
        }
        let a = spawn(&out, "5", "exr");
        let b = spawn(&out, "2", "png");
        for c in [a, b] {
            let r = c.wait_with_output().unwrap();
            assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        }
        let names = tree(&out);
        let exr = names.iter().filter(|n| n.ends_with(".exr")).count();
        let png = names.iter().filter(|n| n.ends_with(".png")).count();
        assert!(
            (exr, png) == (30, 0) || (exr, png) == (0, 12),
            "round {round}: a mix: {names:?}"
        );
        ok(&run(["info".as_ref(), out.as_os_str()]));
    }
    assert!(!tree(dir.path()).iter().any(|e| e.contains(".cubeforge-")));
}

/// Item 4: `-o -` for commands that may write several files: one container on standard output
/// where --format names one, a clear refusal otherwise; never a file or folder named `-`.
#[test]
fn dash_is_standard_output_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let pre = |extra: &[&str]| {
        let mut args = vec![
            "prefilter",
            SKY,
            "-o",
            "-",
            "--filter",
            "box",
            "--size",
            "16",
        ];
        args.extend(extra);
        run_in(d, args)
    };
    let out = pre(&["--format", "ktx2"]);
    ok(&out);
    ok(&prefilter(&d.join("file.ktx2"), &[]));
    assert_eq!(out.stdout, std::fs::read(d.join("file.ktx2")).unwrap());
    std::fs::remove_file(d.join("file.ktx2")).unwrap();
    let out = pre(&["--format", "dds"]);
    ok(&out);
    assert!(out.stdout.starts_with(b"DDS "));
    refused(&pre(&[]), &["-o -", "--format", "ktx2"]);
    let out = run_in(
        d,
        [
            "irradiance",
            SKY,
            "-o",
            "-",
            "--format",
            "ktx2",
            "--size",
            "8",
        ],
    );
    ok(&out);
    assert!(out.stdout.starts_with(b"\xabKTX 20"));
    refused(
        &run_in(d, ["ibl", SKY, "-o", "-", "--target", "bevy"]),
        &["-o -", "name a folder"],
    );
    refused(&run_in(d, ["lut", "-o", "-"]), &["-"]);
    assert!(tree(d).is_empty(), "{:?}", tree(d));
}

/// Item 5: A signal at any moment leaves no temporary behind: 36 runs writing six 1024 px faces,
/// each signalled (SIGINT, SIGTERM, SIGHUP in turn) at another point: two of three while the
/// faces are being written under temporary names (the window that left them: 5 of 48 such
/// runs before the fix), the others spread over the whole run.
#[cfg(unix)]
#[test]
fn signals_at_any_moment_leave_no_temporaries() {
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().unwrap();
    let command = |out: &Path| {
        let mut c = Command::new(BIN);
        c.args(["convert", SKY, "-o"])
            .arg(out)
            .args(["--to", "faces", "--size", "1024", "--format", "hdr"])
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        c
    };
    let hidden = || {
        tree(dir.path())
            .into_iter()
            .filter(|e| e.contains(".cubeforge-"))
            .collect::<Vec<_>>()
    };
    // How long a run takes here, to spread the other signals over it.
    let start = Instant::now();
    assert!(command(&dir.path().join("calibrate"))
        .status()
        .unwrap()
        .success());
    let span = start.elapsed();
    let signals = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];
    let mut rng = crate::common::XorShift(0x51f1_5eed);
    for i in 0..36 {
        // Into a new folder, and into one that exists.
        let out = dir.path().join(format!("out{}", i % 4));
        let mut child = command(&out).spawn().unwrap();
        let jitter = Duration::from_micros(rng.next() % 8_000);
        let at = if i % 3 != 2 {
            let begun = Instant::now();
            while hidden().is_empty() && begun.elapsed() < Duration::from_secs(20) {
                if child.try_wait().unwrap().is_some() {
                    break;
                }
                std::thread::sleep(Duration::from_micros(500));
            }
            jitter
        } else {
            span.mul_f64(i as f64 / 36.0) + jitter
        };
        std::thread::sleep(at);
        // SAFETY: kill only sends a signal to the child we started.
        unsafe { libc::kill(child.id() as libc::pid_t, signals[i % 3]) };
        child.wait().unwrap();
        let left = hidden();
        assert!(left.is_empty(), "run {i}, signalled {at:?} in: {left:?}");
        // Whatever landed is whole: six faces cubeforge reads.
        if out.exists() {
            ok(&run(["info".as_ref(), out.as_os_str()]));
        }
    }
}

/// Item 6: Output names up to the file system's 255 bytes work (the temporary's was 22 bytes
/// longer).
#[test]
fn the_longest_names_the_file_system_takes_work() {
    let dir = tempfile::tempdir().unwrap();
    for len in [230, 250, 255] {
        let name = format!("{}.png", "n".repeat(len - 4));
        let out = run([
            "convert".as_ref(),
            SKY.as_ref(),
            "-o".as_ref(),
            dir.path().join(&name).as_os_str(),
            "--size".as_ref(),
            "8".as_ref(),
        ]);
        ok(&out);
        assert!(dir.path().join(&name).is_file());
        // Once more, replacing it; and as a folder of faces.
        ok(&run([
            "convert".as_ref(),
            SKY.as_ref(),
            "-o".as_ref(),
            dir.path().join(&name).as_os_str(),
            "--size".as_ref(),
            "8".as_ref(),
        ]));
        let folder = dir.path().join("f".repeat(len));
        for _ in 0..2 {
            ok(&prefilter(&folder, &[]));
        }
    }
    assert!(!tree(dir.path()).iter().any(|e| e.contains(".cubeforge-")));
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
