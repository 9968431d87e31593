//! Control maps (section 7.2.4): reflectivity, transmittance, blur and mask where the map
//! says, panorama decals, and the sidecar's LOD bias.

use super::*;
use cubeforge::internals::preview::Control;

#[test]
fn control_map_changes_reflectivity_where_it_says() {
    // R = 1 (mirror) for u < 0.5, R = 0 (decal only) for u >= 0.5; G = 1, B = 0, A = 1. The
    // default camera sees u = 0.25 to 0.75, the split (u = 0.5, +Z) down its middle.
    let (w, h) = (64, 32);
    let map = Image::from_fn(w, h, |x, _| {
        let r = if x < w / 2 { 1.0 } else { 0.0 };
        Vec4::new(r, 1.0, 0.0, 1.0)
    });
    let m = Material {
        decal_color: Vec3::new(1.0, 0.0, 0.0),
        reflectivity: 0.5,
        ..material::preset("chrome").unwrap()
    };
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &map,
            max_lod_bias: 4.0,
        }),
    };
    let n = 96;
    let img = preview::render(&smooth_env(), &m, &surface, &opts(n)).unwrap();
    let (mut mirror, mut decal) = (0, 0);
    for y in 0..n {
        for x in 0..n {
            let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
            let Some(p) = hit_sphere(eye, dir) else {
                continue;
            };
            // The equirect layout's u (around +Y, +Z at 0.5, +X at 0.75); v from the north pole.
            let u = 0.5 + p.x.atan2(p.z) / std::f64::consts::TAU;
            let v = p.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
            if !(0.1..0.9).contains(&v) {
                continue;
            }
            let got = rgb(img.get(x, y));
            let refl = env(reflect(p - eye, p.normalize()));
            if (0.26..0.49).contains(&u) {
                assert!(
                    (got - refl).abs().max_element() < 2e-5,
                    "mirror at ({x}, {y})"
                );
                mirror += 1;
            } else if (0.51..0.74).contains(&u) {
                assert!(
                    (got - DVec3::new(1.0, 0.0, 0.0)).abs().max_element() < 2e-5,
                    "decal at ({x}, {y})"
                );
                decal += 1;
            }
        }
    }
    println!("{mirror} mirror pixels, {decal} decal pixels");
    assert!(mirror > 500 && decal > 500);
    // The camera looks at -Z from +Z: image left is +X (u = 0.75), image right -X (u = 0.25).
    assert!(rgb(img.get(20, 48)).distance(DVec3::new(1.0, 0.0, 0.0)) < 1e-4);
    assert!(rgb(img.get(76, 48)).distance(DVec3::new(1.0, 0.0, 0.0)) > 0.1);
}

/// A decal painted as a panorama wraps the sphere as that panorama wraps the environment: the
/// sphere's (u, v) are the equirect layout's, so each point shows the decal's texel of its own
/// direction, the seam (at the back, -Z) included. Measured on a 256 x 128 panorama of the
/// smooth environment, decal only: largest error 6.0e-5 from the front and from the back
/// (bilinear between texels; the u of before, half a turn off, errs by 0.5). Bound: 5e-4.
#[test]
fn a_panorama_decal_wraps_like_the_environment() {
    let (w, h) = (256, 128);
    let pano = Image::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32;
        let v = (y as f32 + 0.5) / h as f32;
        synthetic::smooth(cubeforge::internals::layout::equirect::uv_to_dir(u, v))
    });
    let m = Material {
        reflectivity: 0.0,
        ..material::preset("mirror-decal").unwrap()
    };
    let surface = Surface {
        decal: Some(&pano),
        control: None,
    };
    let n = 96;
    for yaw in [0.0f32, 180.0] {
        let o = Options { yaw, ..opts(n) };
        let img = preview::render(&smooth_env(), &m, &surface, &o).unwrap();
        let (mut worst, mut count) = (0.0f64, 0);
        for y in 0..n {
            for x in 0..n {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let Some(p) = hit_sphere(eye, dir) else {
                    continue;
                };
                // The orbit turns the hit point with the camera.
                let p = if yaw == 0.0 {
                    p
                } else {
                    DVec3::new(-p.x, p.y, -p.z)
                };
                let want = synthetic::smooth(p.normalize().as_vec3());
                worst = worst.max((rgb(img.get(x, y)) - rgb(want)).abs().max_element());
                count += 1;
            }
        }
        println!("yaw {yaw}: largest error {worst:.2e} over {count} pixels");
        assert!(count > 3000 && worst < 5e-4, "yaw {yaw}: {worst}");
    }
}

