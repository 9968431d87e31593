//! Per-vertex shading (section 7.2.5): it converges to per-fragment as the mesh gets finer,
//! and interpolates the vertex outputs perspective-correctly.

use super::*;

/// Mean absolute difference of two renders over the pixels both show the sphere on
/// (alpha 1 with a transparent background), split into the inner disc and the rim.
fn vertex_vs_fragment(a: &Image, b: &Image) -> (f64, f64) {
    let n = a.width;
    let (mut inner, mut ni, mut rim, mut nr) = (0.0, 0, 0.0, 0);
    for y in 0..n {
        for x in 0..n {
            let (pa, pb) = (a.get(x, y), b.get(x, y));
            if pa.w < 1.0 || pb.w < 1.0 {
                continue;
            }
            let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
            let Some(p) = hit_sphere(eye, dir) else {
                continue;
            };
            let facing = -(p - eye).normalize().dot(p);
            let d = (rgb(pa) - rgb(pb)).abs().element_sum() / 3.0;
            if facing > 0.5 {
                inner += d;
                ni += 1;
            } else {
                rim += d;
                nr += 1;
            }
        }
    }
    (inner / ni as f64, rim / nr.max(1) as f64)
}

#[test]
fn per_vertex_converges_to_per_fragment() {
    let env = FnEnv(synthetic::demo_sky);
    let base = Options {
        size: 128,
        samples: 1,
        background: Background::Color(Vec4::ZERO),
        ..Options::default()
    };
    for name in ["chrome", "crystal"] {
        let m = material::preset(name).unwrap();
        let exact = preview::render(&env, &m, &Surface::default(), &base).unwrap();
        let mut last = f64::INFINITY;
        for t in [4, 8, 16, 32, 64] {
            let o = Options {
                shading: Shading::PerVertex,
                tessellation: t,
                ..base
            };
            let img = preview::render(&env, &m, &Surface::default(), &o).unwrap();
            let (inner, rim) = vertex_vs_fragment(&img, &exact);
            let err = (inner + rim) / 2.0;
            println!("{name} tessellation {t:>2}: mean error inner {inner:.5}, near the silhouette {rim:.5}");
            assert!(err < last, "error must fall as the tessellation grows");
            if t >= 8 {
                assert!(rim > inner, "the artefacts concentrate near the silhouette");
            }
            last = err;
        }
        assert!(
            last < 0.01,
            "{name}: fine tessellation nearly matches per-fragment"
        );
    }
}

#[test]
fn per_vertex_interpolates_the_vertex_outputs_perspective_correctly() {
    // A mesh vertex pixel shows exactly the vertex program's output there, and every
    // pixel's colour is the environment along a vector inside the triangle's cone of vertex
    // vectors. Simplest exact check: the vertex at the sphere's front (+Z, u = 0.5) is on
    // the mesh for an even number of longitude segments and reflects straight back.
    let m = material::preset("chrome").unwrap();
    let env = FnEnv(synthetic::smooth);
    let o = Options {
        size: 65,
        samples: 1,
        shading: Shading::PerVertex,
        tessellation: 8,
        ..Options::default()
    };
    let img = preview::render(&env, &m, &Surface::default(), &o).unwrap();
    // Pixel (32, 32) of a 65-pixel image looks exactly at the origin: hits (0, 0, 1), a mesh
    // vertex (theta = 90 degrees, phi = 0) whose reflected vector is +Z.
    let want = synthetic::smooth(Vec3::Z);
    assert!((img.get(32, 32) - want).abs().max_element() < 1e-5);
}
