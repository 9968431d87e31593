//! Helpers shared by the integration tests: image comparison, running the binary, the real
//! fixtures. Not every test file uses every helper.
#![allow(dead_code)]

use cubeforge::internals::cube::{face_dir, CubeMap, CubeSampler, Environment, Interp};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, ReadOptions, WriteOptions};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Peak signal-to-noise ratio in dB over the RGB channels (alpha ignored), values as they are
/// (clamp them first with [`clamped`] for HDR images). Identical images give infinity.
pub fn psnr(a: &Image, b: &Image, peak: f32) -> f64 {
    psnr_where(a, b, peak, |_, _| true)
}

/// PSNR over the pixels (x, y) for which `keep` is true.
pub fn psnr_where(a: &Image, b: &Image, peak: f32, keep: impl Fn(usize, usize) -> bool) -> f64 {
    assert_same_size(a, b);
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for y in 0..a.height {
        for x in 0..a.width {
            if !keep(x, y) {
                continue;
            }
            let d = a.get(x, y) - b.get(x, y);
            for c in 0..3 {
                sum += (d[c] as f64) * (d[c] as f64);
            }
            n += 3;
        }
    }
    assert!(n > 0, "no pixels to compare");
    let mse = sum / n as f64;
    if mse == 0.0 {
        return f64::INFINITY;
    }
    10.0 * ((peak as f64) * (peak as f64) / mse).log10()
}

/// Largest absolute difference of any RGB channel.
pub fn max_abs_error(a: &Image, b: &Image) -> f32 {
    max_abs_error_where(a, b, |_, _| true)
}

/// Largest absolute RGB difference over the pixels (x, y) for which `keep` is true.
pub fn max_abs_error_where(a: &Image, b: &Image, keep: impl Fn(usize, usize) -> bool) -> f32 {
    assert_same_size(a, b);
    let mut m = 0.0f32;
    for y in 0..a.height {
        for x in 0..a.width {
            if keep(x, y) {
                let d = (a.get(x, y) - b.get(x, y)).abs();
                m = m.max(d.x).max(d.y).max(d.z);
            }
        }
    }
    m
}

/// Every channel clamped to [0, max] (for PSNR of HDR images against a fixed peak).
pub fn clamped(img: &Image, max: f32) -> Image {
    let mut out = img.clone();
    for p in &mut out.pixels {
        *p = p.clamp(glam::Vec4::ZERO, glam::Vec4::splat(max));
    }
    out
}

fn assert_same_size(a: &Image, b: &Image) {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "images to compare differ in size"
    );
}

pub mod ktx2_rule;

/// Runs the `cubeforge` binary with `args`; when it succeeds, every KTX2 it wrote at `-o`
/// keeps the rule of [`ktx2_rule`] (`ktx validate -e` passes it).
pub fn run<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let args: Vec<std::ffi::OsString> = args.into_iter().map(|a| a.as_ref().to_owned()).collect();
    let out = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(&args)
        .output()
        .expect("cubeforge runs");
    if out.status.success() {
        ktx2_rule::check_command(&args);
    }
    out
}

/// Standard error of a run as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The real images of `../shared/fixtures/real`, or None (after saying so) when absent.
pub fn real_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/fixtures/real"
    ));
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipped: ../shared/fixtures/real not found");
        None
    }
}

/// The preview's environment of `path`, opened as the `preview` job opens it (default
/// reading), its load notes left out.
pub fn preview_env(path: &Path) -> cubeforge::Result<cubeforge::internals::preview::LoadedEnv> {
    let input = cubeforge::internals::input::Input::open(
        &[path.to_path_buf()],
        None,
        &ReadOptions::default(),
    )?;
    cubeforge::internals::preview::load_environment(&input).map(|(env, _)| env)
}

/// Reads an image file (NaN, infinite and negative values replaced by 0, as the CLI does).
pub fn read_image(path: &Path) -> Image {
    match cubeforge::internals::convert::read(path, &ReadOptions::default()) {
        Ok((io::Decoded::Image(img), _)) => img,
        Ok((io::Decoded::Cube(_), _)) => panic!("{} holds a cube map", path.display()),
        Err(e) => panic!("{e}"),
    }
}

