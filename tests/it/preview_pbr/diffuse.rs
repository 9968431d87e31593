//! The preview's diffuse light (a white Lambertian sphere: irradiance over pi at its normal)
//! against a reference written here: the cosine integral of the panorama the preview reads,
//! texel by texel over its 512 x 256 texels (each its centre's direction and its exact solid
//! angle), for the `ibl --sun` test sky (a 2-degree disc of 20000) and the real panoramas of
//! ../shared/fixtures/real (skipped when absent). Beside it, the 9 SH coefficients the
//! preview read before, and the sizes of the irradiance cube around the one chosen.

use crate::common;
use crate::ibl::sun::sky_with_sun;
use cubeforge::internals::cube::{CubeMap, CubeSampler};
use cubeforge::internals::filter::{self, IrradianceLight, IrradianceMethod};
use cubeforge::internals::image::Image;
use cubeforge::internals::preview::pbr;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

/// The panorama's texels as (direction, radiance times solid angle), in docs/conventions.md's
/// frame: u = 0.5 looks along +Z, u growing towards +X, v = 0 is +Y.
fn texels(img: &Image) -> Vec<(DVec3, DVec3)> {
    let (w, h) = (img.width, img.height);
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        let lat = |v: f64| (0.5 - v / h as f64) * PI;
        let (top, bottom, mid) = (lat(y as f64), lat(y as f64 + 1.0), lat(y as f64 + 0.5));
        let solid = TAU / w as f64 * (top.sin() - bottom.sin());
        for x in 0..w {
            let phi = ((x as f64 + 0.5) / w as f64 - 0.5) * TAU;
            let d = DVec3::new(mid.cos() * phi.sin(), mid.sin(), mid.cos() * phi.cos());
            out.push((d, img.get(x, y).truncate().as_dvec3() * solid));
        }
    }
    out
}

/// Irradiance over pi at `n`: the sum over every texel of its radiance, solid angle and
/// clamped cosine.
fn brute(texels: &[(DVec3, DVec3)], n: DVec3) -> DVec3 {
    texels
        .iter()
        .map(|(d, l)| *l * n.dot(*d).max(0.0))
        .sum::<DVec3>()
        / PI
}

/// The normals compared: 1200 spread over the sphere (Fibonacci) and 400 within 6 degrees of
/// the terminator of the brightest texel, where a sun's clamped cosine bends.
fn normals(texels: &[(DVec3, DVec3)]) -> Vec<DVec3> {
    let lum = |l: DVec3| 0.2126 * l.x + 0.7152 * l.y + 0.0722 * l.z;
    let sun = texels
        .iter()
        .max_by(|a, b| lum(a.1).total_cmp(&lum(b.1)))
        .unwrap()
        .0;
    let golden = PI * (3.0 - 5f64.sqrt());
    let mut out: Vec<DVec3> = (0..1200)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / 1200.0;
            let r = (1.0 - y * y).sqrt();
            let a = golden * i as f64;
            DVec3::new(r * a.cos(), y, r * a.sin())
        })
        .collect();
    let t = if sun.y.abs() < 0.9 {
        DVec3::Y
    } else {
        DVec3::X
    };
    let (a, b) = (
        t.cross(sun).normalize(),
        sun.cross(t.cross(sun)).normalize(),
    );
    for i in 0..400 {
        let around = TAU * i as f64 / 400.0 * 7.0 % TAU;
        let off = (-6.0 + 12.0 * ((i * 37) % 400) as f64 / 399.0).to_radians();
        let rim = a * around.cos() + b * around.sin();
        out.push(rim * off.cos() + sun * off.sin());
    }
    out
}

/// Mean and largest relative error (the channel furthest off) over `normals`.
fn errors(want: &[DVec3], normals: &[DVec3], got: impl Fn(Vec3) -> Vec3 + Sync) -> (f64, f64) {
    let e: Vec<f64> = normals
        .par_iter()
        .zip(want)
        .map(|(n, w)| {
            let g = got(n.as_vec3()).as_dvec3();
            ((g - *w).abs() / *w).max_element()
        })
        .collect();
    (
        e.iter().sum::<f64>() / e.len() as f64,
        e.iter().copied().fold(0.0, f64::max),
    )
}

/// Level 0 of a sampler as a cube map.
fn level0(s: &CubeSampler) -> CubeMap {
    let n = s.size();
    CubeMap {
        levels: vec![std::array::from_fn(|f| {
            Image::from_fn(n, n, |x, y| s.texel(0, f, x, y))
        })],
    }
}

/// One panorama's errors: the preview's diffuse, the SH9 it read before, the cube's bounded
/// part at other sizes, and the whole irradiance in a cube (the viewer's) looked up
/// bilinearly; each (mean, largest).
struct Measured {
    preview: (f64, f64),
    sh9: (f64, f64),
    sizes: Vec<(usize, (f64, f64))>,
    whole: Vec<(usize, (f64, f64))>,
}

