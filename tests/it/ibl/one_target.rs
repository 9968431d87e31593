//! Issue 48, item 11: an `ibl` output folder is one target's, replaced whole. A run for
//! another target leaves only its own files; a folder holding anything no target wrote is
//! refused before the work and left as it was.

use crate::common::{run, stderr};
use std::path::Path;

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

fn ibl(out: &Path, target: &str) -> std::process::Output {
    run([
        "ibl",
        SKY,
        "-o",
        out.to_str().unwrap(),
        "--target",
        target,
        "--size",
        "16",
        "--samples",
        "4",
    ])
}

#[test]
fn a_folder_holds_one_targets_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ibl");
    let r = ibl(&out, "gltf");
    assert!(r.status.success(), "{}", stderr(&r));
    assert_eq!(
        names(&out),
        ["env_ggx.ktx2", "env_lambertian.ktx2", "lut_ggx.png"]
    );
    // Another target into the same folder: gltf's files go, bevy's are all there is.
    let r = ibl(&out, "bevy");
    assert!(r.status.success(), "{}", stderr(&r));
    assert_eq!(names(&out), ["env_diffuse.ktx2", "env_specular.ktx2"]);
    // And again: no file of the earlier run is called foreign.
    for target in [
        "filament", "unity", "unreal", "godot", "babylon", "three", "generic",
    ] {
        let r = ibl(&out, target);
        assert!(r.status.success(), "{target}: {}", stderr(&r));
    }
    assert_eq!(
        names(&out),
        [
            "env_dfg.png",
            "env_diffuse.ktx2",
            "env_sh.json",
            "env_specular.ktx2"
        ]
    );
    // A file no target wrote: refused before the work, nothing touched.
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let r = ibl(&out, "bevy");
    assert!(!r.status.success());
    assert!(
        stderr(&r).contains("notes.txt, which cubeforge did not write"),
        "{}",
        stderr(&r)
    );
    assert_eq!(
        names(&out),
        [
            "env_dfg.png",
            "env_diffuse.ktx2",
            "env_sh.json",
            "env_specular.ktx2",
            "notes.txt"
        ]
    );
    assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
}
