//! Benchmark (not a timed test): `cubeforge batch` against the same jobs as separate
//! commands run one after another, as a build script would. The 18 real panoramas of
//! `../shared/fixtures/real/zip/` (skipped cleanly when absent), three targets each (bevy,
//! gltf, filament): 54 jobs. Also the no-op rerun, and Ninja on the emitted build.ninja
//! when `ninja` is installed. Run with `cargo bench --bench batch` (`RAYON_NUM_THREADS=2`
//! for two threads). Targets (issue 29), on 2 cores: batch at least 1.5 times faster than
//! the 54 commands; a no-op rerun under 0.5 s.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

const TARGETS: [&str; 3] = ["bevy", "gltf", "filament"];

fn cubeforge() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cubeforge"))
}

fn timed(what: &str, mut c: Command) -> f64 {
    let t = Instant::now();
    let o = c.output().expect("runs");
    assert!(
        o.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    t.elapsed().as_secs_f64()
}

/// Every file under `dir`, with its bytes, in name order.
fn files(dir: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            }
        }
    }
    out.sort();
    out
}

fn main() {
    let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real/zip");
    let mut inputs: Vec<_> = std::fs::read_dir(&real)
        .map(|r| r.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    inputs.retain(|p: &std::path::PathBuf| p.extension().is_some_and(|e| e == "exr"));
    inputs.sort();
    if inputs.is_empty() {
        println!("SKIPPED: no panoramas in {}", real.display());
        return;
    }
    let tmp = std::env::temp_dir().join(format!("cubeforge-bench-batch-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap();
    let mut manifest = String::new();
    for t in TARGETS {
        manifest.push_str(&format!(
            "[[job]]\ninputs = [{:?}]\ncommand = \"ibl\"\nargs = [\"--target\", \"{t}\"]\n\
             output = \"build/{{stem}}/{t}\"\n\n",
            real.join("*.exr").display().to_string()
        ));
    }
    std::fs::write(tmp.join("assets.toml"), manifest).unwrap();
    let jobs = inputs.len() * TARGETS.len();
    let threads = std::env::var("RAYON_NUM_THREADS").unwrap_or_else(|_| "all".into());
    println!(
        "{} panoramas x {} targets = {jobs} ibl jobs, {threads} threads:",
        inputs.len(),
        TARGETS.len()
    );

    // The jobs as separate commands, one after another.
    let t = Instant::now();
    for input in &inputs {
        let stem = input.file_stem().unwrap().to_string_lossy();
        for target in TARGETS {
            let mut c = cubeforge();
            c.arg("-q").arg("ibl").arg(input).arg("-o");
            c.arg(tmp.join("seq").join(&*stem).join(target));
            c.args(["--target", target]);
            timed("ibl", c);
        }
    }
    let sequential = t.elapsed().as_secs_f64();

    let batch = |extra: &[&str]| {
        let mut c = cubeforge();
        c.args(["-q", "batch"])
            .arg(tmp.join("assets.toml"))
            .args(extra);
        timed("batch", c)
    };
    let first = batch(&[]);
    let noop = batch(&[]);
    assert_eq!(
        files(&tmp.join("build")),
        files(&tmp.join("seq")),
        "batch writes the bytes the commands write"
    );
    println!(
        "  {:<44} {sequential:7.2} s",
        format!("{jobs} commands, one after another")
    );
    println!(
        "  {:<44} {first:7.2} s  ({:.2}x; target 1.5x)",
        "cubeforge batch",
        sequential / first
    );
    println!(
        "  {:<44} {noop:7.3} s  (target 0.5 s)",
        "cubeforge batch again (nothing changed)"
    );

    let has_ninja = Command::new("ninja").arg("--version").output().is_ok();
    if has_ninja {
        let _ = std::fs::remove_dir_all(tmp.join("build"));
        let mut c = cubeforge();
        c.args(["-q", "batch"])
            .arg(tmp.join("assets.toml"))
            .args(["--emit", "ninja"]);
        timed("emit", c);
        let j = rayon_threads();
        let mut c = Command::new("ninja");
        c.arg("-C").arg(&tmp).args(["-j", &j.to_string()]);
        let ninja = timed("ninja", c);
        println!(
            "  {:<44} {ninja:7.2} s  ({:.2}x)",
            format!("ninja -j {j} on the emitted build.ninja"),
            sequential / ninja
        );
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

/// The threads the commands use: RAYON_NUM_THREADS, else the machine's.
fn rayon_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}