#[test]
fn control_map_transmittance_blur_and_mask() {
    let n = 48;
    // G = 0: glass shows only its decal.
    let map = Image::filled(8, 8, Vec4::new(0.0, 0.0, 0.0, 1.0));
    let glass = Material {
        decal_color: Vec3::new(0.0, 0.0, 1.0),
        ..material::preset("glass").unwrap()
    };
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &map,
            max_lod_bias: 4.0,
        }),
    };
    let img = preview::render(&smooth_env(), &glass, &surface, &opts(n)).unwrap();
    assert_eq!(img.get(n / 2, n / 2), Vec4::new(0.0, 0.0, 1.0, 1.0));
    // A = 0: the Fresnel term does not apply; the reflectivity R (here 1) does.
    let crystal = material::preset("crystal").unwrap();
    let mirror = Image::filled(8, 8, Vec4::new(1.0, 0.0, 0.0, 0.0));
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &mirror,
            max_lod_bias: 4.0,
        }),
    };
    let img = preview::render(&smooth_env(), &crystal, &surface, &opts(n)).unwrap();
    let chrome = render(&material::preset("chrome").unwrap(), &opts(n));
    assert!(img
        .pixels
        .iter()
        .zip(&chrome.pixels)
        .all(|(a, b)| (*a - *b).abs().max_element() < 1e-5));
    // B: blur 0.5 of max_lod_bias 4 adds 2 levels, like --lod-bias 2.
    let chain = level_chain(64);
    let blur = Image::filled(8, 8, Vec4::new(1.0, 1.0, 0.5, 1.0));
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &blur,
            max_lod_bias: 4.0,
        }),
    };
    let chrome = material::preset("chrome").unwrap();
    let a = preview::render(&chain, &chrome, &surface, &opts(n)).unwrap();
    let b = preview::render(
        &chain,
        &chrome,
        &Surface::default(),
        &Options {
            lod_bias: 2.0,
            ..opts(n)
        },
    )
    .unwrap();
    assert_eq!(a, b);
}

#[test]
fn control_map_sidecar_gives_max_lod_bias() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("mask.png");
    let img = Image::filled(4, 2, Vec4::new(0.5, 0.25, 1.0, 1.0));
    std::fs::write(
        &map,
        cubeforge::internals::output::encode_image(
            &map,
            &img,
            &WriteOptions {
                linear: true,
                ..WriteOptions::default()
            },
        )
        .unwrap(),
    )
    .unwrap();
    let (read, max, side) = preview::read_control(&map, 4.0, &Default::default()).unwrap();
    assert_eq!(max, 4.0);
    assert!(side.is_none());
    // Linear data: 0.5 stays 0.5 (no sRGB decode), to 8-bit precision.
    assert!((read.get(0, 0).x - 0.5).abs() < 0.003);
    std::fs::write(dir.path().join("mask.png.json"), r#"{"max_lod_bias": 6.5}"#).unwrap();
    let (_, max, side) = preview::read_control(&map, 4.0, &Default::default()).unwrap();
    assert_eq!(max, 6.5);
    assert!(side.is_some());
    std::fs::write(dir.path().join("mask.png.json"), "{oops").unwrap();
    let e = preview::read_control(&map, 4.0, &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("mask.png.json") && !e.contains('\n'), "{e}");
}
