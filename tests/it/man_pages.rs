//! The man pages in man/ are generated from the clap definitions; this keeps them in sync.
//! Regenerate with `cargo run -- man man`.

use std::path::Path;
use std::process::Command;

#[test]
fn man_pages_match_the_command_line() {
    let tmp = tempfile::tempdir().unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .arg("man")
        .arg(tmp.path())
        .status()
        .unwrap();
    assert!(status.success());
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("man");
    let mut names: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() >= 3, "cubeforge.1 and one page per command");
    for name in names {
        let fresh = std::fs::read_to_string(tmp.path().join(&name)).unwrap();
        let kept = std::fs::read_to_string(repo.join(&name)).unwrap_or_default();
        assert!(
            fresh == kept,
            "man/{} is stale: run `cargo run -- man man`",
            name.to_string_lossy()
        );
    }
}