/// Writes an image in the format its name says (PNG 8-bit sRGB, EXR half float, ...).
pub fn write_image(path: &Path, img: &Image) {
    let bytes = cubeforge::internals::output::encode_image(path, img, &WriteOptions::default())
        .expect("encodes");
    std::fs::write(path, bytes).expect("writes");
}

/// Seam continuity of one level of a cube map: the largest step between the texels either
/// side of any face edge, and the largest step from an edge texel to its neighbour inside
/// the face, as (across, inside).
pub fn seam_steps(cube: &CubeMap, level: usize) -> (f32, f32) {
    let sampler = CubeSampler::new(cube);
    let n = cube.levels[level][0].width;
    let step = 1.0 / n as f32;
    let (mut across_max, mut inside_max) = (0.0f32, 0.0f32);
    for face in 0..6 {
        for i in 0..n {
            let a = (i as f32 + 0.5) * step;
            for (s, t, ds, dt) in [
                (0.5 * step, a, -step, 0.0),
                (1.0 - 0.5 * step, a, step, 0.0),
                (a, 0.5 * step, 0.0, -step),
                (a, 1.0 - 0.5 * step, 0.0, step),
            ] {
                let here = face_dir(face, s, t).normalize();
                let across = face_dir(face, s + ds, t + dt).normalize();
                let inside = face_dir(face, s - ds, t - dt).normalize();
                let v = sampler.sample(here, level, Interp::Bilinear);
                let step_across = (sampler.sample(across, level, Interp::Bilinear) - v).abs();
                let step_inside = (sampler.sample(inside, level, Interp::Bilinear) - v).abs();
                across_max = across_max.max(step_across.max_element());
                inside_max = inside_max.max(step_inside.max_element());
            }
        }
    }
    (across_max, inside_max)
}

/// The mean of one channel over the sphere: each texel weighted by its solid angle.
pub fn sphere_mean(faces: &[Image; 6], channel: usize) -> f64 {
    let n = faces[0].width;
    let table = cubeforge::internals::cube::solid_angle_table(n);
    let mut acc = 0.0f64;
    for f in faces {
        for (p, sa) in f.pixels.iter().zip(&table) {
            acc += p[channel] as f64 * *sa as f64;
        }
    }
    acc / (4.0 * std::f64::consts::PI)
}

// ---------------------------------------------------------------------------------------------
// Independent readers (OpenImageIO, nvddsinfo, ktx-parse, Pillow, texture2ddecoder,
// zstandard). A test that needs one calls
// its finder first: where the reader is missing the test prints a skip line on stderr and
// returns, or fails when CI is set to a true value (.ci/run installs every reader and sets
// CI=true, so a reader that went missing there is a failure, not a silent pass).

/// Whether `CI` holds a true value (`true`, `1`, `yes`; any case), as CI services set it.
pub fn ci() -> bool {
    std::env::var("CI")
        .map(|v| matches!(v.trim().to_ascii_lowercase().as_str(), "true" | "1" | "yes"))
        .unwrap_or(false)
}

/// `found`, or: under CI a failure that names the missing reader; otherwise false after a
/// skip line naming the test, the reader and how to install it.
pub fn reader_found(reader: &str, install: &str, found: bool) -> bool {
    if found {
        return true;
    }
    let test = std::thread::current()
        .name()
        .unwrap_or("this test")
        .to_owned();
    assert!(
        !ci(),
        "{test}: the independent reader {reader} is missing, and CI is set: install it ({install}) or unset CI"
    );
    // Straight to the process's stderr: libtest captures eprintln! of passing tests.
    use std::io::Write;
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED {test}: {reader} not installed ({install}); with CI=true this fails"
    );
    false
}

/// Whether `cmd ARGS` runs (exit status ignored when `any_status`).
fn runs(cmd: &str, args: &[&str], any_status: bool) -> bool {
    Command::new(cmd)
        .args(args)
        .output()
        .is_ok_and(|o| any_status || o.status.success())
}

/// OpenImageIO's `oiiotool`.
pub fn oiiotool() -> bool {
    reader_found(
        "oiiotool",
        "apt-get install openimageio-tools",
        runs("oiiotool", &["--version"], false),
    )
}

