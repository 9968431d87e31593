//! Brennan's correction: both parallax modes against his formulas, and how they differ.

use super::*;
use cubeforge::internals::preview::{Parallax, ParallaxMode};

#[test]
fn parallax_modes_match_brennan_and_differ_as_expected() {
    let m = material::preset("chrome").unwrap();
    let n = 64;
    let center = Vec3::new(0.4, -0.2, 0.3);
    let radius = 3.0;
    let mut renders = Vec::new();
    for mode in [ParallaxMode::Approx, ParallaxMode::Exact] {
        let o = Options {
            parallax: Some(Parallax {
                radius,
                center,
                mode,
            }),
            ..opts(n)
        };
        let img = render(&m, &o);
        let c = center.as_dvec3();
        let r = radius as f64;
        let mut worst = 0.0f64;
        for y in 0..n {
            for x in 0..n {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let Some(p) = hit_sphere(eye, dir) else {
                    continue;
                };
                let v = reflect(p - eye, p).normalize();
                let look = match mode {
                    // Seed 002: R'' = R + CP / Radius, R of unit length.
                    ParallaxMode::Approx => v + (p - c) / r,
                    // The ray P + tV meets the sphere |X - C| = Radius at t > 0: look up X - C.
                    ParallaxMode::Exact => {
                        let cp = p - c;
                        let b = cp.dot(v);
                        let t = -b + (b * b - cp.dot(cp) + r * r).sqrt();
                        cp + v * t
                    }
                };
                let got = rgb(img.get(x, y));
                worst = worst.max((got - env(look)).abs().max_element());
            }
        }
        println!("{mode:?}: max error {worst:.2e}");
        assert!(worst < 5e-5, "{mode:?}: max error {worst}");
        renders.push(img);
    }
    let infinite = render(&m, &opts(n));
    let diff = |a: &Image, b: &Image| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (*p - *q).abs().max_element())
            .fold(0.0f32, f32::max)
    };
    let (approx_exact, approx_inf, exact_inf) = (
        diff(&renders[0], &renders[1]),
        diff(&renders[0], &infinite),
        diff(&renders[1], &infinite),
    );
    println!("max differences: approx-exact {approx_exact:.4}, approx-infinite {approx_inf:.4}, exact-infinite {exact_inf:.4}");
    // Both corrections move the lookups a lot more than they differ from each other.
    assert!(approx_inf > 0.05 && exact_inf > 0.05);
    assert!(approx_exact > 1e-3 && approx_exact < approx_inf.min(exact_inf));
    // Far away the environment is at infinity again: both converge to the plain lookup.
    let mut prev = (f32::INFINITY, f32::INFINITY);
    for radius in [4.0, 40.0, 400.0] {
        let d: Vec<f32> = [ParallaxMode::Approx, ParallaxMode::Exact]
            .iter()
            .map(|&mode| {
                let o = Options {
                    parallax: Some(Parallax {
                        radius,
                        center,
                        mode,
                    }),
                    ..opts(n)
                };
                diff(&render(&m, &o), &infinite)
            })
            .collect();
        assert!(d[0] < prev.0 && d[1] < prev.1);
        prev = (d[0], d[1]);
    }
    assert!(prev.0 < 0.01 && prev.1 < 0.01);
}
