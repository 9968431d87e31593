//! Light is conserved: every resampling keeps each channel's flux (solid-angle-weighted mean
//! radiance) within 0.5%, HDR suns included, and what is computed from a conversion (SH,
//! irradiance, prefiltered levels) agrees with the input it came from.

use crate::common;

use cubeforge::internals::convert::{self, Loaded, Output, Source};
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::filter::{self, sh, ChainOptions, FilterKind, IrradianceMethod};
use cubeforge::internals::flux::{mean_radiance, Grid};
use cubeforge::internals::image::{ColorSpace, Image};
use cubeforge::internals::io::{FileFormat, Meta, ReadOptions};
use cubeforge::internals::layout::{equirect, Kind, Projection};
use cubeforge::internals::resample::Resampler;
use glam::{Vec3, Vec4};
use std::path::PathBuf;

/// Face sizes and projection sizes the issue names.
const FACE_SIZES: [usize; 10] = [8, 16, 24, 32, 48, 64, 96, 128, 192, 256];
const PROJECTION_SIZES: [usize; 4] = [16, 64, 128, 256];

/// The flux of a conversion's output.
fn output_flux(out: &Output, to: Kind) -> [f64; 3] {
    match out {
        Output::Cube(c) => mean_radiance(
            Grid::Cube(c.size()),
            &c.levels[0].iter().collect::<Vec<_>>(),
        ),
        Output::Image(img) => {
            let p = to.projection().expect("a projection");
            mean_radiance(Grid::Projection(p, img.width, img.height), &[img])
        }
    }
}

/// Largest relative change of any channel's flux.
fn change(got: [f64; 3], want: [f64; 3]) -> f64 {
    (0..3)
        .map(|c| (got[c] / want[c] - 1.0).abs())
        .fold(0.0, f64::max)
}

/// Converts `loaded` to faces at every face size and to each projection at several sizes;
/// returns the largest flux change and where it happened.
fn worst_change(loaded: &Loaded) -> (f64, String) {
    let want = loaded.mean_radiance();
    let mut worst = (0.0, String::new());
    let rs = Resampler::default();
    let jobs = FACE_SIZES.iter().map(|&n| (Kind::Faces, n)).chain(
        [
            Kind::Equirect,
            Kind::Sphere,
            Kind::Angular,
            Kind::Octahedral,
        ]
        .into_iter()
        .flat_map(|k| PROJECTION_SIZES.iter().map(move |&n| (k, n))),
    );
    for (to, n) in jobs {
        let out = convert::convert(loaded, to, n, &rs);
        let e = change(output_flux(&out, to), want);
        if e > worst.0 {
            worst = (e, format!("{} {n}", to.name()));
        }
    }
    worst
}

/// An input held in memory: a panorama.
fn panorama(img: Image) -> Loaded {
    Loaded {
        source: Source::Projection(Projection::Equirect, img),
        kind: Kind::Equirect.into(),
        hdr: true,
        meta: Meta {
            file_format: FileFormat::Exr,
            pixel_format: "RGBA32F".into(),
            color_space: ColorSpace::Linear,
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

/// A 256 x 128 sky with a sun of 30000 two texels wide: the case point lookups get wrong.
fn sun_sky() -> Image {
    let sun = Vec3::new(0.3, 0.5, 0.8).normalize();
    Image::from_fn(256, 128, |x, y| {
        let d = equirect::uv_to_dir((x as f32 + 0.5) / 256.0, (y as f32 + 0.5) / 128.0);
        let sky = Vec4::new(
            0.3 + 0.2 * d.y,
            0.4 + 0.2 * d.y,
            0.6 + 0.3 * d.y.max(0.0),
            1.0,
        );
        if d.dot(sun) > 0.9996 {
            Vec4::new(30000.0, 28000.0, 25000.0, 1.0)
        } else {
            sky
        }
    })
}

#[test]
fn a_sun_keeps_its_light_at_every_size() {
    let loaded = panorama(sun_sky());
    let peaks = loaded.peaks().expect("the sun is a peak");
    assert!(peaks.len() < 64, "{} peak texels", peaks.len());
    let (e, at) = worst_change(&loaded);
    println!(
        "synthetic sun: largest flux change {:.4}% ({at})",
        e * 100.0
    );
    assert!(e < 0.005, "flux changes by {:.3}% at {at}", e * 100.0);
}

#[test]
fn flux_conserving_output_is_the_same_with_any_thread_count() {
    let loaded = panorama(sun_sky());
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let rs = Resampler::default();
            let Output::Cube(c) = convert::convert(&loaded, Kind::Faces, 24, &rs) else {
                panic!()
            };
            let Output::Image(s) = convert::convert(&loaded, Kind::Sphere, 48, &rs) else {
                panic!()
            };
            let Output::Image(o) = convert::convert(&loaded, Kind::Octahedral, 48, &rs) else {
                panic!()
            };
            (c, s, o)
        })
    };
    let one = run(1);
    assert!(
        one == run(2) && one == run(3),
        "outputs differ by thread count"
    );
}

