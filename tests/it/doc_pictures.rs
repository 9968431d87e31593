//! The documentation pictures (docs/*.png) are current: `docs/pictures.sh` renders every one
//! of them again, into a temporary folder (never over the tracked files), and each tracked
//! picture must match its fresh copy within a tolerance. Pictures of the real photographs are
//! skipped, with a SKIPPED line, where `../shared/fixtures/real` is absent.

use std::path::Path;
use std::process::Command;

/// Mean absolute difference allowed per channel, in 8-bit levels: outputs are the same bits on
/// every run and thread count, so this only leaves room for another platform's maths library.
const MEAN_LEVELS: f64 = 0.1;
/// Largest difference allowed at any one pixel and channel, in 8-bit levels.
const MAX_LEVELS: u8 = 16;

#[test]
fn doc_pictures_are_current() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let docs = repo.join("docs");
    let tmp = tempfile::tempdir().unwrap();
    let out = Command::new("bash")
        .arg(docs.join("pictures.sh"))
        .arg(env!("CARGO_BIN_EXE_cubeforge"))
        .arg(tmp.path())
        .output()
        .expect("bash runs");
    let said = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "docs/pictures.sh failed:\n{said}");
    let have_real = repo.join("../shared/fixtures/real").is_dir();

    let pngs = |dir: &Path| -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".png"))
            .collect();
        names.sort();
        names
    };
    let tracked = pngs(&docs);
    assert!(tracked.len() >= 5, "{tracked:?}");
    for name in pngs(tmp.path()) {
        assert!(
            tracked.contains(&name),
            "docs/pictures.sh makes {name}, which docs/ does not hold"
        );
    }
    for name in &tracked {
        let fresh = tmp.path().join(name);
        // The viewer's screenshot (a browser's page: its fonts vary by machine) is checked
        // for its size and roughly its content; it needs a browser, which CI installs.
        let screenshot = name.starts_with("view_");
        if !fresh.exists() {
            assert!(
                (!have_real || (screenshot && std::env::var_os("CI").is_none()))
                    && said.contains(&format!("skipped: {name} ")),
                "docs/{name} is not made by docs/pictures.sh"
            );
            // Why, as docs/pictures.sh said it: what is missing for this picture.
            let why = said
                .lines()
                .find_map(|l| l.strip_prefix(&format!("skipped: {name} ")))
                .unwrap_or("not made");
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED docs/{name}: {why}");
            continue;
        }
        let (mean, max) = difference(&docs.join(name), &fresh);
        println!("docs/{name}: mean difference {mean:?} levels, largest {max}");
        if screenshot {
            assert!(
                mean.iter().all(|&m| m <= 4.0),
                "docs/{name} is stale (mean difference per channel {mean:?} levels): run `bash docs/pictures.sh target/release/cubeforge`"
            );
            continue;
        }
        assert!(
            mean.iter().all(|&m| m <= MEAN_LEVELS) && max <= MAX_LEVELS,
            "docs/{name} is stale (mean difference per channel {mean:?} levels, largest {max}): \
             run `bash docs/pictures.sh target/release/cubeforge`"
        );
    }
}

/// Per channel the mean absolute difference of two 8-bit RGBA pictures, and the largest.
fn difference(path: &Path, b: &Path) -> ([f64; 4], u8) {
    let a = image::open(path).unwrap().to_rgba8();
    let b = image::open(b).unwrap().to_rgba8();
    assert_eq!(
        a.dimensions(),
        b.dimensions(),
        "{} changed size: the picture is stale",
        path.display()
    );
    let mut sum = [0u64; 4];
    let mut max = 0u8;
    for (p, q) in a.pixels().zip(b.pixels()) {
        for c in 0..4 {
            let d = p[c].abs_diff(q[c]);
            sum[c] += d as u64;
            max = max.max(d);
        }
    }
    let n = (a.width() * a.height()) as f64;
    (sum.map(|s| s as f64 / n), max)
}
