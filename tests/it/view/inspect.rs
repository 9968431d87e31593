//! The rest of the page against the CPU: per-vertex shading and Brennan's finite radius
//! against `preview`, the cross layout against `convert --to hcross`, an `ibl` folder's
//! chain with its engine's mapping against `preview --target`; and the inspection views
//! (seams, a sweep row) and a lone control map draw. Thresholds: 45 dB, 40 dB with a LOD
//! bias on the per-vertex mesh (measured: per-vertex 58-61, parallax 70.5, the cross 70, the
//! glTF folder 72.9).

use super::against_cpu::{page_vs_preview, GAUSSIAN_CHAIN};
use super::{assert_thresholds, browser, cubeforge, done, psnr, rgb, shoot, work, Case};
use super::{CHROME_AND_PAINT, SKY_EXR};

#[test]
fn per_vertex_shading_and_a_finite_radius_match_preview() {
    if !browser() {
        return;
    }
    let cases = [
        Case::with(
            "material=chrome&size=128&shading=per-vertex&tessellation=8",
            &[
                "--material",
                "chrome",
                "--size",
                "128",
                "--shading",
                "per-vertex",
                "--tessellation",
                "8",
            ],
            45.0,
        ),
        Case::with(
            "material=crystal&size=128&shading=per-vertex",
            &[
                "--material",
                "crystal",
                "--size",
                "128",
                "--shading",
                "per-vertex",
            ],
            45.0,
        ),
        Case::with(
            "material=chrome&size=128&shading=per-vertex&tessellation=8&lod_bias=2",
            &[
                "--material",
                "chrome",
                "--size",
                "128",
                "--shading",
                "per-vertex",
                "--tessellation",
                "8",
                "--lod-bias",
                "2",
            ],
            40.0,
        ),
        Case::with(
            "material=chrome&size=128&env_radius=3",
            &["--material", "chrome", "--size", "128", "--env-radius", "3"],
            45.0,
        ),
        Case::with(
            "material=glass&size=128&env_radius=2&env_center=0.5,0,0&parallax=exact",
            &[
                "--material",
                "glass",
                "--size",
                "128",
                "--env-radius",
                "2",
                "--env-center",
                "0.5,0,0",
                "--parallax",
                "exact",
            ],
            45.0,
        ),
    ];
    let (dir, m) = page_vs_preview("vertex", "chain.ktx2", &[GAUSSIAN_CHAIN], &[], &[], &cases);
    assert_thresholds("per-vertex shading and Brennan's correction", &m);
    super::quote("per-vertex", &m.iter().map(|m| m.db).collect::<Vec<_>>());
    done(&dir);
}

#[test]
fn the_cross_an_ibl_folder_and_the_inspection_views() {
    if !browser() {
        return;
    }
    let dir = work("inspect");
    let ok = |args: &[&str]| {
        let o = cubeforge(args, &dir);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    ok(&["view", SKY_EXR, "-o", "sky", "-q"]);
    ok(&[
        "convert",
        SKY_EXR,
        "-o",
        "cross.png",
        "--to",
        "hcross",
        "--size",
        "128",
        "-q",
    ]);
    let queries: Vec<String> = [
        "layout=cross&size=512&samples=1",
        "material=chrome&size=128&seams=1",
        "material=gold&size=96&sweep=1",
        "material=chrome&size=96&sweep=1",
    ]
    .map(String::from)
    .to_vec();
    let shots = shoot(&dir.join("sky/index.html"), &dir.join("gpu"), &queries);
    // The cross: cubeforge's hcross, face for face (docs/view.md quotes it).
    let db = psnr(shots[0].png("the cross"), &dir.join("cross.png"));
    assert!(
        db >= 45.0,
        "the cross against convert --to hcross: {db:.1} dB"
    );
    super::quote("cross", &[db]);
    // Seams tint the sphere: not the plain picture.
    let plain = dir.join("plain.png");
    ok(&[
        "preview",
        SKY_EXR,
        "-o",
        plain.to_str().unwrap(),
        "--material",
        "chrome",
        "--size",
        "128",
        "-q",
    ]);
    let seams = psnr(shots[1].png("seams"), &plain);
    assert!(
        seams < 40.0,
        "seams=1 drew the plain sphere ({seams:.1} dB)"
    );
    // A sweep is a row of five.
    for shot in &shots[2..] {
        let img = rgb(shot.png("a sweep"));
        assert_eq!(img.dimensions(), (5 * 96, 96));
    }

    // An ibl folder: glTF's chain with glTF's roughness mapping, as preview --target reads it.
    ok(&[
        "ibl",
        SKY_EXR,
        "-o",
        "gltf",
        "--target",
        "gltf",
        "--samples",
        "8",
        "-q",
    ]);
    let said = ok(&["view", "gltf", "-o", "gltf_page"]);
    assert!(said.contains("an ibl folder"), "{said}");
    let shots = shoot(
        &dir.join("gltf_page/index.html"),
        &dir.join("gltf_gpu"),
        &["material=gold&size=128".into()],
    );
    ok(&[
        "preview",
        "gltf/env_ggx.ktx2",
        "-o",
        "gltf_cpu.png",
        "--target",
        "gltf",
        "--material",
        "gold",
        "--size",
        "128",
        "-q",
    ]);
    let db = psnr(shots[0].png("the glTF folder"), &dir.join("gltf_cpu.png"));
    assert!(
        db >= 45.0,
        "the glTF folder's chain against preview --target gltf: {db:.1} dB"
    );

    // A control map alone: on the sphere under the demo sky.
    ok(&[
        "control",
        CHROME_AND_PAINT,
        "-o",
        "ctl.png",
        "--size",
        "128",
        "-q",
    ]);
    let said = ok(&["view", "ctl.png", "-o", "ctl_page"]);
    assert!(said.contains("a control map"), "{said}");
    let shots = shoot(
        &dir.join("ctl_page/index.html"),
        &dir.join("ctl_gpu"),
        &["material=chrome&size=96".into()],
    );
    shots[0].png("a lone control map");
    done(&dir);
}