fn measure(path: &Path, sizes: &[usize], whole: &[usize]) -> Measured {
    let tx = texels(&common::read_image(path));
    let normals = normals(&tx);
    let want: Vec<DVec3> = normals.par_iter().map(|n| brute(&tx, *n)).collect();
    let env = common::preview_env(path).unwrap();
    let setup = pbr::prepare(&env, path, None).unwrap();
    let split = &setup.split_sum;
    let preview = errors(&want, &normals, |n| split.irradiance_over_pi(n));
    let cube = level0(&env.sampler);
    let (_, coeffs) = filter::irradiance(&cube, 1, IrradianceMethod::Sh);
    let over_pi = filter::sh::irradiance_over_pi(&coeffs);
    let sh9 = errors(&want, &normals, |n| {
        let y = filter::sh::basis(n);
        let c = (0..9).fold(DVec3::ZERO, |s, i| s + DVec3::from(over_pi[i]) * y[i]);
        c.max(DVec3::ZERO).as_vec3()
    });
    let sizes = sizes
        .iter()
        .map(|&s| {
            let light = IrradianceLight::new(&cube, s);
            (s, errors(&want, &normals, |n| light.at(n)))
        })
        .collect();
    let whole = whole
        .iter()
        .map(|&s| {
            let baked = CubeSampler::new(&split.diffuse().to_cube(s));
            (
                s,
                errors(&want, &normals, |n| baked.bilinear(n, 0).truncate()),
            )
        })
        .collect();
    Measured {
        preview,
        sh9,
        sizes,
        whole,
    }
}

fn pc((mean, worst): (f64, f64)) -> String {
    format!("{:.2}% ({:.2}%)", mean * 100.0, worst * 100.0)
}

/// The `ibl --sun` test sky: the preview's diffuse within 1% mean and 3% largest of the
/// brute-force integral (measured 0.12% and 2.2%), where the SH9 are 160% off on the mean
/// (their ringing, several times the sky's light past the sun's terminator); and the table of
/// cube sizes that chose [`filter::IRRADIANCE_LIGHT_SIZE`]: 16 faces are off by 3.9% at
/// most, 64 gain 0.5% for four times the sum, and the whole irradiance in a cube (the peaks
/// interpolated too) needs 128 faces to come near.
#[test]
fn the_diffuse_light_is_the_maps_cosine_integral() {
    let dir = tempfile::tempdir().unwrap();
    let input = sky_with_sun(dir.path());
    let m = measure(&input, &[8, 16, 32, 64], &[32, 64, 128]);
    let mut rows = vec![
        "| irradiance looked up by normal | mean (largest) off the brute force |".to_string(),
        "|---|---|".to_string(),
        format!(
            "| the preview's: its bounded part at {} faces, the peaks summed | {} |",
            filter::IRRADIANCE_LIGHT_SIZE,
            pc(m.preview)
        ),
    ];
    for (s, e) in &m.sizes {
        rows.push(format!("| bounded part at {s} faces | {} |", pc(*e)));
    }
    for (s, e) in &m.whole {
        rows.push(format!(
            "| the whole irradiance in a {s}-face cube | {} |",
            pc(*e)
        ));
    }
    rows.push(format!("| 9 SH coefficients (before) | {} |", pc(m.sh9)));
    let table = rows.join("\n");
    println!("{table}");
    // What it costs a preview (printed, not checked: the machine's load moves it).
    let env = common::preview_env(&input).unwrap();
    let cube = level0(&env.sampler);
    let t = std::time::Instant::now();
    let light = IrradianceLight::new(&cube, filter::IRRADIANCE_LIGHT_SIZE);
    println!(
        "IrradianceLight of a {}-face map: {:.1} ms, {} peak texels",
        cube.size(),
        t.elapsed().as_secs_f64() * 1e3,
        light.peak_texels()
    );
    assert!(m.preview.0 < 0.01 && m.preview.1 < 0.03, "{table}");
    assert!(m.sh9.0 > 10.0 * m.preview.0, "{table}");
    crate::figures::check("docs/preview.md", "preview diffuse", &table);
}

/// The real panoramas: the preview's diffuse within 1% mean of the brute-force integral of
/// each, and 8% at any normal and channel: park's largest (7.1%) is at normals facing the
/// ground, in blue, whose irradiance there is a fifth of green's (0.003 off in 0.04), and
/// stays 3.7% with the bounded part at 128 faces: the map as a 128-face cube, not the sum.
/// The SH9 beside it, and the viewer's cube.
#[test]
fn the_diffuse_light_of_real_panoramas() {
    let real = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real/hdr");
    let mut files: Vec<PathBuf> = match std::fs::read_dir(&real) {
        Ok(d) => d.map(|e| e.unwrap().path()).collect(),
        Err(_) => {
            println!("SKIPPED: no {}", real.display());
            return;
        }
    };
    files.sort();
    let mut rows = vec![
        format!(
            "| panorama | the preview's diffuse, mean (largest) | 9 SH coefficients (before) | \
             the viewer's {}-face cube |",
            cubeforge::internals::view::IRRADIANCE_SIZE
        ),
        "|---|---|---|---|".to_string(),
    ];
    for f in &files {
        let m = measure(f, &[], &[cubeforge::internals::view::IRRADIANCE_SIZE]);
        let name = f.file_stem().unwrap().to_string_lossy();
        rows.push(format!(
            "| {name} | {} | {} | {} |",
            pc(m.preview),
            pc(m.sh9),
            pc(m.whole[0].1)
        ));
        assert!(m.preview.0 < 0.01 && m.preview.1 < 0.08, "{name}: {rows:?}");
    }
    let table = rows.join("\n");
    println!("{table}");
    crate::figures::check("docs/preview.md", "preview diffuse real", &table);
}
