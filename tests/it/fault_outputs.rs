//! Issue 26's findings about outputs, each made again and shown fixed: folders that merged
//! with what they held, `-o -` that made a folder named `-`, signals that left temporaries,
//! and long names that failed.

use crate::common::run;
use crate::fault_campaign::{faces, ok, refused, run_in, tree, BIN, SKY};
use std::path::Path;
use std::process::{Command, Stdio};

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
    if !extra.contains(&"--levels") {
        args.extend([
            std::ffi::OsStr::new("--min-size"),
            std::ffi::OsStr::new("1"),
        ]);
    }
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
            "--min-size",
            "1",
        ];
        args.extend(extra);
        run_in(d, args)
    };
    let out = pre(&["--format", "ktx2"]);
    ok(&out);
    ok(&prefilter(&d.join("file.ktx2"), &[]));
    assert_eq!(out.stdout, std::fs::read(d.join("file.ktx2")).unwrap());
    std::fs::remove_file(d.join("file.ktx2")).unwrap();
    // The description beside it, which standard output has no room for.
    std::fs::remove_file(d.join("file.ktx2.levels.json")).unwrap();
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
        // Made, then replaced; then as a folder of faces, made and replaced.
        for _ in 0..2 {
            ok(&run([
                "convert".as_ref(),
                SKY.as_ref(),
                "-o".as_ref(),
                dir.path().join(&name).as_os_str(),
                "--size".as_ref(),
                "8".as_ref(),
            ]));
            assert!(dir.path().join(&name).is_file());
        }
        let folder = dir.path().join("f".repeat(len));
        for _ in 0..2 {
            ok(&prefilter(&folder, &[]));
        }
    }
    assert!(!tree(dir.path()).iter().any(|e| e.contains(".cubeforge-")));
}
