//! Control maps: every source and operation gives exact texel values, resizing uses the filter
//! it promises, `[pack]` moves parameters, bad recipes fail with the recipe's line and leave
//! nothing behind, and the outputs (PNG, EXR, KTX2 with mips, sidecar JSON) read back as written.
//!
//! This module holds the helpers every part uses (baking a recipe, running the command,
//! reading a PNG back); the tests are split by topic below it.

mod errors;
mod images;
mod operations;
mod outputs;
mod read_back;
mod sources;

use cubeforge::internals::control::{self, Recipe, Size, Syntax};
use cubeforge::internals::io::Limits;
use std::path::Path;
use std::process::{Command, Output};

const EPS: f32 = 1e-6;

fn parse_in(dir: &Path, text: &str, syntax: Syntax) -> cubeforge::Result<Recipe> {
    control::parse(text, syntax, Path::new("recipe"), dir, &Limits::default())
}

/// Bakes TOML recipe text at `w` x `h`, images relative to `dir`.
fn bake_in(dir: &Path, text: &str, w: usize, h: usize) -> control::Baked {
    let recipe = parse_in(dir, text, Syntax::Toml).unwrap_or_else(|e| panic!("{e}\n{text}"));
    recipe
        .bake(Some(Size::new(w, h).unwrap()), &Limits::default())
        .unwrap()
}

fn bake(text: &str, w: usize, h: usize) -> control::Baked {
    bake_in(Path::new("."), text, w, h)
}

/// One channel of a baked map (0 R, 1 G, 2 B, 3 A), rows top to bottom.
fn channel(b: &control::Baked, c: usize) -> Vec<f32> {
    b.image.pixels.iter().map(|p| p[c]).collect()
}

/// The reflectivity (R) of `[reflectivity]` given as `source` (a TOML table body).
fn refl(source: &str, w: usize, h: usize) -> Vec<f32> {
    channel(&bake(&format!("[reflectivity]\n{source}\n"), w, h), 0)
}

fn assert_close(got: &[f32], want: &[f32]) {
    assert_eq!(got.len(), want.len(), "length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= EPS,
            "texel {i}: got {g}, want {w}\n{got:?}"
        );
    }
}

fn cubeforge(args: &[&dyn AsRef<std::ffi::OsStr>], cwd: &Path) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubeforge"));
    cmd.current_dir(cwd);
    for a in args {
        cmd.arg(a);
    }
    cmd.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The RGBA8 bytes of a PNG, decoded by the `image` crate (no colour conversion).
fn png8(path: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(path).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba8, "{}", path.display());
    let img = img.to_rgba8();
    (img.width(), img.height(), img.into_raw())
}

fn write_png8(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    image::save_buffer(path, rgba, w, h, image::ExtendedColorType::Rgba8).unwrap();
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}
