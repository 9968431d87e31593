//! The hooks for other runners: depfiles that list exactly what a command read, a
//! build.ninja that real Ninja runs (and a second time finds nothing to do), and shards that
//! together run every job once.

use super::{project, ran, SKY_PNG};
use crate::cli_options::run_ok;
use std::path::Path;
use std::process::Command;

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn depfiles_list_every_file_read() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    project(d);
    let p = d.join("proj");
    // A preview with a decal; a recipe and the mask it names; a folder of faces.
    run_ok(
        &[
            "preview",
            "hdri/a.exr",
            "-o",
            "p.png",
            "--size",
            "16",
            "--decal",
            "decal.png",
            "--material",
            "mirror-decal",
            "--depfile",
            "p.d",
        ],
        &p,
    );
    assert_eq!(
        read(&p.join("p.d")),
        "p.png: \\\n  hdri/a.exr \\\n  decal.png\n"
    );
    run_ok(
        &["control", "r.toml", "-o", "c.png", "--depfile", "deps/c.d"],
        &p,
    );
    assert_eq!(
        read(&p.join("deps/c.d")),
        "c.png: \\\n  r.toml \\\n  masks/m.png\n"
    );
    run_ok(
        &[
            "convert",
            "hdri/a.exr",
            "-o",
            "my faces",
            "--to",
            "faces",
            "--size",
            "8",
            "-q",
        ],
        &p,
    );
    run_ok(
        &[
            "convert",
            "my faces",
            "-o",
            "f.ktx2",
            "--depfile",
            "f.d",
            "-q",
        ],
        &p,
    );
    let faces: String = ["px", "nx", "py", "ny", "pz", "nz"]
        .iter()
        .map(|f| format!(" \\\n  my\\ faces/{f}.exr"))
        .collect();
    assert_eq!(read(&p.join("f.d")), format!("f.ktx2:{faces}\n"));
    // A material file and its decal.
    std::fs::write(
        p.join("mat.toml"),
        "model = \"reflect\"\nreflectivity = 0.5\ndecal = \"decal.png\"\n",
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(["preview", "hdri/b.exr", "-o", "m.png", "--size", "16"])
        .args(["--material", "mat.toml", "--depfile", "m.d"])
        .current_dir(&p)
        .output()
        .unwrap();
    if o.status.success() {
        assert_eq!(
            read(&p.join("m.d")),
            "m.png: \\\n  mat.toml \\\n  hdri/b.exr \\\n  decal.png\n"
        );
    } else {
        panic!("{}", String::from_utf8_lossy(&o.stderr));
    }
    // Standard output has no name; info writes nothing.
    let o = crate::cli_options::run(&["lut", "-o", "-", "--depfile", "x.d"], &p);
    assert_eq!(o.status.code(), Some(1));
    let o = crate::cli_options::run(&["info", "decal.png", "--depfile", "x.d"], &p);
    assert_eq!(o.status.code(), Some(1));
    assert!(!p.join("x.d").exists());
    // batch --depfiles: one beside each output.
    run_ok(&["batch", "m.toml", "--depfiles", "-q"], &p);
    assert_eq!(
        read(&p.join("build/control.png.d")),
        "build/control.png: \\\n  r.toml \\\n  masks/m.png\n"
    );
    assert_eq!(
        read(&p.join("build/c/preview.png.d")),
        "build/c/preview.png: \\\n  hdri/c.exr \\\n  decal.png\n"
    );
    // An up-to-date job's missing depfile comes from its record.
    std::fs::remove_file(p.join("build/control.png.d")).unwrap();
    let o = run_ok(&["batch", "m.toml", "--depfiles"], &p);
    assert!(ran(&o).is_empty());
    assert_eq!(
        read(&p.join("build/control.png.d")),
        "build/control.png: \\\n  r.toml \\\n  masks/m.png\n"
    );
}

/// Ninja, or None where it is missing (a failure under CI, which installs it).
fn ninja() -> Option<&'static str> {
    let found = Command::new("ninja").arg("--version").output().is_ok();
    if !found {
        assert!(
            std::env::var_os("CI").is_none(),
            "ninja is missing (Debian: ninja-build)"
        );
        eprintln!("SKIPPED: ninja is not installed");
        return None;
    }
    Some("ninja")
}

