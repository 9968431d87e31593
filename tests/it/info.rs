//! `info` on every kind of input: square images settled with `--from`, face sizes by the
//! layout's convention, statistics over a layout's texels only (no empty cross cells, no
//! corners outside a ball), folders of faces and prefiltered chains.

use crate::common;

use common::{run, stderr, write_image};
use cubeforge::internals::cube::FACE_NAMES;
use cubeforge::internals::image::Image;
use cubeforge::internals::info::{self, Report};
use cubeforge::internals::io::ReadOptions;
use cubeforge::internals::layout::cross::{self, Cells};
use cubeforge::internals::layout::Kind;
use glam::Vec4;
use std::path::{Path, PathBuf};

fn describe(path: &Path, from: Option<Kind>) -> cubeforge::Result<Report> {
    info::describe(path, from, &ReadOptions::default())
}

fn flat(w: usize, h: usize, v: f32) -> Image {
    Image::from_fn(w, h, |_, _| Vec4::new(v, v, v, 1.0))
}

/// Six faces of `n` px, face i holding the value i + 1, as `dir/{name}.{ext}`.
fn write_faces(dir: &Path, n: usize, names: &[&str; 6], ext: &str) {
    std::fs::create_dir_all(dir).unwrap();
    for (i, name) in names.iter().enumerate() {
        write_image(
            &dir.join(format!("{name}.{ext}")),
            &flat(n, n, (i + 1) as f32),
        );
    }
}

fn json(args: &[&std::ffi::OsStr]) -> serde_json::Value {
    let mut all: Vec<&std::ffi::OsStr> = vec!["info".as_ref(), "--json".as_ref()];
    all.extend(args);
    let out = run(&all);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

fn text(args: &[&std::ffi::OsStr]) -> String {
    let mut all: Vec<&std::ffi::OsStr> = vec!["info".as_ref()];
    all.extend(args);
    let out = run(&all);
    assert!(out.status.success(), "{}", stderr(&out));
    String::from_utf8(out.stdout).unwrap()
}

/// The one error line of a failed run, which names `file`.
fn one_error(args: &[&std::ffi::OsStr], file: &str) -> String {
    let mut all: Vec<&std::ffi::OsStr> = vec!["info".as_ref()];
    all.extend(args);
    let out = run(&all);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("cubeforge: error: ") && err.contains(file),
        "{err}"
    );
    err
}

#[test]
fn square_images_need_from_for_their_face_size() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("square.exr");
    // A ball: 2 inside the disc, 0 in the corners.
    write_image(
        &p,
        &Image::from_fn(64, 64, |x, y| {
            let (u, v) = ((x as f32 + 0.5) / 32.0 - 1.0, (y as f32 + 0.5) / 32.0 - 1.0);
            let c = if u * u + v * v < 1.0 { 2.0 } else { 0.0 };
            Vec4::new(c, c, c, 1.0)
        }),
    );

    // No --from: the layout and the face size are unknown (64 as one face, 32 as a ball).
    let r = describe(&p, None).unwrap();
    assert_eq!((r.kind, r.face_size), (None, None));
    // The library names the parameter by its field (the CLI by its flag).
    let note = cubeforge::internals::error::name_params(&r.kind_note.clone().unwrap(), false);
    assert!(
        note.contains("`from` sphere")
            && note.contains("`from` octahedral")
            && note.contains("face size 32"),
        "{note}"
    );
    assert!(note.contains("single face (face size 64)"), "{note}");
    assert!(r.flux.is_none());
    assert_eq!(r.stats.min_luminance, 0.0, "every texel counts");
    let t = r.to_string();
    assert!(
        t.contains(
            "face size:    unknown: 32 as a sphere, angular or octahedral map, 64 as a single face"
        ),
        "{t}"
    );

    // --from sphere / angular: a 2N x 2N map has face size N; the corners are not in it.
    for (kind, name) in [(Kind::Sphere, "sphere"), (Kind::Angular, "angular")] {
        let r = describe(&p, Some(kind)).unwrap();
        assert_eq!(
            (r.kind, r.face_size),
            (Some(kind.into()), Some(32)),
            "{name}"
        );
        assert!(r.kind_note.is_none());
        assert!(r.flux.is_some());
        assert!(
            (r.stats.min_luminance - 2.0).abs() < 1e-6,
            "{name}: corners counted: {:?}",
            r.stats
        );
        let v = json(&["--from".as_ref(), name.as_ref(), p.as_os_str()]);
        assert_eq!(v["kind"], name, "{v}");
        assert_eq!(v["face_size"], 32, "{v}");
    }
    let v = json(&[p.as_os_str()]);
    assert!(v["kind"].is_null() && v["face_size"].is_null(), "{v}");
    assert!(
        text(&["--from".as_ref(), "sphere".as_ref(), p.as_os_str()]).contains("face size:    32")
    );

    // A layout the image cannot hold, or one that is not a single image: one line each.
    let e = one_error(
        &["--from".as_ref(), "hcross".as_ref(), p.as_os_str()],
        "square.exr",
    );
    assert!(
        e.contains("64x64 image cannot hold an hcross layout"),
        "{e}"
    );
    let e = one_error(
        &["--from".as_ref(), "faces".as_ref(), p.as_os_str()],
        "square.exr",
    );
    assert!(e.contains("does not describe a single image"), "{e}");
}

