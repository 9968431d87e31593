//! Errors: the recipe's line, a non-zero exit, nothing written.

use super::*;

/// Runs `control` on a recipe file holding `text`; returns stderr after checking the exit
/// status and that the folder holds nothing but the recipe (and `keep`).
fn fails(name: &str, text: &str, keep: &[(&str, &[u8])]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (n, bytes) in keep {
        std::fs::write(dir.path().join(n), bytes).unwrap();
    }
    let recipe = dir.path().join(name);
    std::fs::write(&recipe, text).unwrap();
    let before = files_in(dir.path());
    for out in ["out.png", "out.ktx2", "out.exr"] {
        let o = cubeforge(&[&"control", &name, &"-o", &out], dir.path());
        assert!(!o.status.success(), "{name} should fail:\n{text}");
        assert_eq!(o.status.code(), Some(1));
        assert_eq!(files_in(dir.path()), before, "nothing may be written");
        let e = stderr(&o);
        assert!(e.starts_with("cubeforge: error: "), "{e}");
        assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    let o = cubeforge(&[&"control", &name, &"-o", &"out.png"], dir.path());
    stderr(&o)
}

#[test]
fn a_missing_image_names_its_line() {
    let e = fails(
        "r.toml",
        "size = 8\n\n[reflectivity]\nconstant = 1\n\n[blur]\nimage = { path = \"paint/mask.png\", channel = \"r\" }\n",
        &[],
    );
    assert!(e.contains("r.toml: line 7:"), "{e}");
    assert!(
        e.contains("paint/mask.png") && e.contains("not found"),
        "{e}"
    );
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"reflectivity\": {\n    \"image\": {\n      \"channel\": \"r\",\n      \"path\": \"nope.png\"\n    }\n  }\n}\n",
        &[],
    );
    assert!(
        e.contains("r.json: line 6:") && e.contains("nope.png"),
        "{e}"
    );
    // A file that is there but is no image: its decode error, still with the line.
    let e = fails(
        "r.toml",
        "size = 8\n[fresnel]\nimage = { path = \"bad.png\" }\n",
        &[("bad.png", b"not a png")],
    );
    assert!(e.contains("line 3:") && e.contains("bad.png"), "{e}");
}

#[test]
fn an_unknown_channel_names_its_line() {
    let png = {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.png");
        write_png8(&p, 1, 1, &[1, 2, 3, 4]);
        std::fs::read(p).unwrap()
    };
    let e = fails(
        "r.toml",
        "size = 8\n[reflectivity]\nimage = { path = \"m.png\", channel = \"x\" }\n",
        &[("m.png", &png)],
    );
    assert!(
        e.contains("line 3:") && e.contains("unknown variant `x`"),
        "{e}"
    );
    // A channel of the packing that does not exist.
    let e = fails(
        "r.toml",
        "size = 8\n\n[pack]\nr = \"blur\"\nq = \"fresnel\"\n",
        &[],
    );
    assert!(
        e.contains("line 5:") && e.contains("unknown field `q`"),
        "{e}"
    );
    // A parameter that does not exist, as a channel's content.
    let e = fails("r.toml", "size = 8\n[pack]\ng = \"roughness\"\n", &[]);
    assert!(e.contains("line 3:") && e.contains("roughness"), "{e}");
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"pack\": {\n    \"x\": \"blur\"\n  }\n}\n",
        &[],
    );
    assert!(e.contains("line 4:") && e.contains("`x`"), "{e}");
}

#[test]
fn an_unknown_parameter_names_its_line() {
    let e = fails(
        "r.toml",
        "size = 8\nreflectivity = 1\nroughness = 0.5\n",
        &[],
    );
    assert!(
        e.contains("line 3:") && e.contains("unknown field `roughness`"),
        "{e}"
    );
    // ... or an unknown key in a source or operation.
    let e = fails(
        "r.toml",
        "size = 8\n[blur]\nchecker = { cells = [2, 2] }\nremap = { in = [0, 1], levels = 3 }\n",
        &[],
    );
    assert!(
        e.contains("line 4:") && e.contains("unknown field `levels`"),
        "{e}"
    );
    let e = fails(
        "r.toml",
        "size = 8\n[blur]\n\n[blur.checker]\ncells = [2, 2]\ncolour = 1\n",
        &[],
    );
    assert!(e.contains("line 6:") && e.contains("colour"), "{e}");
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"reflectivity\": {\n    \"noise\": { \"seed\": 3 },\n    \"blend\": 1\n  }\n}\n",
        &[],
    );
    assert!(e.contains("line 5:") && e.contains("`blend`"), "{e}");
}

