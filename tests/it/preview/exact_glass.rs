//! `--refraction exact` against a ray trace of the same solid sphere written here, in double
//! precision and from the angles (Fresnel's sine and tangent laws, Snell's law as a rotation
//! in the plane of incidence, each chord intersected as a quadratic), bouncing until less
//! than 1e-14 of the light is left inside; the texts' output unchanged; the ball a lens.

use super::*;
use crate::common;
use cubeforge::internals::preview::Refraction;
use cubeforge::{Destination, Job, PreviewJob};
use std::path::Path;

/// Unpolarised Fresnel reflectance from medium `n1` into `n2` at angle `theta_i` (radians).
fn fresnel_angles(theta_i: f64, n1: f64, n2: f64) -> f64 {
    let s = n1 / n2 * theta_i.sin();
    if s >= 1.0 {
        return 1.0;
    }
    if theta_i < 1e-7 {
        let r = (n1 - n2) / (n1 + n2);
        return r * r;
    }
    let theta_t = s.asin();
    let rs = ((theta_i - theta_t).sin() / (theta_i + theta_t).sin()).powi(2);
    let rp = ((theta_i - theta_t).tan() / (theta_i + theta_t).tan()).powi(2);
    (rs + rp) / 2.0
}

/// Snell's law: unit `d` meeting the surface with unit normal `n` (facing `d`'s side) from `n1`
/// into `n2`, as sin(theta_t) along the tangent and -cos(theta_t) along the normal.
fn snell(d: DVec3, n: DVec3, n1: f64, n2: f64) -> Option<DVec3> {
    let tangent = d - n * d.dot(n);
    let sin_t = n1 / n2 * tangent.length();
    if sin_t >= 1.0 {
        return None;
    }
    let along = if tangent.length() > 0.0 {
        tangent.normalize() * sin_t
    } else {
        DVec3::ZERO
    };
    Some(along - n * (1.0 - sin_t * sin_t).sqrt())
}

/// The rays (unit direction, fraction of the light) the eye ray through pixel (x, y) becomes
/// on a sphere of index 1 / `eta` in air: the front reflection, then every exit. With
/// `max_exits`, the renderer's stopping rule: what is inside after that many internal hits
/// leaves by the last exit.
fn glass_rays(
    x: usize,
    y: usize,
    n: usize,
    eta: f64,
    max_exits: Option<usize>,
) -> Option<Vec<(DVec3, f64)>> {
    let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
    let p = hit_sphere(eye, dir)?;
    let (n_out, n_in) = (1.0, 1.0 / eta);
    let i = dir.normalize();
    let nrm = p.normalize();
    let r = fresnel_angles((-i.dot(nrm)).clamp(-1.0, 1.0).acos(), n_out, n_in);
    let mut rays = vec![(reflect(i, nrm), r)];
    let mut inside = 1.0 - r;
    let Some(mut d) = snell(i, nrm, n_out, n_in) else {
        return Some(rays);
    };
    let mut q = p;
    for _ in 0..max_exits.unwrap_or(100_000) {
        // The far root of |q + t d| = 1 from a point on (or just inside) the sphere.
        let (b, c) = (q.dot(d), q.dot(q) - 1.0);
        q += d * (-b + (b * b - c).max(0.0).sqrt());
        let out_n = q.normalize();
        let r = fresnel_angles(d.dot(out_n).clamp(-1.0, 1.0).acos(), n_in, n_out);
        if let Some(out) = snell(d, -out_n, n_in, n_out) {
            rays.push((out, inside * (1.0 - r)));
        }
        inside *= r;
        d = reflect(d, out_n);
        if inside < 1e-14 {
            break;
        }
    }
    if max_exits.is_some() && rays.len() > 1 {
        rays.last_mut().unwrap().1 += inside;
    }
    Some(rays)
}

/// The expected colour of pixel (x, y) with exact refraction, None off the sphere.
fn expected_exact(
    m: &Material,
    x: usize,
    y: usize,
    n: usize,
    max_exits: Option<usize>,
) -> Option<DVec3> {
    let sum = |eta: f32| -> Option<DVec3> {
        let rays = glass_rays(x, y, n, eta as f64, max_exits)?;
        Some(rays.iter().map(|(d, w)| env(*d) * *w).sum())
    };
    Some(match m.model {
        Model::Refract => lerp(
            m.decal_color.as_dvec3(),
            sum(m.eta_ratio.x)?,
            m.transmittance as f64,
        ),
        Model::Dispersion => DVec3::new(
            sum(m.eta_ratio.x)?.x,
            sum(m.eta_ratio.y)?.y,
            sum(m.eta_ratio.z)?.z,
        ),
        _ => unreachable!("exact applies to refract and dispersion"),
    })
}