#[test]
fn from_applies_to_other_shapes() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("pano.exr");
    write_image(&p, &flat(32, 16, 1.0));
    let r = describe(&p, Some(Kind::Equirect)).unwrap();
    assert_eq!(
        (r.kind, r.face_size),
        (Some(Kind::Equirect.into()), Some(8))
    );
    let e = describe(&p, Some(Kind::Angular)).unwrap_err().to_string();
    assert!(
        e.contains("32x16 image cannot hold an angular layout"),
        "{e}"
    );
}

#[test]
fn cross_statistics_leave_out_empty_cells() {
    let dir = tempfile::tempdir().unwrap();
    let faces: [Image; 6] = std::array::from_fn(|i| flat(8, 8, 2.0 + i as f32));
    for cells in [Cells::Hcross, Cells::Vcross, Cells::Hstrip] {
        let kind = cells.kind();
        let p = dir.path().join(format!("{}.exr", kind.name()));
        write_image(&p, &cross::assemble(cells, &faces));
        let r = describe(&p, None).unwrap();
        assert_eq!((r.kind, r.face_size), (Some(kind.into()), Some(8)));
        let s = &r.stats;
        let near = |a: f64, b: f64| (a - b).abs() < 1e-5;
        assert!(near(s.min_luminance, 2.0), "{kind:?}: {s:?}");
        assert!(near(s.max_luminance, 7.0), "{kind:?}: {s:?}");
        assert!(near(s.mean_luminance, 4.5), "{kind:?}: {s:?}");
    }
}

