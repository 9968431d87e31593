//! `cubeforge view`: the page's GPU pictures (headless Chromium, WebGL2 on SwiftShader, driven
//! by `tests/tools/view_shot.cjs`) against `cubeforge preview` with the same options, two
//! independent implementations of the same shaders; the page's own error message for broken
//! data; a 512-face chain's load time; `--single-file`; `--serve`; the command line's refusals.
//!
//! This module holds the helpers: finding the browser, rendering many queries of one page in
//! one browser launch (a launch costs about a second, each page load's shader compile on
//! SwiftShader about two), PSNR of 8-bit PNGs, and the work folders
//! (under the target's tmp folder, kept when a test fails so its pictures can be looked at).

mod against_cpu;
mod command_line;
mod inspect;
mod page;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

pub(crate) const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");
pub(crate) const SKY_PNG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");
pub(crate) const CHROME_AND_PAINT: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/fixtures/control/chrome_and_paint.toml"
);
pub(crate) const FROSTED_GLASS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/fixtures/control/frosted_glass.toml"
);
const SHOT_TOOL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/tools/view_shot.cjs");

/// Runs `cubeforge ARGS` in `dir`; panics with its stderr unless it succeeds.
pub(crate) fn cubeforge(args: &[&str], dir: &Path) -> Output {
    crate::cli_options::run_ok(args, dir)
}

// ---------------------------------------------------------------------------------------------
// The browser.

/// Whether node, Chromium ($CHROMIUM, else /usr/bin/chromium or `chromium` on the PATH) and
/// puppeteer-core (target/tools/node_modules, where view_shot.cjs loads it) are all here. Where
/// one is missing: under CI (which installs them: .ci/run) the test fails naming it; otherwise
/// a `SKIPPED` line and false.
pub(crate) fn browser() -> bool {
    let node = Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    let chromium = chromium().is_some();
    let puppeteer = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/tools/node_modules/puppeteer-core/package.json")
        .is_file();
    let missing: Vec<&str> = [
        (!node, "node"),
        (!chromium, "chromium"),
        (!puppeteer, "puppeteer-core"),
    ]
    .iter()
    .filter(|(m, _)| *m)
    .map(|(_, n)| *n)
    .collect();
    crate::common::reader_found(
        &format!("headless Chromium for view's page (missing: {})", missing.join(", ")),
        "Debian: apt-get install chromium; npm install puppeteer-core@24 in target/tools; node from your system (bash .ci/run does all three)",
        missing.is_empty(),
    )
}

/// The Chromium that view_shot.cjs launches.
fn chromium() -> Option<PathBuf> {
    if let Some(c) = std::env::var_os("CHROMIUM") {
        return Some(PathBuf::from(c)).filter(|p| p.is_file());
    }
    let default = PathBuf::from("/usr/bin/chromium");
    if default.is_file() {
        return Some(default);
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("chromium"))
            .find(|p| p.is_file())
    })
}

/// What the page gave for one query.
#[derive(Debug, Clone)]
pub(crate) enum Shot {
    /// The frame was drawn: its canvas as a PNG, and the ms from navigation to the frame.
    Ready { png: PathBuf, ms: u64 },
    /// The page set window.cubeforgeError; `shown` is the text of its #status line.
    Error { error: String, shown: String },
}

impl Shot {
    /// The picture, or a panic that says what the page showed instead.
    pub(crate) fn png(&self, what: &str) -> &Path {
        match self {
            Shot::Ready { png, .. } => png,
            Shot::Error { error, shown } => {
                panic!("{what}: the page failed instead of drawing: {error} (shown: {shown:?})")
            }
        }
    }
}

