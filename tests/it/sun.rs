//! The sun of a real panorama, found and measured (issue 49): esplanade's sun where its bright
//! texels are, with the light they hold; park's and studio's brightest lights; venice (an
//! overcast canal) has none. Each panorama as the CLI reads it, at its own size.

use crate::common;
use cubeforge::internals::convert::{self, Source};
use cubeforge::internals::flux::{sun, Grid};
use cubeforge::internals::io::ReadOptions;
use cubeforge::internals::layout::Projection;
use glam::DVec3;

/// The panorama's image and its grid.
fn panorama(name: &str) -> Option<(cubeforge::internals::image::Image, Grid)> {
    let path = common::real_dir()?.join("hdr").join(name);
    let loaded = convert::load(&[path], None, &ReadOptions::default()).expect("loads");
    let Source::Projection(Projection::Equirect, img) = loaded.source else {
        panic!("{name} is a panorama")
    };
    let grid = Grid::Projection(Projection::Equirect, img.width, img.height);
    Some((img, grid))
}

fn lum(p: glam::Vec4) -> f64 {
    0.2126 * p.x as f64 + 0.7152 * p.y as f64 + 0.0722 * p.z as f64
}

/// The direction of the brightest texel.
fn brightest(img: &cubeforge::internals::image::Image, grid: Grid) -> DVec3 {
    let i = (0..img.pixels.len())
        .max_by(|&a, &b| lum(img.pixels[a]).total_cmp(&lum(img.pixels[b])))
        .unwrap();
    let (x, y) = (i % img.width, i / img.width);
    grid.dir(0, x as f32 + 0.5, y as f32 + 0.5)
        .unwrap()
        .as_dvec3()
}

/// The luminance-weighted centroid of the texels above `above` within 5 degrees of `near`
/// (the sun's texels: esplanade has a second bright patch 15 degrees away) and their integral
/// (luminance times solid angle), written apart from the finder.
fn bright(
    img: &cubeforge::internals::image::Image,
    grid: Grid,
    above: f64,
    near: DVec3,
) -> (DVec3, f64) {
    let (mut sum, mut total) = (DVec3::ZERO, 0.0);
    let reach = 5f64.to_radians().cos();
    for y in 0..img.height {
        for x in 0..img.width {
            let l = lum(img.pixels[y * img.width + x]);
            let d = grid
                .dir(0, x as f32 + 0.5, y as f32 + 0.5)
                .unwrap()
                .as_dvec3();
            if l > above && d.dot(near) >= reach {
                let w = l * grid.solid_angle(x, y);
                sum += d * w;
                total += w;
            }
        }
    }
    (sum.normalize_or_zero(), total)
}

#[test]
fn esplanade_has_a_sun_where_its_bright_texels_are() {
    let Some((img, grid)) = panorama("esplanade.hdr") else {
        return;
    };
    let lights = sun::find(grid, &[&img]);
    let s = lights.sun.expect("esplanade has a sun");
    let near = brightest(&img, grid);
    let (centre, _) = bright(&img, grid, 3000.0, near);
    let off = s.direction.as_dvec3().angle_between(centre).to_degrees();
    let (hi, lo) = (
        bright(&img, grid, 3000.0, near).1,
        bright(&img, grid, 100.0, near).1,
    );
    println!(
        "esplanade (sky {:.3}): sun at {:?} ({off:.2} degrees from its texels above 3000), irradiance {:.1} \
         (texels above 3000: {hi:.1}, above 100: {lo:.1}), {:.2} degrees across, {} texels",
        lights.sky,
        s.direction,
        s.luminance(),
        s.angular_diameter_deg,
        s.texels
    );
    assert!(off < 1.0, "{off} degrees");
    // Taken out, the sun leaves the map's flux less its irradiance over 4 pi.
    let mut img = img;
    let before = cubeforge::internals::flux::mean_radiance(grid, &[&img]);
    sun::remove(grid, std::slice::from_mut(&mut img), &s, lights.threshold);
    let after = cubeforge::internals::flux::mean_radiance(grid, &[&img]);
    for c in 0..3 {
        let want = before[c] - s.irradiance[c] / (4.0 * std::f64::consts::PI);
        let moved = after[c] / want - 1.0;
        println!(
            "esplanade without its sun: channel {c} flux {:.5} against {want:.5}",
            after[c]
        );
        assert!(moved.abs() < 5e-3, "channel {c}: {moved}");
    }
    assert!(
        s.luminance() >= hi && s.luminance() <= lo,
        "{} not in {hi}..{lo}",
        s.luminance()
    );
}

#[test]
fn venice_has_no_sun_and_the_others_say_what_they_hold() {
    for name in ["venice.hdr", "park.hdr", "studio.hdr"] {
        let Some((img, grid)) = panorama(name) else {
            return;
        };
        let lights = sun::find(grid, &[&img]);
        println!(
            "{name}: sky {:.3}, sun {:?}, {} other lights",
            lights.sky,
            lights
                .sun
                .as_ref()
                .map(|s| (s.direction, s.luminance(), s.angular_diameter_deg)),
            lights.others.len()
        );
        if name == "venice.hdr" {
            assert!(lights.sun.is_none(), "venice: {:?}", lights.sun);
        }
    }
}

/// `info --json`'s `"sun"`: esplanade's where the finder puts it, with its lux at the stated
/// scale; venice's null.
#[test]
fn info_json_says_where_the_sun_is() {
    let Some(real) = common::real_dir() else {
        return;
    };
    let info = |name: &str| -> serde_json::Value {
        let path = real.join("hdr").join(name);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_cubeforge"))
            .args(["info", "--json"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", common::stderr(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let v = info("esplanade.hdr");
    let (img, grid) = panorama("esplanade.hdr").unwrap();
    let s = sun::find(grid, &[&img]).sun.unwrap();
    let s_json = &v["sun"];
    for c in 0..3 {
        let d = s_json["direction"][c].as_f64().unwrap();
        assert!((d - s.direction[c] as f64).abs() < 1e-6, "{s_json}");
        let e = s_json["irradiance"][c].as_f64().unwrap();
        assert!(
            (e - s.irradiance[c]).abs() < 1e-9 * s.luminance(),
            "{s_json}"
        );
    }
    let lux = s_json["illuminance_lux"].as_f64().unwrap();
    assert!((lux - s.luminance()).abs() < 1e-9 * lux, "{s_json}");
    assert_eq!(s_json["nits_per_unit"].as_f64(), Some(1.0));
    assert!(s_json["angular_diameter_deg"].as_f64().unwrap() > 0.0);
    assert!(v["lights"].as_array().is_some_and(|l| !l.is_empty()));
    let v = info("venice.hdr");
    assert!(v["sun"].is_null(), "{}", v["sun"]);
}