fn exact_view(n: usize) -> Options {
    Options {
        refraction: Refraction::Exact,
        ..opts(n)
    }
}

/// A bubble: air (1 / 1.5) in glass, where light meets the sphere from the denser side and is
/// totally reflected at the front beyond the critical angle.
fn bubble() -> Material {
    Material {
        name: "bubble".into(),
        model: Model::Refract,
        eta_ratio: Vec3::splat(1.5),
        ..Material::default()
    }
}

#[test]
fn exact_glass_matches_a_double_precision_trace() {
    let n = 96;
    let mut materials: Vec<Material> = ["glass", "water", "diamond", "plastic", "crystal"]
        .iter()
        .map(|s| material::preset(s).unwrap())
        .collect();
    materials.push(bubble());
    for m in &materials {
        let img = render(m, &exact_view(n));
        let (mut full, mut same_rule, mut count) = (0.0f64, 0.0f64, 0);
        for y in 0..n {
            for x in 0..n {
                let got = rgb(img.get(x, y));
                let Some(want) = expected_exact(m, x, y, n, None) else {
                    let (_, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                    assert!((got - env(dir)).abs().max_element() < 1e-4, "background");
                    continue;
                };
                let rule = expected_exact(
                    m,
                    x,
                    y,
                    n,
                    Some(cubeforge::internals::preview::glass::MAX_EXITS),
                )
                .unwrap();
                assert!(got.is_finite(), "{}: NaN at ({x}, {y})", m.name);
                full = full.max((got - want).abs().max_element());
                same_rule = same_rule.max((got - rule).abs().max_element());
                count += 1;
            }
        }
        println!(
            "{}: max error {full:.2e} vs the full series, {same_rule:.2e} vs {} exits, over {count} pixels",
            m.name,
            cubeforge::internals::preview::glass::MAX_EXITS
        );
        assert!(count > 4000);
        // f32 against f64 on the same stopping rule; the series cut after MAX_EXITS internal
        // hits differs only at the rim, where nearly all the light bounces on.
        assert!(same_rule < 5e-5, "{}: {same_rule}", m.name);
        assert!(full < 5e-4, "{}: {full}", m.name);
    }
}

#[test]
fn exact_glass_keeps_the_light_and_is_a_lens() {
    // A white environment: the weights sum to one at every pixel, the ball disappears.
    let white = FnEnv((|_| Vec4::ONE) as fn(Vec3) -> Vec4);
    let n = 64;
    for name in ["glass", "diamond", "crystal"] {
        let m = material::preset(name).unwrap();
        let img = preview::render(&white, &m, &Surface::default(), &exact_view(n)).unwrap();
        let worst = img
            .pixels
            .iter()
            .map(|p| (p.truncate() - Vec3::ONE).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{name}: {worst}");
    }
    // Red grows with x, and image right is -X. One refraction at the front (the texts) bends a
    // ray right of the centre back past the axis a little; the whole ball, in and out, bends
    // it twice as far (2 (theta_i - theta_t)): a lens that shows the world behind inverted
    // and wide, where the texts' view is magnified.
    let m = material::preset("glass").unwrap();
    let (texts, exact) = (render(&m, &opts(n)), render(&m, &exact_view(n)));
    let across = |img: &Image, c: usize, (a, b): ((usize, usize), (usize, usize))| {
        img.get(b.0, b.1)[c] - img.get(a.0, a.1)[c]
    };
    let h = ((n / 2 - 12, n / 2), (n / 2 + 11, n / 2));
    let v = ((n / 2, n / 2 - 12), (n / 2, n / 2 + 11));
    for (c, pair) in [(0, h), (1, v)] {
        let (t, e) = (across(&texts, c, pair), across(&exact, c, pair));
        println!("channel {c} across the centre: texts {t:.3}, exact {e:.3}");
        assert!(e > 0.1 && e > t + 0.05, "channel {c}: texts {t}, exact {e}");
    }
    // The reflect model ignores the flag.
    let chrome = material::preset("chrome").unwrap();
    assert_eq!(render(&chrome, &opts(n)), render(&chrome, &exact_view(n)));
    // Rows in parallel: the same picture on any number of threads.
    let crystal = material::preset("crystal").unwrap();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                render(
                    &crystal,
                    &Options {
                        samples: 4,
                        ..exact_view(48)
                    },
                )
            })
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn the_flag_runs_through_the_job_and_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let sky = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");
    let cli = |name: &str, extra: &[&str]| {
        let path = out(name);
        let mut args = vec!["preview", sky, "-o", &path, "--size", "40", "-m", "crystal"];
        args.extend_from_slice(extra);
        let r = common::run(args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        std::fs::read(&path).unwrap()
    };
    // The default is the texts, byte for byte; exact is another picture.
    let default = cli("default.png", &[]);
    assert_eq!(default, cli("texts.png", &["--refraction", "texts"]));
    assert_ne!(default, cli("exact.png", &["--refraction", "exact"]));
    // The job carries it: the library's render of the same view, exact.
    let exr = out("job.exr");
    let mut job = PreviewJob::new(sky.into(), Destination::Path(exr.clone().into()));
    job.material = "glass".into();
    job.view.size = 32;
    job.view.refraction = Refraction::Exact;
    job.run(&()).unwrap();
    let env = common::preview_env(Path::new(sky)).unwrap();
    let want = preview::render(
        &env.sampler,
        &material::preset("glass").unwrap(),
        &Surface::default(),
        &job.view,
    )
    .unwrap();
    let got = common::read_image(Path::new(&exr));
    let worst = got
        .pixels
        .iter()
        .zip(&want.pixels)
        .map(|(a, b)| (*a - *b).abs().max_element() / b.max_element().max(1.0))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "job vs library: {worst}");
    let texts = preview::render(
        &env.sampler,
        &material::preset("glass").unwrap(),
        &Surface::default(),
        &Options {
            refraction: Refraction::Texts,
            ..job.view
        },
    )
    .unwrap();
    assert_ne!(texts, want);
    // Exact needs the fragment pipeline: per-vertex is refused in one line.
    let r = common::run([
        "preview",
        sky,
        "-o",
        &out("v.png"),
        "--size",
        "16",
        "-m",
        "glass",
        "--refraction",
        "exact",
        "--shading",
        "per-vertex",
    ]);
    assert!(!r.status.success());
    let e = String::from_utf8_lossy(&r.stderr);
    assert!(
        e.contains("--refraction exact") && e.contains("--shading per-fragment"),
        "{e}"
    );
}