#[test]
fn a_value_outside_0_1_names_its_line() {
    let e = fails("r.toml", "size = 8\nreflectivity = 0.5\nblur = 1.5\n", &[]);
    assert!(
        e.contains("line 3:") && e.contains("1.5 is outside [0, 1]"),
        "{e}"
    );
    let e = fails(
        "r.toml",
        "size = 8\n\n[fresnel]\nlinear_gradient = { from = [0, 0], to = [1, -0.5] }\n",
        &[],
    );
    assert!(
        e.contains("line 4:") && e.contains("-0.5 is outside [0, 1]"),
        "{e}"
    );
    let e = fails(
        "r.toml",
        "size = 8\n[reflectivity]\nconstant = 0.5\nremap = { in = [0, 1],\n  out = [0, 2] }\n",
        &[],
    );
    assert!(e.contains("line 5:") && e.contains("2 is outside"), "{e}");
    let e = fails(
        "r.toml",
        "size = 8\n[reflectivity]\nconstant = 0\n[reflectivity.mix]\nwith = 1\namount = 7\n",
        &[],
    );
    assert!(e.contains("line 6:") && e.contains("7 is outside"), "{e}");
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"transmittance\": {\n    \"constant\":\n      -1\n  }\n}\n",
        &[],
    );
    assert!(
        e.contains("r.json: line 5:") && e.contains("-1 is outside"),
        "{e}"
    );
    // Other bounded numbers say what they need.
    let e = fails(
        "r.toml",
        "size = 8\nfresnel = { noise = { octaves = 0 } }\n",
        &[],
    );
    assert!(e.contains("line 2:") && e.contains("octaves"), "{e}");
    let e = fails("r.toml", "size = 8\nmax_lod_bias = -1\n", &[]);
    assert!(e.contains("line 2:") && e.contains("max_lod_bias"), "{e}");
}

#[test]
fn other_recipe_errors() {
    // TOML syntax.
    let e = fails("r.toml", "size = 8\nreflectivity = [0.5\n", &[]);
    assert!(e.contains("line 2:"), "{e}");
    // JSON syntax.
    let e = fails("r.json", "{\n  \"size\": 8,\n  \"blur\" 1\n}\n", &[]);
    assert!(e.contains("line 3:"), "{e}");
    // Two kinds in one source, or none.
    let e = fails(
        "r.toml",
        "size = 8\n[blur]\nchecker = {}\nnoise = {}\n",
        &[],
    );
    assert!(e.contains("exactly one"), "{e}");
    let e = fails("r.toml", "size = 8\n[blur]\ninvert = true\n", &[]);
    assert!(e.contains("needs one of"), "{e}");
    // Blur without the LOD bias it is a fraction of.
    let e = fails("r.toml", "size = 8\nblur = 0.5\n", &[]);
    assert!(e.contains("max_lod_bias"), "{e}");
    // No size anywhere.
    let e = fails("r.toml", "reflectivity = 0.5\n", &[]);
    assert!(e.contains("no size"), "{e}");
    // A JSON array is not a recipe (serde would read a struct from it by position).
    let e = fails("r.json", "[8, 2]\n", &[]);
    assert!(e.contains("line 1:") && e.contains("one object"), "{e}");
    // Not a recipe extension.
    let e = fails("r.yaml", "size: 8\n", &[]);
    assert!(e.contains(".toml or .json"), "{e}");
}

#[test]
fn bad_options_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("r.toml");
    std::fs::write(&recipe, "size = 8\nreflectivity = 1\n").unwrap();
    for args in [
        vec!["-o", "out.jpg"],
        vec!["-o", "out.dds"],
        vec!["-o", "out.png", "--size", "0x4"],
        vec!["-o", "out.png", "--size", "big"],
        vec!["-o", "out.ktx2", "--gpu-format", "rgba8-srgb"],
        vec!["-o", "out.exr", "--png16"],
        vec!["-o", "out.ktx2", "--levels", "9"],
        vec!["-o", "r.toml.png", "--size", "60000x60000"],
        vec!["-o", "r.toml"],
    ] {
        let mut full: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"control", &"r.toml"];
        for a in &args {
            full.push(a);
        }
        let o = cubeforge(&full, dir.path());
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
        assert_eq!(files_in(dir.path()), ["r.toml"], "{args:?}");
    }
}