#[test]
fn a_faces_folder_is_a_cube_map() {
    let dir = tempfile::tempdir().unwrap();
    let faces = dir.path().join("faces");
    write_faces(&faces, 16, &FACE_NAMES, "exr");
    let r = describe(&faces, None).unwrap();
    assert_eq!(r.kind, Some(Kind::Faces.into()));
    assert_eq!((r.width, r.height, r.face_size), (16, 16, Some(16)));
    assert_eq!(r.mip_levels, 1);
    assert!((r.stats.min_luminance - 1.0).abs() < 1e-5, "{:?}", r.stats);
    assert!((r.stats.max_luminance - 6.0).abs() < 1e-5, "{:?}", r.stats);
    // Every face covers the same solid angle: the flux is the mean of 1 to 6.
    let f = r.flux.unwrap();
    assert!(f.iter().all(|c| (c - 3.5).abs() < 1e-6), "{f:?}");
    assert_eq!(
        describe(&faces, Some(Kind::Faces)).unwrap().face_size,
        Some(16)
    );

    let v = json(&[faces.as_os_str()]);
    assert_eq!(v["kind"], "faces", "{v}");
    assert_eq!(v["face_size"], 16, "{v}");
    assert_eq!(v["file_format"], "exr", "{v}");
    let t = text(&[faces.as_os_str()]);
    assert!(t.contains("layout:       faces (a folder of six)"), "{t}");
    assert!(t.contains("flux:         3.5"), "{t}");

    // Long names and another format.
    let long = dir.path().join("long");
    write_faces(
        &long,
        4,
        &["posx", "negx", "posy", "negy", "posz", "negz"],
        "png",
    );
    let v = json(&[long.as_os_str()]);
    assert_eq!(
        (v["face_size"].clone(), v["file_format"].clone()),
        (4.into(), "png".into())
    );

    // --from of a single image on a folder; a folder of something else; a face missing; a
    // face of another size: one line naming the folder or the face.
    let e = one_error(
        &["--from".as_ref(), "sphere".as_ref(), faces.as_os_str()],
        "faces",
    );
    assert!(e.contains("--from sphere"), "{e}");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    std::fs::write(empty.join("notes.txt"), "hello").unwrap();
    let e = one_error(&[empty.as_os_str()], "empty");
    assert!(e.contains("holds neither six faces"), "{e}");
    std::fs::remove_file(faces.join("ny.exr")).unwrap();
    let e = one_error(&[faces.as_os_str()], "faces");
    assert!(e.contains("face ny is missing"), "{e}");
    write_image(&faces.join("ny.exr"), &flat(8, 8, 1.0));
    let e = one_error(&[faces.as_os_str()], "ny.exr");
    assert!(e.contains("same size"), "{e}");
}