/// Every HDR panorama of ../shared/fixtures/real, as the CLI reads it.
fn real_panoramas() -> Vec<PathBuf> {
    let Some(real) = common::real_dir() else {
        return vec![];
    };
    let mut files = vec![];
    for dir in ["hdr", "zip", "dwab"] {
        let mut names: Vec<PathBuf> = std::fs::read_dir(real.join(dir))
            .expect("lists")
            .map(|e| e.unwrap().path())
            .collect();
        names.sort();
        files.extend(names);
    }
    files
}

/// A real panorama's name without its folder and extension, as the docs name it.
fn stem(path: &std::path::Path) -> String {
    path.file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().into_owned())
}

fn load(path: &PathBuf) -> Loaded {
    convert::load(std::slice::from_ref(path), None, &ReadOptions::default()).expect("loads")
}

/// Measured on the 40 panoramas (4 .hdr, 18 ZIP, 18 DWAB EXR), faces of 8 to 256 and
/// equirect, sphere, angular and octahedral maps of 16 to 256: largest change 0.145% (the
/// issue's figures before: up to 43%); octahedral maps at most 0.036% (forest, 128 x 128).
/// Bound: 0.5%.
#[test]
fn real_panoramas_keep_their_flux() {
    let mut worst = (0.0, String::new());
    for path in real_panoramas() {
        let (e, at) = worst_change(&load(&path));
        println!("{}: {:.4}% ({at})", path.display(), e * 100.0);
        if e > worst.0 {
            worst = (e, format!("{} {at}", stem(&path)));
        }
    }
    println!("largest flux change {:.4}% ({})", worst.0 * 100.0, worst.1);
    if worst.0 > 0.0 {
        let text = format!("largest change **{:.3}%** ({})", worst.0 * 100.0, worst.1);
        crate::figures::check("docs/conventions.md", "flux real", &text);
    }
    assert!(worst.0 < 0.005, "{:.3}% at {}", worst.0 * 100.0, worst.1);
}

/// Each real panorama and the synthetic sun as an octahedral map of 128 x 128 (the input of
/// a probe pipeline), converted on to faces and every projection at every size: each output
/// keeps the octahedral map's flux. Measured: largest change 0.303% (sunrise to a 32 x 32
/// mirror ball, whose rim is the panorama's own worst output too: 0.145%). Bound: 0.5%.
#[test]
fn octahedral_maps_keep_their_flux() {
    let mut inputs: Vec<(String, Loaded)> = real_panoramas()
        .iter()
        .map(|p| (stem(p), load(p)))
        .collect();
    inputs.push(("synthetic sun".into(), panorama(sun_sky())));
    let mut worst = (0.0, String::new());
    for (name, pano) in &inputs {
        let Output::Image(img) =
            convert::convert(pano, Kind::Octahedral, 64, &Resampler::default())
        else {
            panic!()
        };
        let mut octa = panorama(img);
        octa.source = match octa.source {
            Source::Projection(_, img) => Source::Projection(Projection::Octahedral, img),
            s => s,
        };
        octa.kind = Kind::Octahedral.into();
        let (e, at) = worst_change(&octa);
        if e > worst.0 {
            worst = (e, format!("{name} {at}"));
        }
    }
    println!(
        "octahedral inputs: largest flux change {:.4}% ({})",
        worst.0 * 100.0,
        worst.1
    );
    if inputs.len() > 1 {
        let text = format!("largest change {:.3}% ({})", worst.0 * 100.0, worst.1);
        crate::figures::check("docs/conventions.md", "flux octahedral", &text);
    }
    assert!(worst.0 < 0.005, "{:.3}% at {}", worst.0 * 100.0, worst.1);
}

