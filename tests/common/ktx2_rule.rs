//! The rule every KTX2 cubeforge writes keeps: `ktx validate -e` (KTX-Software, warnings as
//! errors) passes it. Its key/value data holds only keys the KTX 2.0 specification defines
//! (any other is warning 7010, an unknown `KTX`/`ktx` one error 7009), sorted, each once,
//! with `KTXwriter` (7125 when missing); cubeforge's own keys only when `--cubeforge-keys`
//! asked for them. Checked here in Rust on every KTX2 a test's command writes
//! ([`super::run`]), and by `ktx validate -e` too where it is on PATH.

use std::path::{Path, PathBuf};

/// The keys the KTX 2.0 specification defines (section 5.6).
pub const KTX_KEYS: [&str; 10] = [
    "KTXcubemapIncomplete",
    "KTXorientation",
    "KTXglFormat",
    "KTXdxgiFormat__",
    "KTXmetalPixelFormat",
    "KTXswizzle",
    "KTXwriter",
    "KTXwriterScParams",
    "KTXastcDecodeMode",
    "KTXanimData",
];

/// What is wrong with the key/value data of the KTX2 `bytes` (None: nothing). `cubeforge_keys`:
/// keys starting `cubeforge.` were asked for.
pub fn key_problem(bytes: &[u8], cubeforge_keys: bool) -> Option<String> {
    let meta = cubeforge::internals::io::ktx2::metadata(bytes);
    let keys: Vec<&str> = meta.iter().map(|(k, _)| k.as_str()).collect();
    for k in &keys {
        let ours = cubeforge_keys && k.starts_with("cubeforge.");
        if !KTX_KEYS.contains(k) && !ours {
            return Some(format!(
                "key {k:?} is not the KTX 2.0 specification's (7010/7009)"
            ));
        }
    }
    if !keys.contains(&"KTXwriter") {
        return Some("no KTXwriter (7125)".into());
    }
    if keys.windows(2).any(|w| w[0].as_bytes() >= w[1].as_bytes()) {
        return Some(format!("keys not sorted, or repeated: {keys:?}"));
    }
    for (k, v) in &meta {
        if std::str::from_utf8(v).is_err() && (k == "KTXwriter" || k == "KTXorientation") {
            return Some(format!("{k}'s value is not UTF-8"));
        }
    }
    None
}

/// Panics when the KTX2 at `path` breaks the rule, or when `ktx validate -e` (if installed)
/// rejects it.
pub fn check_file(path: &Path, cubeforge_keys: bool) {
    let bytes = std::fs::read(path).unwrap();
    if let Some(why) = key_problem(&bytes, cubeforge_keys) {
        panic!("{}: {why}", path.display());
    }
    if !cubeforge_keys && ktx_tool() {
        let out = std::process::Command::new("ktx")
            .args(["validate", "-e"])
            .arg(path)
            .output()
            .expect("ktx runs");
        assert!(
            out.status.success(),
            "ktx validate -e {}: {}{}",
            path.display(),
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// Whether KTX-Software's `ktx` is on PATH (it is not packaged: most runs check in Rust alone).
pub fn ktx_tool() -> bool {
    static FOUND: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *FOUND.get_or_init(|| {
        std::process::Command::new("ktx")
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Every `.ktx2` at or under `path` (a file, or a folder an output went into).
pub fn ktx2_files(path: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if path.is_dir() {
        if let Ok(entries) = std::fs::read_dir(path) {
            for e in entries.flatten() {
                out.extend(ktx2_files(&e.path()));
            }
        }
    } else if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ktx2"))
        && path.is_file()
    {
        out.push(path.to_path_buf());
    }
    out
}

/// After a successful command `args`: every KTX2 its `-o`/`--output` names (or holds) keeps
/// the rule.
pub fn check_command(args: &[std::ffi::OsString]) {
    let keys = args.iter().any(|a| a == "--cubeforge-keys");
    let outputs = args
        .windows(2)
        .filter(|w| w[0] == "-o" || w[0] == "--output")
        .map(|w| PathBuf::from(&w[1]));
    for out in outputs {
        for file in ktx2_files(&out) {
            check_file(&file, keys);
        }
    }
}