#[test]
fn material_files_may_ask_for_exact_refraction() {
    let p = Path::new("mats/ball.toml");
    let m = material::parse_toml(
        "model = \"refract\"\neta_ratio = 0.6667\nrefraction = \"exact\"\n",
        p,
    )
    .unwrap();
    assert_eq!(m.refraction, Some(Refraction::Exact));
    let back = material::parse_toml(&material::to_toml(&m), p).unwrap();
    assert_eq!(back.refraction, Some(Refraction::Exact));
    // The file's word wins over the option, either way.
    let glass = Material {
        eta_ratio: Vec3::splat(0.6667),
        ..material::preset("glass").unwrap()
    };
    assert_eq!(render(&m, &opts(32)), render(&glass, &exact_view(32)));
    let texts = Material {
        refraction: Some(Refraction::Texts),
        ..glass.clone()
    };
    assert_eq!(render(&texts, &exact_view(32)), render(&glass, &opts(32)));
    // Only where it means something, and never per vertex.
    for (text, needle) in [
        ("model = \"reflect\"\nrefraction = \"exact\"\n", "line 2"),
        (
            "model = \"refract\"\neta_ratio = 0.7\nrefraction = \"twice\"\n",
            "line 3",
        ),
    ] {
        let e = material::parse_toml(text, p).unwrap_err().to_string();
        assert!(
            e.starts_with("mats/ball.toml: ") && e.contains(needle),
            "{e}"
        );
    }
    let per_vertex = Options {
        shading: Shading::PerVertex,
        ..opts(16)
    };
    let e = preview::render(&smooth_env(), &m, &Surface::default(), &per_vertex)
        .unwrap_err()
        .to_string();
    assert!(e.contains("per-fragment"), "{e}");
}