/// A folder written by `cubeforge prefilter -o DIR`.
fn prefilter_folder(dir: &Path) -> PathBuf {
    let src = dir.join("pano.exr");
    write_image(
        &src,
        &Image::from_fn(32, 16, |x, y| Vec4::new(x as f32, y as f32, 1.0, 1.0)),
    );
    let chain = dir.join("chain");
    let out = run([
        "prefilter".as_ref(),
        src.as_os_str(),
        "-o".as_ref(),
        chain.as_os_str(),
        "--filter".as_ref(),
        "gaussian".as_ref(),
        "--size".as_ref(),
        "8".as_ref(),
        "--samples".as_ref(),
        "4".as_ref(),
        "--min-size".as_ref(),
        "1".as_ref(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    chain
}

#[test]
fn a_prefiltered_chain_folder_lists_its_levels() {
    let dir = tempfile::tempdir().unwrap();
    let chain = prefilter_folder(dir.path());
    let r = describe(&chain, None).unwrap();
    assert_eq!(
        (r.kind, r.face_size, r.mip_levels),
        (Some(Kind::Faces.into()), Some(8), 4)
    );
    let levels = r.levels.as_ref().expect("levels.json");
    assert_eq!(
        levels.filter,
        cubeforge::internals::filter::FilterKind::Gaussian
    );
    assert_eq!(levels.levels.len(), 4);

    let v = json(&[chain.as_os_str()]);
    assert_eq!(v["mip_levels"], 4, "{v}");
    assert_eq!(v["levels"]["levels"][3]["size"], 1, "{v}");
    let t = text(&[chain.as_os_str()]);
    assert!(t.contains("prefiltered chain (folders m0 to m3)"), "{t}");
    assert!(t.contains("mip levels:   4"), "{t}");
    assert!(t.contains("level  3:         1 px, gaussian sigma"), "{t}");

    // A level of the wrong size, or levels.json disagreeing with the folders: one line.
    let m3 = chain.join("m3");
    let m3_faces: Vec<PathBuf> = std::fs::read_dir(&m3)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let keep = dir.path().join("m3");
    std::fs::rename(&m3, &keep).unwrap();
    let e = one_error(&[chain.as_os_str()], "levels.json");
    assert!(e.contains("lists 4 levels but the folder holds 3"), "{e}");
    std::fs::rename(&keep, &m3).unwrap();
    for f in &m3_faces {
        write_image(f, &flat(2, 2, 1.0));
    }
    let e = one_error(&[chain.as_os_str()], "m3");
    assert!(e.contains("must be 1x1 (half of m2)"), "{e}");
    std::fs::write(chain.join("levels.json"), "{ not json").unwrap();
    std::fs::remove_dir_all(&m3).unwrap();
    let e = one_error(&[chain.as_os_str()], "levels.json");
    assert!(e.contains("not valid JSON"), "{e}");
}

/// Several inputs, one of them bad: a JSON array of the good ones, one line for the bad one.
#[test]
fn json_stays_valid_with_a_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.exr");
    write_image(&good, &flat(16, 8, 1.0));
    let bad = dir.path().join("bad\nname.exr");
    std::fs::write(&bad, b"not an image").unwrap();
    let out = run([
        "info".as_ref(),
        "--json".as_ref(),
        good.as_os_str(),
        bad.as_os_str(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    assert_eq!(v.as_array().map(Vec::len), Some(1), "{v}");
    // One line for the file (its name's line break written out), one for the summary.
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 2, "{err}");
    assert!(err.contains("bad\\nname.exr: "), "{err}");
    assert!(err.contains("1 of 2 files could not be read"), "{err}");
}

/// The real faces folders and balls of ../shared/fixtures/real (skipped when absent).
#[test]
fn real_folders_and_balls() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let forest = real.join("faces/forest_ldr");
    let city = real.join("faces/city");
    let v = json(&[forest.as_os_str(), city.as_os_str()]);
    for (r, format) in v.as_array().unwrap().iter().zip(["jpeg", "exr"]) {
        assert_eq!(r["kind"], "faces", "{r}");
        assert_eq!(r["file_format"], format, "{r}");
        assert_eq!(r["face_size"], 128, "{r}");
        assert!(r["flux"][0].as_f64().unwrap() > 0.0, "{r}");
    }
    for (file, from) in [
        ("ball/studio_mirrorball.exr", "sphere"),
        ("ball/park_angular.exr", "angular"),
    ] {
        let p = real.join(file);
        let v = json(&["--from".as_ref(), from.as_ref(), p.as_os_str()]);
        assert_eq!(v["kind"], from, "{v}");
        assert_eq!(v["face_size"], 128, "{v}");
        assert!(v["flux"][0].as_f64().unwrap() > 0.0, "{v}");
    }
}

/// A 16 px cube with its 5 box levels, every value in [0.1, 3.1]: nothing bad anywhere.
fn clean_chain() -> cubeforge::internals::cube::CubeMap {
    cubeforge::internals::cube::CubeMap::from_fn(16, |d| {
        Vec4::new(d.x.abs() * 3.0 + 0.1, d.y * 0.5 + 0.6, d.z.abs() + 0.1, 1.0)
    })
    .with_box_mips(None)
}

/// The bad values put in a chain: (level, face, texel, channel, value). Level 0 stays clean;
/// level 1 gets 1 negative, level 3 2 NaN, 1 Inf (negative infinity) and 1 negative.
const BAD: [(usize, usize, usize, usize, f32); 5] = [
    (1, 5, 0, 0, -2.0),
    (3, 0, 0, 0, f32::NAN),
    (3, 0, 1, 1, f32::NAN),
    (3, 1, 2, 2, f32::NEG_INFINITY),
    (3, 2, 3, 1, -1.0),
];

/// `info` counts a container's or chain's every level and names the bad ones, in its text and
/// in `--json`; level 0's luminance is what it was.
fn assert_bad_levels_reported(path: &Path) {
    let r = describe(path, None).unwrap();
    assert_eq!(
        (r.stats.nan, r.stats.inf, r.stats.negative),
        (2, 1, 2),
        "{r:?}"
    );
    let levels: Vec<(usize, u64, u64, u64)> = r
        .bad_levels
        .iter()
        .map(|b| (b.level, b.nan, b.inf, b.negative))
        .collect();
    assert_eq!(levels, [(1, 0, 0, 1), (3, 2, 1, 1)]);
    assert!(r.stats.min_luminance > 0.0, "{:?}", r.stats);

    let t = text(&[path.as_os_str()]);
    assert!(
        t.contains("bad values:   2 NaN, 1 Inf, 2 negative\n"),
        "{t}"
    );
    assert!(
        t.contains("\n  bad level 1:  0 NaN, 0 Inf, 1 negative\n"),
        "{t}"
    );
    assert!(
        t.contains("\n  bad level 3:  2 NaN, 1 Inf, 1 negative\n"),
        "{t}"
    );
    assert!(
        !t.contains("bad level 0") && !t.contains("bad level 2"),
        "{t}"
    );

    let v = json(&[path.as_os_str()]);
    assert_eq!(
        (
            &v["stats"]["nan"],
            &v["stats"]["inf"],
            &v["stats"]["negative"]
        ),
        (&2.into(), &1.into(), &2.into()),
        "{v}"
    );
    assert_eq!(
        v["bad_levels"],
        serde_json::json!([
            {"level": 1, "nan": 0, "inf": 0, "negative": 1},
            {"level": 3, "nan": 2, "inf": 1, "negative": 1}
        ]),
        "{v}"
    );
}

/// A clean chain says so: no per-level lines, no `bad_levels` in its JSON.
fn assert_clean(path: &Path) {
    let r = describe(path, None).unwrap();
    assert!(r.bad_levels.is_empty(), "{r:?}");
    assert_eq!((r.stats.nan, r.stats.inf, r.stats.negative), (0, 0, 0));
    assert!(!text(&[path.as_os_str()]).contains("bad level"));
    assert!(json(&[path.as_os_str()]).get("bad_levels").is_none());
}

/// The encoders make every value finite (and the half float ones clamp), so the bad values
/// are patched into the encoded bytes: `at(level, face, texel)` is where that texel starts,
/// read from the container's own header; a channel is 2 bytes (half) or 4 (f32) after it.
fn patch(bytes: &mut [u8], half: bool, at: impl Fn(usize, usize, usize) -> usize) {
    for (level, face, texel, channel, v) in BAD {
        let texel_at = at(level, face, texel);
        if half {
            let o = texel_at + 2 * channel;
            bytes[o..o + 2].copy_from_slice(&half::f16::from_f32(v).to_le_bytes());
        } else {
            let o = texel_at + 4 * channel;
            bytes[o..o + 4].copy_from_slice(&v.to_le_bytes());
        }
    }
}

#[test]
fn a_bad_mip_in_a_ktx2_chain_is_counted_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let cube = clean_chain();
    let mut b =
        cubeforge::internals::io::ktx2::encode(&cube, cubeforge::internals::io::GpuFormat::Rgba16f);
    let clean = dir.path().join("clean.ktx2");
    std::fs::write(&clean, &b).unwrap();
    assert_clean(&clean);
    // KTX2's level index (from byte 80, 24 bytes a level) gives each level's byteOffset; a
    // level holds its six faces in order, 8 bytes a texel.
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().unwrap());
    let offsets: Vec<usize> = (0..5).map(|l| u64_at(&b, 80 + 24 * l) as usize).collect();
    patch(&mut b, true, |l, f, t| {
        let n = 16 >> l;
        offsets[l] + (f * n * n + t) * 8
    });
    let p = dir.path().join("bad.ktx2");
    std::fs::write(&p, &b).unwrap();
    assert_bad_levels_reported(&p);
}

#[test]
fn a_bad_mip_in_a_dds_chain_is_counted_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let cube = clean_chain();
    let mut b =
        cubeforge::internals::io::dds::encode(&cube, cubeforge::internals::io::GpuFormat::Rgba32f)
            .unwrap();
    let clean = dir.path().join("clean.dds");
    std::fs::write(&clean, &b).unwrap();
    assert_clean(&clean);
    // DDS: magic and header (128 bytes), DX10 header (20), then face-major: each face's
    // levels, largest first, 16 bytes a texel. The edge and level count are header words.
    let word = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize;
    let (edge, levels) = (word(16), word(28));
    assert_eq!((edge, levels), (16, 5));
    let level_len = |l: usize| (edge >> l).pow(2) * 16;
    let face_len: usize = (0..levels).map(level_len).sum();
    patch(&mut b, false, |l, f, t| {
        148 + f * face_len + (0..l).map(level_len).sum::<usize>() + t * 16
    });
    let p = dir.path().join("bad.dds");
    std::fs::write(&p, &b).unwrap();
    assert_bad_levels_reported(&p);
}