/// OpenEXR's `exrenvmap` (Debian's `openexr`; it exits non-zero when given no file).
pub fn exrenvmap() -> bool {
    reader_found(
        "exrenvmap",
        "apt-get install openexr",
        runs("exrenvmap", &["-h"], true),
    )
}

/// OpenEXR's own Python bindings (PyPI `OpenEXR` 3.5, which writes ZSTD), with numpy.
pub fn openexr_python() -> bool {
    reader_found(
        "OpenEXR 3.5 (Python)",
        "python3 -m pip install OpenEXR==3.5.3",
        runs(
            "python3",
            &["-c", "import OpenEXR, numpy; OpenEXR.ZSTD_COMPRESSION"],
            false,
        ),
    )
}

/// Runs a Python `script` (given `dir` as its argument) that writes files with OpenEXR's
/// bindings; panics with its stderr if it fails.
pub fn openexr_script(script: &str, dir: &Path) {
    let o = Command::new("python3")
        .args(["-c", script])
        .arg(dir)
        .output()
        .expect("runs python3");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// OpenEXR's C++ library and headers (Debian's `libopenexr-dev`), with a C++ compiler: for
/// the tools in tests/tools that write and read files through `RgbaOutputFile` and
/// `RgbaInputFile`.
pub fn openexr_cxx() -> bool {
    reader_found(
        "OpenEXR's C++ library (libopenexr-dev) and c++",
        "apt-get install libopenexr-dev g++",
        runs("pkg-config", &["--exists", "OpenEXR"], false) && runs("c++", &["--version"], false),
    )
}

/// Builds `tests/tools/NAME.cpp` against OpenEXR into `dir`; the program's path.
pub fn build_openexr_tool(name: &str, dir: &Path) -> PathBuf {
    let flags = Command::new("pkg-config")
        .args(["--cflags", "--libs", "OpenEXR"])
        .output()
        .expect("runs pkg-config");
    let flags = String::from_utf8_lossy(&flags.stdout).to_string();
    let exe = dir.join(name);
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/tools/{name}.cpp"));
    let o = Command::new("c++")
        .args(["-std=c++17", "-O1", "-o"])
        .arg(&exe)
        .arg(&source)
        .args(flags.split_whitespace())
        .output()
        .expect("runs c++");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    exe
}

/// NVIDIA Texture Tools' `nvddsinfo` (it exits non-zero when given no file).
pub fn nvddsinfo() -> bool {
    reader_found(
        "nvddsinfo",
        "apt-get install libnvtt-bin",
        runs("nvddsinfo", &[], true),
    )
}

/// Python's `texture2ddecoder` (Perfare's BC6H/BC7 decoders, C++): an independent block
/// decoder.
pub fn texture2ddecoder() -> bool {
    reader_found(
        "texture2ddecoder",
        "python3 -m pip install texture2ddecoder",
        runs("python3", &["-c", "import texture2ddecoder"], false),
    )
}

/// Python's `zstandard` (bindings to the reference libzstd): inflates KTX2 levels on its own.
pub fn zstandard() -> bool {
    reader_found(
        "zstandard",
        "python3 -m pip install zstandard",
        runs("python3", &["-c", "import zstandard"], false),
    )
}

/// Python's Pillow with its DDS plugin.
pub fn pillow() -> bool {
    reader_found(
        "Pillow",
        "python3 -m pip install pillow",
        runs("python3", &["-c", "import PIL.DdsImagePlugin"], false),
    )
}

/// The folder holding `node_modules/ktx-parse` ($CUBEFORGE_TOOLS, then target/tools), when
/// node runs too; `tests/tools/ktx_check.mjs` takes it as its first argument.
pub fn ktx_parse() -> Option<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("CUBEFORGE_TOOLS")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    dirs.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("target/tools"));
    let tools = dirs
        .into_iter()
        .find(|d| d.join("node_modules/ktx-parse/package.json").is_file());
    let node = runs("node", &["--version"], false);
    let found = reader_found(
        "ktx-parse (with node)",
        "npm install ktx-parse@2 in target/tools or $CUBEFORGE_TOOLS; node from your system",
        tools.is_some() && node,
    );
    tools.filter(|_| found)
}

