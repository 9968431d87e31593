//! Orientation, sampling, determinism: the chrome ball against the sphere-map layout, the
//! texts' orientation, stratified samples, and renders independent of the thread count.

use super::*;
use cubeforge::internals::layout::sphere as sphere_map;
use cubeforge::internals::preview::camera::sample_offsets;

#[test]
fn chrome_ball_matches_the_sphere_map_layout() {
    // From far along -Z (yaw 180), a chrome ball is the project's sphere map (camera facing
    // +Z, image right +X, up +Y; the centre shows -Z): the same directions at the same
    // places, so the preview's orientation agrees with `convert --to sphere`.
    let n = 64;
    let d = 1000.0f32;
    let fov = 2.0 * (1.0 / ((d * d - 1.0) as f64).sqrt()).atan().to_degrees() as f32;
    let o = Options {
        size: n,
        samples: 1,
        distance: d,
        fov,
        yaw: 180.0,
        background: Background::Color(Vec4::ZERO),
        ..Options::default()
    };
    let img = render(&material::preset("chrome").unwrap(), &o);
    let mut compared = 0;
    let mut worst = 0.0f32;
    for y in 0..n {
        for x in 0..n {
            let s = (x as f32 + 0.5) / n as f32;
            let t = 1.0 - (y as f32 + 0.5) / n as f32;
            let (cx, cy) = (2.0 * s - 1.0, 2.0 * t - 1.0);
            if cx * cx + cy * cy > 0.85 {
                continue;
            }
            let dir = sphere_map::st_to_dir(s, t).unwrap();
            let want = synthetic::smooth(dir.normalize());
            worst = worst.max((img.get(x, y) - want).abs().max_element());
            compared += 1;
        }
    }
    println!("chrome ball vs sphere map: max difference {worst:.2e} over {compared} pixels");
    assert!(compared > 2000);
    assert!(worst < 5e-3, "max difference {worst}");
}

#[test]
fn reflection_and_background_are_oriented_like_the_texts() {
    // Default camera: +Y at the top of the ball's reflection, the background straight ahead
    // is -Z, and image right is -X.
    let n = 64;
    let img = render(&material::preset("chrome").unwrap(), &opts(n));
    let top = img.get(n / 2, 4); // near the top of the ball: reflects upwards
    assert!(
        top.y > 0.8,
        "the top of the ball reflects +Y (green high): {top}"
    );
    let corner = img.get(n - 1, n / 2);
    let (_, dir) = pixel_ray(n - 1, n / 2, n, 30.0, 4.0);
    assert!(dir.x < 0.0);
    assert!((rgb(corner) - env(dir)).abs().max_element() < 1e-5);
    assert!(corner.x < 0.5, "image right looks towards -X (red low)");
}

#[test]
fn samples_are_stratified_and_one_is_the_centre() {
    assert_eq!(sample_offsets(1), vec![(0.5, 0.5)]);
    for s in [2, 3, 4, 5, 8, 16] {
        let o = sample_offsets(s);
        assert_eq!(o.len(), s);
        let mut cols: Vec<usize> = o.iter().map(|p| (p.0 * s as f32) as usize).collect();
        let mut rows: Vec<usize> = o.iter().map(|p| (p.1 * s as f32) as usize).collect();
        cols.sort();
        rows.sort();
        let all: Vec<usize> = (0..s).collect();
        assert_eq!(cols, all, "one sample per column for {s}");
        assert_eq!(rows, all, "one sample per row for {s}");
        assert_eq!(sample_offsets(s), o, "deterministic");
    }
}

#[test]
fn output_does_not_depend_on_thread_count() {
    let env = CubeSampler::new(&CubeMap::from_fn(32, synthetic::demo_sky).with_box_mips(None));
    let m = material::preset("crystal").unwrap();
    for shading in [Shading::PerFragment, Shading::PerVertex] {
        let o = Options {
            size: 48,
            samples: 4,
            shading,
            lod_bias: 0.5,
            ..Options::default()
        };
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| preview::render(&env, &m, &Surface::default(), &o).unwrap())
        };
        assert_eq!(run(1), run(3));
    }
}