/// A chain folder whose m2/px.exr holds a NaN (an f32 EXR the exr crate writes: cubeforge's
/// own encoder never writes one): `info` names level 2.
#[test]
fn a_bad_mip_in_a_chain_folder_is_counted_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let chain = prefilter_folder(dir.path());
    assert_clean(&chain);
    let face = chain.join("m2/px.exr");
    assert!(face.is_file());
    exr::prelude::write_rgba_file(&face, 2, 2, |x, y| {
        let v = if (x, y) == (1, 0) { f32::NAN } else { 0.5 };
        (v, 0.5, 0.5, 1.0)
    })
    .unwrap();
    let r = describe(&chain, None).unwrap();
    assert_eq!((r.stats.nan, r.stats.inf, r.stats.negative), (1, 0, 0));
    assert_eq!(r.bad_levels.len(), 1, "{r:?}");
    assert_eq!((r.bad_levels[0].level, r.bad_levels[0].nan), (2, 1));
    let t = text(&[chain.as_os_str()]);
    assert!(
        t.contains("bad values:   1 NaN, 0 Inf, 0 negative\n"),
        "{t}"
    );
    assert!(
        t.contains("\n  bad level 2:  1 NaN, 0 Inf, 0 negative\n"),
        "{t}"
    );
    let v = json(&[chain.as_os_str()]);
    assert_eq!(
        v["bad_levels"],
        serde_json::json!([{"level": 2, "nan": 1, "inf": 0, "negative": 0}]),
        "{v}"
    );
}