/// SH of a panorama's own texels: each texel's radiance times the basis at its centre times
/// its exact solid angle.
fn direct_sh(img: &Image) -> [[f64; 3]; 9] {
    let grid = Grid::Projection(Projection::Equirect, img.width, img.height);
    let mut c = [[0.0f64; 3]; 9];
    for y in 0..img.height {
        let a = grid.solid_angle(0, y);
        for x in 0..img.width {
            let d = grid.dir(0, x as f32 + 0.5, y as f32 + 0.5).unwrap();
            let p = img.get(x, y);
            for (i, b) in sh::basis(d).iter().enumerate() {
                for ch in 0..3 {
                    c[i][ch] += p[ch] as f64 * b * a;
                }
            }
        }
    }
    c
}

/// The cube the `irradiance` and `prefilter` commands start from: the input at its own
/// resolution (at most 256 faces for irradiance).
fn base(loaded: &Loaded, size: usize) -> CubeMap {
    match convert::convert(loaded, Kind::Faces, size, &Resampler::default()) {
        Output::Cube(c) => c,
        Output::Image(_) => panic!("faces are a cube"),
    }
}

/// Measured on the 40 panoramas: c0 within 0.11% of the direct projection (the issue saw 20%
/// on esplanade), bands 1 and 2 within 0.19% of c0. Bounds: 1% of c0 for all nine.
#[test]
fn sh_of_real_panoramas_match_a_direct_projection() {
    let mut worst = (0.0f64, 0.0f64);
    for path in &real_panoramas() {
        let loaded = load(path);
        let Source::Projection(_, img) = &loaded.source else {
            panic!()
        };
        let want = direct_sh(img);
        let base = base(&loaded, loaded.face_size().min(256));
        let (_, got) = filter::irradiance(&base, 8, IrradianceMethod::Sh);
        for ch in 0..3 {
            let c0 = want[0][ch];
            let e0 = (got[0][ch] / c0 - 1.0).abs();
            let rest = (1..9)
                .map(|i| ((got[i][ch] - want[i][ch]) / c0).abs())
                .fold(0.0, f64::max);
            worst = (worst.0.max(e0), worst.1.max(rest));
            assert!(
                e0 < 0.01,
                "{}: c0 off by {:.3}%",
                path.display(),
                e0 * 100.0
            );
            assert!(
                rest < 0.01,
                "{}: SH off by {:.3}% of c0",
                path.display(),
                rest * 100.0
            );
        }
    }
    println!(
        "SH vs direct projection: c0 {:.4}%, others {:.4}% of c0",
        worst.0 * 100.0,
        worst.1 * 100.0
    );
    if !real_panoramas().is_empty() {
        let text = format!("within {:.2}% (c0)", worst.0 * 100.0);
        crate::figures::check("docs/conventions.md", "flux sh", &text);
    }
}

