//! The engines' own readers on our files (ktx-parse, Babylon's loader, Bevy's loader):
//! skipped when absent (a failure under CI).

use super::*;
use std::process::Command;

#[test]
fn ktx2_files_pass_independent_readers() {
    let Some(tools) = common::ktx_parse() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let out = dir.path().join("bevy");
    ibl(&input, &out, "bevy", &SMALL);
    for (file, levels) in [("env_specular.ktx2", 4), ("env_diffuse.ktx2", 1)] {
        let v = common::ktx_check(&tools, &out.join(file), file);
        assert_eq!(v["faceCount"], 6, "{v}");
        assert_eq!(v["pixelDepth"], 0, "{v}");
        assert_eq!(v["layerCount"], 0, "{v}");
        assert_eq!(v["levelCount"], levels, "{v}");
        assert_eq!(v["rewriteIdentical"], true, "{v}");
    }
}

#[test]
fn babylon_reads_the_ibl_env() {
    let Some(tools) = common::babylon_core() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let out = dir.path().join("babylon");
    ibl(&input, &out, "babylon", &BABYLON);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tools/env_check.mjs");
    let o = Command::new("node")
        .arg(&script)
        .arg(&tools)
        .arg(out.join("env.env"))
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["width"], 32, "{j}");
    assert_eq!(j["levels"], 6, "{j}");
    assert_eq!(j["lodGenerationScale"], 0.8, "{j}");
    assert!(j["irradiance"]["x"].is_array(), "{j}");
}

#[test]
fn bevys_own_loader_takes_the_bevy_files_as_cube_maps() {
    let Some(bevy) = common::bevy_ktx2() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let out = dir.path().join("bevy");
    ibl(&input, &out, "bevy", &SMALL);
    for (file, mips) in [("env_specular.ktx2", 4), ("env_diffuse.ktx2", 1)] {
        let v = common::bevy_check(&bevy, &out.join(file));
        assert_eq!(v["view"], "Cube", "{v}");
        assert_eq!(v["layers"], 6, "{v}");
        assert_eq!(v["mips"], mips, "{v}");
        assert_eq!(v["format"], "Rgba16Float", "{v}");
    }
    // Compressed as Bevy's own example maps are, and as BC6H: still cube maps to Bevy.
    for (format, bevy_name) in [("rgb9e5", "Rgb9e5Ufloat"), ("bc6h", "Bc6hRgbUfloat")] {
        let out = dir.path().join(format);
        let mut args = SMALL.to_vec();
        args.extend(["--gpu-format", format, "--zstd=3"]);
        ibl(&input, &out, "bevy", &args);
        let v = common::bevy_check(&bevy, &out.join("env_specular.ktx2"));
        assert_eq!(v["view"], "Cube", "{v}");
        assert_eq!(v["mips"], 4, "{v}");
        assert_eq!(v["format"], bevy_name, "{v}");
        // And cubeforge reads them back as the same chain.
        let back = read_cube(&out.join("env_specular.ktx2"));
        assert_eq!(back.levels.len(), 4);
    }
}