/// A container is reported as itself (a map kind whose layout is faces). `--from` names
/// layouts only: a container's name there is refused on one line before any file is read,
/// and a layout given for a container file is refused by the file.
#[test]
fn a_container_is_its_own_kind_and_from_takes_layouts() {
    use cubeforge::internals::io::{dds, Container, GpuFormat};
    use cubeforge::MapKind;
    let dir = tempfile::tempdir().unwrap();
    let cube = cubeforge::internals::cube::CubeMap::from_fn(8, |_| Vec4::ONE);
    let p = dir.path().join("c.dds");
    std::fs::write(&p, dds::encode(&cube, GpuFormat::Rgba16f).unwrap()).unwrap();
    let r = describe(&p, None).unwrap();
    assert_eq!(r.kind, Some(MapKind::Container(Container::Dds)));
    assert_eq!(r.kind.map(MapKind::layout), Some(Kind::Faces));
    assert_eq!(json(&[p.as_os_str()])["kind"], "dds");
    let e = describe(&p, Some(Kind::Sphere)).unwrap_err().to_string();
    assert!(e.contains("the file is a DDS cube map"), "{e}");

    let out = run([
        "info".as_ref(),
        "--from".as_ref(),
        "dds".as_ref(),
        p.as_os_str(),
    ]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("invalid value 'dds' for '--from"), "{err}");
}