/// The folder holding `node_modules/<package>` ($CUBEFORGE_TOOLS, then target/tools), when node
/// runs too.
fn node_package(package: &str, install: &str) -> Option<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::env::var_os("CUBEFORGE_TOOLS")
        .map(PathBuf::from)
        .into_iter()
        .collect();
    dirs.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("target/tools"));
    let tools = dirs.into_iter().find(|d| {
        d.join("node_modules")
            .join(package)
            .join("package.json")
            .is_file()
    });
    let node = runs("node", &["--version"], false);
    let found = reader_found(
        &format!("{package} (with node)"),
        install,
        tools.is_some() && node,
    );
    tools.filter(|_| found)
}

/// The folder holding `node_modules/@babylonjs/core`, for `tests/tools/env_check.mjs`.
pub fn babylon_core() -> Option<PathBuf> {
    node_package(
        "@babylonjs/core",
        "npm install @babylonjs/core@9 in target/tools or $CUBEFORGE_TOOLS; node from your system",
    )
}

/// The folder holding `node_modules/filament` (Filament's web build), for
/// `tests/tools/filament_snippet.cjs`.
pub fn filament_js() -> Option<PathBuf> {
    node_package(
        "filament",
        "npm install filament@1 in target/tools or $CUBEFORGE_TOOLS; node from your system",
    )
}

/// The folder holding `node_modules/three` (three.js's loaders), for
/// `tests/tools/three_uhdr.cjs`.
pub fn three_js() -> Option<PathBuf> {
    node_package(
        "three",
        "npm install three@0.187 in target/tools or $CUBEFORGE_TOOLS; node from your system",
    )
}

/// A C++ compiler (`c++`), to check printed C++ snippets against stand-in declarations.
pub fn cxx() -> bool {
    reader_found(
        "a C++ compiler (c++)",
        "apt-get install g++",
        runs("c++", &["--version"], false),
    )
}

/// The folder holding `node_modules/playcanvas`, for `tests/tools/ktx1_check.mjs`.
pub fn playcanvas() -> Option<PathBuf> {
    node_package(
        "playcanvas",
        "npm install playcanvas@2 in target/tools or $CUBEFORGE_TOOLS; node from your system",
    )
}

/// Python's Pillow (any build: PNG is always there).
pub fn pillow_png() -> bool {
    reader_found(
        "Pillow",
        "python3 -m pip install pillow",
        runs("python3", &["-c", "import PIL.PngImagePlugin"], false),
    )
}

/// A deterministic xorshift64 generator for the seeded mutation tests.
pub struct XorShift(pub u64);

impl XorShift {
    pub fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

/// Bevy's own KTX2 loader, built by `.ci/run` from `tests/tools/bevy_ktx2` into
/// `target/tools/bevy_ktx2` (its path, when built).
pub fn bevy_ktx2() -> Option<PathBuf> {
    let bin = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/tools/bevy_ktx2/release/bevy_ktx2_check");
    let found = reader_found(
        "Bevy's KTX2 loader (bevy_image)",
        "cargo build --release --locked --manifest-path tests/tools/bevy_ktx2/Cargo.toml --target-dir target/tools/bevy_ktx2",
        bin.is_file(),
    );
    found.then_some(bin)
}

/// What Bevy's own KTX2 loader (found by [`bevy_ktx2`]) makes of `file`, as the JSON
/// `tests/tools/bevy_ktx2` prints (view, layers, mips, format); panics with the loader's
/// message when it refuses the file.
pub fn bevy_check(bin: &Path, file: &Path) -> serde_json::Value {
    let o = Command::new(bin)
        .arg(file)
        .output()
        .expect("run Bevy's loader");
    assert!(
        o.status.success(),
        "Bevy's loader refused {}: {}",
        file.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("bevy_ktx2_check prints JSON")
}

/// What ktx-parse (found by [`ktx_parse`] in `tools`) reads in `file`, as the JSON
/// `tests/tools/ktx_check.mjs` prints; panics with ktx-parse's message and `what` when it fails.
pub fn ktx_check(tools: &Path, file: &Path, what: &str) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tools/ktx_check.mjs");
    let out = Command::new("node")
        .arg(&script)
        .arg(tools)
        .arg(file)
        .output()
        .expect("run node");
    assert!(
        out.status.success(),
        "ktx-parse failed on {what}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("ktx_check.mjs prints JSON")
}