#[test]
fn the_emitted_build_ninja_runs_under_ninja() {
    let Some(ninja) = ninja() else { return };
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    project(d);
    let p = d.join("proj");
    run_ok(&["batch", "m.toml", "--emit", "ninja"], &p);
    let text = read(&p.join("build.ninja"));
    assert_eq!(text.matches("\nbuild build/").count(), 7, "{text}");
    let ninja_run = |args: &[&str]| {
        let o = Command::new(ninja)
            .args(args)
            .current_dir(&p)
            .output()
            .unwrap();
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            o.status.success(),
            "{out}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        out
    };
    let out = ninja_run(&["-j", "2"]);
    assert!(out.contains("[7/7]"), "{out}");
    // The same bytes as batch writes.
    let b = d.join("b");
    std::fs::create_dir_all(&b).unwrap();
    for f in ["hdri", "masks", "decal.png", "r.toml", "m.toml"] {
        let _ = Command::new("cp")
            .args(["-r"])
            .arg(p.join(f))
            .arg(&b)
            .status();
    }
    run_ok(&["batch", "m.toml", "-q"], &b);
    for f in [
        "build/a/box.ktx2",
        "build/c/preview.png",
        "build/control.png",
    ] {
        assert_eq!(
            std::fs::read(p.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    assert!(ninja_run(&[]).contains("no work to do"));
    // The recipe's mask changed: Ninja learnt it from the depfile.
    std::thread::sleep(std::time::Duration::from_millis(20));
    std::fs::write(p.join("masks/m.png"), std::fs::read(SKY_PNG).unwrap()).unwrap();
    let out = ninja_run(&["-n"]);
    assert!(out.contains("[1/1] cubeforge control r.toml"), "{out}");
    ninja_run(&[]);
    assert!(ninja_run(&[]).contains("no work to do"));
}

#[test]
fn shards_run_every_job_once() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    project(d);
    let mut all = Vec::new();
    for i in 0..3 {
        let o = run_ok(&["batch", "proj/m.toml", "--shard", &format!("{i}/3")], d);
        let r = ran(&o);
        // A shard keeps every job of an input together.
        for input in ["hdri/a.exr", "hdri/b.exr", "hdri/c.exr"] {
            let n = r.iter().filter(|l| l.contains(input)).count();
            assert!(n == 0 || n == 2, "{r:?}");
        }
        assert!(d
            .join(format!("proj/m.shard-{i}-of-3.state.json"))
            .is_file());
        all.extend(r);
    }
    all.sort();
    let mut once = all.clone();
    once.dedup();
    assert_eq!(all, once);
    assert_eq!(all.len(), 7, "{all:?}");
    let o = run_ok(&["batch", "proj/m.toml", "--shard", "0/3", "--dry-run"], d);
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("left to other shards"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    for bad in ["3/3", "1", "a/b", "0/0", "0/2:cost"] {
        let o = crate::cli_options::run(&["batch", "proj/m.toml", "--shard", bad], d);
        assert_eq!(o.status.code(), Some(2), "{bad}");
    }
}

/// Shards balanced by cost (issue 52): one 2048 x 1024 panorama among seven 256 x 128 ones on
/// two shards, no shard's texels past max(the largest input, 1.2 x the even share); every
/// input on one shard; `--dry-run` prints each shard's estimate; `I/N:order` deals them out in
/// turn as before (the large one beside three small ones).
#[test]
fn shards_are_balanced_by_cost() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let p = d.join("proj/hdri");
    std::fs::create_dir_all(&p).unwrap();
    let sky = crate::common::read_image(std::path::Path::new(super::SKY_EXR));
    let sizes = [
        (256, 128),
        (256, 128),
        (2048, 1024),
        (256, 128),
        (256, 128),
        (256, 128),
        (256, 128),
        (256, 128),
    ];
    for (k, (w, h)) in sizes.iter().enumerate() {
        let img = cubeforge::Image::from_fn(*w, *h, |x, y| {
            sky.bilinear(
                (x as f32 + 0.5) * sky.width as f32 / *w as f32,
                (y as f32 + 0.5) * sky.height as f32 / *h as f32,
                true,
            )
        });
        crate::common::write_image(&p.join(format!("p{k}.exr")), &img);
    }
    std::fs::write(
        d.join("proj/m.toml"),
        "[[job]]\ninputs = [\"hdri/*.exr\"]\ncommand = \"convert\"\nargs = [\"--to\", \"faces\", \"--size\", \"16\"]\noutput = \"build/{stem}/\"\n",
    )
    .unwrap();
    let texels = |k: usize| (sizes[k].0 * sizes[k].1) as f64;
    let total: f64 = (0..8).map(texels).sum();
    for (split, balanced) in [("", true), (":order", false)] {
        let mut seen = Vec::new();
        let mut loads = Vec::new();
        for i in 0..2 {
            let shard = format!("{i}/2{split}");
            let o = run_ok(&["batch", "proj/m.toml", "--shard", &shard, "--dry-run"], d);
            let out = String::from_utf8_lossy(&o.stdout).into_owned();
            assert!(
                out.contains("shard 0/2:") && out.contains("shard 1/2:"),
                "{out}"
            );
            let mine: Vec<usize> = (0..8)
                .filter(|k| {
                    out.lines()
                        .any(|l| l.contains("would run") && l.contains(&format!("p{k}.exr")))
                })
                .collect();
            loads.push(mine.iter().map(|&k| texels(k)).sum::<f64>());
            seen.extend(mine);
        }
        seen.sort();
        assert_eq!(
            seen,
            (0..8).collect::<Vec<_>>(),
            "every input once ({split})"
        );
        let bound = texels(2).max(1.2 * total / 2.0);
        let worst = loads.iter().cloned().fold(0.0, f64::max);
        println!("shards{split}: texels {loads:?}, bound {bound}");
        assert_eq!(
            worst <= bound,
            balanced,
            "{split}: {loads:?} against {bound}"
        );
    }
}