/// Opens `page` once per query in one headless Chromium launch; `out`/0.png, 1.png, ... in
/// query order. Panics (with the tool's output) when the tool itself fails.
pub(crate) fn shoot(page: &Path, out: &Path, queries: &[String]) -> Vec<Shot> {
    std::fs::create_dir_all(out).unwrap();
    // The page's tone curve is ACES for an HDR input where the query names none; preview's
    // is none: a query that names none gets preview's, unless it asks for the page's own
    // default with the fragment `#hdr-default` (which the page's query does not see).
    let queries: Vec<String> = queries
        .iter()
        .map(|q| {
            if q.contains("tonemap=") || q.contains("#hdr-default") {
                q.clone()
            } else {
                format!("{q}&tonemap=none")
            }
        })
        .collect();
    let queries = &queries[..];
    let start = std::time::Instant::now();
    let o = Command::new("node")
        .arg(SHOT_TOOL)
        .arg(page)
        .arg(out)
        .args(queries)
        .output()
        .expect("node runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with('{')).collect();
    assert!(
        o.status.success() && lines.len() == queries.len(),
        "view_shot.cjs on {} ({} queries) failed: {}\nstdout: {stdout}\nstderr: {}",
        page.display(),
        queries.len(),
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!(
        "view_shot.cjs: {} queries of {} in {:.1} s",
        queries.len(),
        page.display(),
        start.elapsed().as_secs_f64()
    );
    lines
        .iter()
        .enumerate()
        .map(|(i, line)| {
            let v: serde_json::Value = serde_json::from_str(line)
                .unwrap_or_else(|e| panic!("view_shot.cjs printed {line:?}: {e}"));
            if v["ready"] == true {
                assert_eq!(v["title"], "ready", "{}: {line}", queries[i]);
                Shot::Ready {
                    png: out.join(format!("{i}.png")),
                    ms: v["ms"].as_u64().expect("ms"),
                }
            } else {
                Shot::Error {
                    error: v["error"].as_str().unwrap_or_default().to_owned(),
                    shown: v["shown"].as_str().unwrap_or_default().to_owned(),
                }
            }
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Pictures.

/// An 8-bit PNG as RGB (alpha dropped).
pub(crate) fn rgb(p: &Path) -> image::RgbImage {
    image::open(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .to_rgb8()
}

/// PSNR in dB of two 8-bit RGB pictures of one size (peak 255); identical: infinity.
pub(crate) fn psnr_rgb(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions(), "pictures differ in size");
    let sum: f64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(&x, &y)| (x as f64 - y as f64).powi(2))
        .sum();
    let mse = sum / a.as_raw().len() as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

/// PSNR in dB of two 8-bit PNGs.
pub(crate) fn psnr(a: &Path, b: &Path) -> f64 {
    let (x, y) = (rgb(a), rgb(b));
    assert_eq!(
        x.dimensions(),
        y.dimensions(),
        "{} and {} differ in size",
        a.display(),
        b.display()
    );
    psnr_rgb(&x, &y)
}

// ---------------------------------------------------------------------------------------------
// Comparing with preview.

/// One picture to compare: a page query, the `preview` options that render the same, and the
/// lowest PSNR it may have.
#[derive(Debug, Clone)]
pub(crate) struct Case {
    pub query: String,
    pub preview: Vec<String>,
    pub min_db: f64,
}

impl Case {
    /// A query whose keys are all preview options (material, size, exposure, tonemap,
    /// lod_bias, yaw, pitch, fov, distance, samples): preview takes the same.
    pub(crate) fn same(query: &str, min_db: f64) -> Case {
        let mut preview = Vec::new();
        for pair in query.split('&') {
            let (k, v) = pair.split_once('=').expect("key=value");
            let flag = match k {
                "material" | "size" | "exposure" | "tonemap" | "yaw" | "pitch" | "fov"
                | "distance" | "samples" => k.to_owned(),
                "lod_bias" => "lod-bias".to_owned(),
                _ => panic!("{k} is no preview option: give the case its preview arguments"),
            };
            preview.push(format!("--{flag}"));
            preview.push(v.to_owned());
        }
        Case {
            query: query.to_owned(),
            preview,
            min_db,
        }
    }

    /// A query and the preview arguments (beside input and output) that render the same.
    pub(crate) fn with(query: &str, preview: &[&str], min_db: f64) -> Case {
        Case {
            query: query.to_owned(),
            preview: preview.iter().map(|s| s.to_string()).collect(),
            min_db,
        }
    }
}

/// What one case measured.
pub(crate) struct Measured {
    pub case: Case,
    pub gpu: PathBuf,
    pub cpu: PathBuf,
    pub db: f64,
}

/// Renders every case's CPU picture with `cubeforge preview INPUT -o DIR/cpu/N.png ARGS
/// EXTRA` (run in `dir`) and measures it against the GPU shot of the same query.
pub(crate) fn measure(
    dir: &Path,
    input: &str,
    extra: &[&str],
    cases: &[Case],
    shots: &[Shot],
) -> Vec<Measured> {
    assert_eq!(cases.len(), shots.len());
    let cpu_dir = dir.join("cpu");
    std::fs::create_dir_all(&cpu_dir).unwrap();
    // One after another: preview spreads each picture over the cores itself.
    let cpu: Vec<PathBuf> = cases
        .iter()
        .enumerate()
        .map(|(i, case)| {
            let out = cpu_dir.join(format!("{i}.png"));
            let o = out.to_str().unwrap();
            let mut args: Vec<&str> = vec!["preview", input, "-o", o];
            args.extend(case.preview.iter().map(String::as_str));
            args.extend_from_slice(extra);
            args.push("-q");
            cubeforge(&args, dir);
            out
        })
        .collect();
    cases
        .iter()
        .zip(shots)
        .zip(cpu)
        .map(|((case, shot), cpu)| {
            let gpu = shot.png(&case.query).to_path_buf();
            Measured {
                db: psnr(&gpu, &cpu),
                case: case.clone(),
                gpu,
                cpu,
            }
        })
        .collect()
}

/// docs/view.md's figure `view KEY`: the PSNR of `dbs` in whole dB ("A to B dB" for a group).
pub(crate) fn quote(key: &str, dbs: &[f64]) {
    let lo = dbs.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = dbs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let text = if dbs.len() == 1 {
        format!("{lo:.0} dB")
    } else {
        format!("{lo:.0} to {hi:.0} dB")
    };
    crate::figures::check("docs/view.md", &format!("view {key}"), &text);
}

/// Prints every case's PSNR (shown with --nocapture, and when the test fails) and fails,
/// listing each case under its threshold with the two pictures' paths.
pub(crate) fn assert_thresholds(what: &str, measured: &[Measured]) {
    let mut report = String::new();
    let mut failed = Vec::new();
    for m in measured {
        report.push_str(&format!(
            "  {:>6.1} dB (min {:>4.1})  {}\n",
            m.db, m.case.min_db, m.case.query
        ));
        if m.db.is_nan() || m.db < m.case.min_db {
            failed.push(format!(
                "{}: {:.1} dB < {:.1} dB (GPU {}, CPU {})",
                m.case.query,
                m.db,
                m.case.min_db,
                m.gpu.display(),
                m.cpu.display()
            ));
        }
    }
    eprint!("view vs preview, {what}:\n{report}");
    assert!(
        failed.is_empty(),
        "{what}: GPU and CPU pictures differ:\n{}",
        failed.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// Work folders.

/// This process's folder under the target's tmp folder; folders that earlier runs left (the
/// pictures of failed tests) are removed once their process is gone.
fn root() -> &'static Path {
    static ROOT: OnceLock<PathBuf> = OnceLock::new();
    ROOT.get_or_init(|| {
        let base = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view");
        if Path::new("/proc/self").exists() {
            for e in std::fs::read_dir(&base).into_iter().flatten().flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                let gone = name
                    .strip_prefix('p')
                    .and_then(|pid| pid.parse::<u32>().ok())
                    .is_some_and(|pid| !Path::new("/proc").join(pid.to_string()).exists());
                if gone {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let dir = base.join(format!("p{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

/// A fresh folder for one test. Kept when the test fails (its pictures are named in the
/// failure); [`done`] removes it when the test has passed.
pub(crate) fn work(name: &str) -> PathBuf {
    let dir = root().join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Removes a passed test's folder.
pub(crate) fn done(dir: &Path) {
    let _ = std::fs::remove_dir_all(dir);
}