/// The whole chain from a panorama and from a 4x enlarged copy of it (2048 x 1024) agree:
/// irradiance (brute force, every texel), SH and each GGX level's flux. Measured on
/// esplanade (sun 30000) and park: irradiance within 0.25%, SH c0 0.09%, GGX levels 0.015%.
/// Bound: 1%. Both irradiance maps integrate cube maps of one face size (the smaller
/// input's, 128): the exact integrals over a 128- and a 256-face copy of park differ by 1.6%
/// where an output texel's horizon grazes the sun (its texels land a little differently), and
/// the irradiance integrates the sun where it is.
#[test]
fn chain_agrees_with_a_4x_enlarged_copy() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let mut all = 0.0f64;
    for name in ["hdr/esplanade.hdr", "hdr/park.hdr"] {
        let small = load(&real.join(name));
        let Output::Image(big) =
            convert::convert(&small, Kind::Equirect, 512, &Resampler::default())
        else {
            panic!()
        };
        assert_eq!((big.width, big.height), (2048, 1024));
        let big = panorama(big);
        let mut worst = [0.0f64; 3];
        let [a, b] = [&small, &big].map(|l| {
            let base = base(l, small.face_size().min(256));
            filter::irradiance(&base, 16, IrradianceMethod::Brute)
        });
        for (fa, fb) in a.0.levels[0].iter().zip(&b.0.levels[0]) {
            for (pa, pb) in fa.pixels.iter().zip(&fb.pixels) {
                for c in 0..3 {
                    worst[0] = worst[0].max((pb[c] / pa[c] - 1.0).abs() as f64);
                }
            }
        }
        for c in 0..3 {
            worst[1] = worst[1].max((b.1[0][c] / a.1[0][c] - 1.0).abs());
        }
        let opts = ChainOptions {
            filter: FilterKind::Ggx,
            levels: Some(6),
            samples: 32,
            ..ChainOptions::default()
        };
        let [ca, cb] = [&small, &big].map(|l| {
            let base = base(l, 64);
            filter::prefilter(&base, &opts, &|_| {}).0
        });
        for (la, lb) in ca.levels.iter().zip(&cb.levels) {
            let n = la[0].width;
            let fa = mean_radiance(Grid::Cube(n), &la.iter().collect::<Vec<_>>());
            let fb = mean_radiance(Grid::Cube(n), &lb.iter().collect::<Vec<_>>());
            worst[2] = worst[2].max(change(fb, fa));
        }
        println!(
            "{name}: from the 4x copy, irradiance {:.3}%, SH c0 {:.4}%, GGX level flux {:.3}%",
            worst[0] * 100.0,
            worst[1] * 100.0,
            worst[2] * 100.0
        );
        assert!(worst.iter().all(|&e| e < 0.01), "{name}: {worst:?}");
        all = worst.iter().fold(all, |a, &b| a.max(b));
    }
    let text = format!("agree within {:.2}%", all * 100.0);
    crate::figures::check("docs/conventions.md", "flux 4x", &text);
}

/// `info` prints the flux a user can check a conversion with.
#[test]
fn info_reports_the_flux() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("sun.exr");
    common::write_image(&src, &sun_sky());
    let cross = dir.path().join("cross.exr");
    let out = common::run([
        "convert".as_ref(),
        src.as_os_str(),
        "-o".as_ref(),
        cross.as_os_str(),
        "--size".as_ref(),
        "16".as_ref(),
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    let flux = |p: &PathBuf| -> [f64; 3] {
        let out = common::run(["info".as_ref(), p.as_os_str(), "--json".as_ref()]);
        assert!(out.status.success(), "{}", common::stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let v = if v.is_array() { v[0].clone() } else { v };
        let f = v["flux"].as_array().expect("a flux entry");
        std::array::from_fn(|c| f[c].as_f64().unwrap())
    };
    let (a, b) = (flux(&src), flux(&cross));
    println!("info flux: panorama {a:?}, 16 px cross {b:?}");
    // Half-float storage of the sun (30000 rounds to 29984) is the only difference.
    assert!(change(b, a) < 0.005, "{a:?} vs {b:?}");
    let text = common::run(["info".as_ref(), src.as_os_str()]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("flux:"));
}
