//! Octahedral maps: texel by texel against environments defined as functions of direction,
//! lookups across the square's folded edges, round trips through panoramas and cube maps,
//! and the command line (`--to octahedral`, `--from octahedral`, `info`).

use crate::common;

use cubeforge::internals::convert::{self, Loaded, Output, Source};
use cubeforge::internals::cube::{CubeMap, Environment, Interp};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{FileFormat, Meta};
use cubeforge::internals::layout::{octahedral, ImageEnv, Kind, Projection};
use cubeforge::internals::resample::Resampler;
use cubeforge::internals::synthetic;
use glam::{Vec3, Vec4};

fn loaded(source: Source, kind: Kind) -> Loaded {
    Loaded {
        source,
        kind: kind.into(),
        hdr: true,
        meta: Meta {
            file_format: FileFormat::Exr,
            pixel_format: "RGBA32F".into(),
            color_space: cubeforge::internals::image::ColorSpace::Linear,
            hdr: true,
            replaced_values: 0,
            stored_levels: 1,
            declared: None,
            part: None,
            undo: Default::default(),
        },
        files: vec![],
    }
}

/// A map of projection `p`, `w` x `h`, each texel `f` at its centre's direction.
fn exact(p: Projection, w: usize, h: usize, f: fn(Vec3) -> Vec4) -> Image {
    Image::from_fn(w, h, |x, y| {
        f(
            p.to_dir((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32)
                .unwrap(),
        )
    })
}

fn image(out: Output) -> Image {
    match out {
        Output::Image(img) => img,
        Output::Cube(_) => panic!("expected an image"),
    }
}

fn cube(out: Output) -> CubeMap {
    match out {
        Output::Cube(c) => c,
        Output::Image(_) => panic!("expected a cube"),
    }
}

/// (PSNR over RGB with peak 1, largest RGB error) of `a` against `b`.
fn scores(a: &Image, b: &Image) -> (f64, f32) {
    (common::psnr(a, b, 1.0), common::max_abs_error(a, b))
}

/// The worst (lowest PSNR, largest error) over six faces.
fn cube_scores(a: &CubeMap, b: &CubeMap) -> (f64, f32) {
    (0..6)
        .map(|f| scores(&a.levels[0][f], &b.levels[0][f]))
        .fold((f64::INFINITY, 0.0f32), |(p, e), (q, g)| {
            (p.min(q), e.max(g))
        })
}

/// Every texel of the output, corners and edges included (there is no outside to mask), on
/// `wavy` (`synthetic::smooth` is in conversions.rs with every layout). Measured: faces 32 ->
/// octahedral 64 x 64 57.5 dB, max 0.0044; octahedral 64 x 64 -> faces 32 54.6 dB, max 0.0074
/// (bilinear); bicubic 65.7 dB / 0.0028 and 67.1 dB / 0.0034. Bounds: 52 dB and 0.01
/// bilinear, 62 dB and 0.005 bicubic.
#[test]
fn octahedral_matches_ground_truth_texel_by_texel() {
    let n = 32;
    let truth_cube = CubeMap::from_fn(n, wavy);
    let truth_octa = exact(Projection::Octahedral, 2 * n, 2 * n, wavy);
    let mut figures = Vec::new();
    for (interp, min_psnr, max_e) in [
        (Interp::Bilinear, 52.0, 0.01),
        (Interp::Bicubic, 62.0, 0.005),
    ] {
        let rs = Resampler {
            interp,
            ..Resampler::default()
        };
        let faces = loaded(Source::Cube(truth_cube.clone()), Kind::Faces);
        let out = image(convert::convert(&faces, Kind::Octahedral, n, &rs));
        assert_eq!((out.width, out.height), (2 * n, 2 * n));
        let (p, e) = scores(&out, &truth_octa);
        println!("{interp:?}: faces {n} -> octahedral: {p:.1} dB, max {e:.5}");
        if interp == Interp::Bilinear {
            figures.push(format!(
                "faces of {n} to a {} x {} octahedral map {p:.1} dB PSNR (largest error {e:.4})",
                2 * n,
                2 * n
            ));
        }
        assert!(p >= min_psnr && e <= max_e, "to octahedral: {p:.1} dB, {e}");
        let octa = loaded(
            Source::Projection(Projection::Octahedral, truth_octa.clone()),
            Kind::Octahedral,
        );
        let back = cube(convert::convert(&octa, Kind::Faces, n, &rs));
        let (p, e) = cube_scores(&back, &truth_cube);
        println!("{interp:?}: octahedral -> faces {n}: {p:.1} dB, max {e:.5}");
        if interp == Interp::Bilinear {
            figures.push(format!("back {p:.1} dB ({e:.4})"));
        }
        assert!(
            p >= min_psnr && e <= max_e,
            "from octahedral: {p:.1} dB, {e}"
        );
    }
    crate::figures::check("docs/conventions.md", "octahedral", &figures.join(", "));
}

/// Lookups within half a texel of the square's edges read across them (each edge is itself
/// mirrored about its midpoint), so they are no worse than lookups inside, whose worst are
/// where the map folds too (the octahedron's edges); clamping the edge texels instead
/// (`Image::bilinear` without wrap) is worse there. Measured on a 32 x 32 map of `wavy`:
/// largest error 0.049 near the edges and 0.049 inside (bilinear; bicubic 0.040 and 0.040);
/// rms error near the edges 0.0177 read across, 0.0308 clamped (bicubic 0.0123). Bounds:
/// the largest within 1.1x of inside's, rms under 0.7x clamped.
#[test]
fn lookups_read_across_the_folded_edges() {
    let w = 32;
    let img = exact(Projection::Octahedral, w, w, wavy);
    let env = ImageEnv::new(Projection::Octahedral, &img, Some(1));
    // Root mean square of the errors of a band, from (sum of squares, count).
    let rms = |(sum, n): (f64, f64)| (sum / n).sqrt();
    let add = |acc: &mut (f64, f64), e: f32| *acc = (acc.0 + (e * e) as f64, acc.1 + 1.0);
    for interp in [Interp::Bilinear, Interp::Bicubic] {
        let (mut edge, mut held) = ((0.0, 0.0), (0.0, 0.0));
        let (mut edge_max, mut inside_max) = (0.0f32, 0.0f32);
        // A fine grid of points of the square, each looked up by its direction.
        let k = 8 * w;
        for j in 0..k {
            for i in 0..k {
                let (u, v) = ((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                let d = octahedral::uv_to_dir(u, v);
                let want = wavy(d);
                let err = |got: Vec4| (got - want).truncate().abs().max_element();
                let e = err(env.sample(d, 0, interp));
                let texels = (u.min(1.0 - u)).min(v.min(1.0 - v)) * w as f32;
                if texels < 0.5 {
                    add(&mut edge, e);
                    edge_max = edge_max.max(e);
                    add(
                        &mut held,
                        err(img.bilinear(u * w as f32, v * w as f32, false)),
                    );
                } else if texels > 1.5 {
                    inside_max = inside_max.max(e);
                }
            }
        }
        let (edge, held) = (rms(edge), rms(held));
        println!(
            "{interp:?}: largest error {edge_max:.4} near the edges, {inside_max:.4} inside; rms near the edges {edge:.4} (clamped bilinear {held:.4})"
        );
        assert!(
            edge_max <= 1.1 * inside_max,
            "{interp:?}: {edge_max} near the edges, {inside_max} inside"
        );
        assert!(
            edge < 0.7 * held,
            "{interp:?}: rms {edge} vs {held} clamped"
        );
    }
}

/// A few waves across the sphere: smooth, but with slopes a clamped edge shows.
fn wavy(d: Vec3) -> Vec4 {
    Vec4::new(
        0.5 + 0.4 * (3.0 * d.x + 2.0 * d.z).sin(),
        0.5 + 0.4 * (4.0 * d.y - d.z).cos(),
        0.5 + 0.4 * (5.0 * d.z + d.x).sin(),
        1.0,
    )
}

/// On `wavy`, measured: equirect 256 x 128 -> octahedral 128 x 128 -> equirect 61.5 dB, max
/// 0.0071; faces 64 -> octahedral 128 x 128 -> faces 64 62.0 dB, max 0.0035. Bounds: 58 dB,
/// 0.01.
#[test]
fn round_trips_through_an_octahedral_map() {
    let n = 64;
    let rs = Resampler::default();
    // The input converted to an octahedral map, loaded again as an input.
    let via_octahedral = |src: &Loaded| {
        let octa = image(convert::convert(src, Kind::Octahedral, n, &rs));
        loaded(
            Source::Projection(Projection::Octahedral, octa),
            Kind::Octahedral,
        )
    };
    let pano = exact(Projection::Equirect, 4 * n, 2 * n, wavy);
    let src = loaded(
        Source::Projection(Projection::Equirect, pano.clone()),
        Kind::Equirect,
    );
    let back = image(convert::convert(
        &via_octahedral(&src),
        Kind::Equirect,
        n,
        &rs,
    ));
    let (p, e) = scores(&back, &pano);
    println!("equirect -> octahedral -> equirect: {p:.1} dB, max {e:.5}");
    let from_pano = format!("{p:.1} dB from a panorama");
    assert!(p >= 58.0 && e <= 0.01, "{p:.1} dB, {e}");

    let faces = CubeMap::from_fn(n, wavy);
    let src = loaded(Source::Cube(faces.clone()), Kind::Faces);
    let back = cube(convert::convert(&via_octahedral(&src), Kind::Faces, n, &rs));
    let (p, e) = cube_scores(&back, &faces);
    println!("faces -> octahedral -> faces: {p:.1} dB, max {e:.5}");
    let text = format!("{from_pano}, {p:.1} dB from faces of {n}");
    crate::figures::check("docs/conventions.md", "octahedral round trips", &text);
    assert!(p >= 58.0 && e <= 0.01, "{p:.1} dB, {e}");
}

/// The chiral marker (above and right of +Z's centre, see `synthetic::marker`) lands where the
/// convention puts it, worked out by hand: d = (0.3, 0.3, 1) / |d| is above the horizon, so
/// p = (0.3, 1) / 1.6 = (0.1875, 0.625), (u, v) = (0.59375, 0.8125): texel (76, 104) of 128.
/// A mirrored layout (the same mirror both ways) would pass a round trip but not this.
#[test]
fn the_marker_lands_where_the_convention_says() {
    let n = 128;
    let from_fn = cubeforge::internals::resample::FnEnv(synthetic::marker);
    let rs = Resampler {
        antialias: false,
        ..Resampler::default()
    };
    let img = rs.to_projection(&from_fn, Projection::Octahedral, n, n);
    // The centre of the marker's texels (4, where the rest is at most 1).
    let (mut sx, mut sy, mut count) = (0.0f32, 0.0f32, 0.0f32);
    for y in 0..n {
        for x in 0..n {
            if img.get(x, y).x > 2.0 {
                (sx, sy, count) = (sx + x as f32, sy + y as f32, count + 1.0);
            }
        }
    }
    let (x, y) = (sx / count, sy / count);
    assert!(
        count > 4.0 && (x - 76.0).abs() <= 1.0 && (y - 104.0).abs() <= 1.0,
        "marker at ({x}, {y}), {count} texels"
    );
}

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

/// `--to octahedral` writes a 2N x 2N map; reading it needs `--from octahedral` (a square image
/// is ambiguous, and the one-line error says so). Both ways the command writes what the
/// library makes (to half-float precision), `info` names the layout and face size, and the
/// map keeps the panorama's flux. Measured: 0.048% off the library's (relative, largest: the
/// half floats), flux within 0.02%. Bounds: 0.1%, 0.5%.
#[test]
fn command_line_writes_and_reads_octahedral_maps() {
    let dir = tempfile::tempdir().unwrap();
    let octa = dir.path().join("probe.exr");
    let back = dir.path().join("back.exr");
    let run = |args: &[&str]| {
        let out = common::run(args);
        (out.status.success(), common::stderr(&out))
    };
    let (o, b) = (octa.to_str().unwrap(), back.to_str().unwrap());
    let (ok, err) = run(&[
        "convert",
        SKY,
        "-o",
        o,
        "--to",
        "octahedral",
        "--size",
        "32",
    ]);
    assert!(ok, "{err}");
    let (ok, err) = run(&["convert", o, "-o", b, "--to", "equirect"]);
    assert!(!ok);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("probe.exr") && err.contains("--from octahedral"),
        "{err}"
    );
    let (ok, err) = run(&[
        "convert",
        o,
        "--from",
        "octahedral",
        "-o",
        b,
        "--to",
        "equirect",
    ]);
    assert!(ok, "{err}");

    // What the library makes: the panorama to an octahedral map of 64, that map to a panorama
    // keeping its face size (32: 128 x 64).
    let rs = Resampler::default();
    let read = cubeforge::internals::io::ReadOptions::default();
    let sky = convert::load(&[SKY.into()], None, &read).unwrap();
    let want_octa = image(convert::convert(&sky, Kind::Octahedral, 32, &rs));
    let got_octa = common::read_image(&octa);
    let read_back =
        convert::load(std::slice::from_ref(&octa), Some(Kind::Octahedral), &read).unwrap();
    assert_eq!(read_back.face_size(), 32);
    let want_back = image(convert::convert(&read_back, Kind::Equirect, 32, &rs));
    let got_back = common::read_image(&back);
    for (got, want, what) in [
        (&got_octa, &want_octa, "octahedral"),
        (&got_back, &want_back, "equirect"),
    ] {
        assert_eq!((got.width, got.height), (want.width, want.height), "{what}");
        let rel = got
            .pixels
            .iter()
            .zip(&want.pixels)
            .map(|(g, w)| ((*g - *w).abs() / w.abs().max(glam::Vec4::splat(1e-3))).max_element())
            .fold(0.0f32, f32::max);
        println!("{what}: largest relative difference {rel:.5}");
        assert!(rel < 1e-3, "{what}: {rel}");
    }
    assert_eq!(
        (got_octa.width, got_back.width, got_back.height),
        (64, 128, 64)
    );

    let info = |args: &[&str]| -> serde_json::Value {
        let out = common::run([&["info", "--json"], args].concat());
        assert!(out.status.success(), "{}", common::stderr(&out));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let v = info(&["--from", "octahedral", o]);
    assert_eq!(v["kind"], "octahedral", "{v}");
    assert_eq!(v["face_size"], 32, "{v}");
    let flux = |v: &serde_json::Value| -> Vec<f64> {
        let f = v["flux"].as_array().unwrap();
        f.iter().map(|f| f.as_f64().unwrap()).collect()
    };
    let (f, g) = (flux(&v), flux(&info(&[SKY])));
    let change = (0..3)
        .map(|c| (f[c] / g[c] - 1.0).abs())
        .fold(0.0, f64::max);
    println!("flux of the octahedral map {f:?}, of the panorama {g:?}");
    assert!(change < 0.005, "{:.3}%", change * 100.0);
    // Without --from, info says what the square may be.
    let v = info(&[o]);
    assert!(v["kind"].is_null(), "{v}");
    let note = v["kind_note"].as_str().unwrap();
    assert!(note.contains("--from octahedral"), "{note}");
}
