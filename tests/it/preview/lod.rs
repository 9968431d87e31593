//! Level of detail: the level a pixel reads follows the reflected footprint, plus the bias.

use super::*;

/// The GPU's level for a chrome pixel from the reflected vectors at it and at the pixels to
/// its right and below (true neighbours, not extrapolated): projected on R's face, in
/// texels of a face of edge `size`.
fn expected_lod(x: usize, y: usize, n: usize, size: usize) -> Option<f64> {
    let r = |x: usize, y: usize| {
        let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
        hit_sphere(eye, dir).map(|p| (reflect(p - eye, p), -(p - eye).normalize().dot(p)))
    };
    let (v, facing) = r(x, y)?;
    let (vx, _) = r(x + 1, y)?;
    let (vy, _) = r(x, y + 1)?;
    if facing < 0.5 {
        return None;
    }
    let a = v.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let proj = |q: DVec3| {
        let m = q[axis] * v[axis].signum();
        let o: Vec<f64> = (0..3).filter(|&k| k != axis).map(|k| q[k] / m).collect();
        glam::DVec2::new(o[0], o[1])
    };
    let p = proj(v);
    let rho = (proj(vx) - p).length().max((proj(vy) - p).length()) * size as f64 / 2.0;
    Some(rho.log2())
}

#[test]
fn lod_follows_the_reflected_footprint_plus_bias() {
    let size = 64;
    let chain = level_chain(size);
    let max = (CubeMap::full_chain_len(size) - 1) as f64;
    let m = material::preset("chrome").unwrap();
    let n = 64;
    let mut checked = 0;
    let mut worst = 0.0f64;
    for bias in [0.0, 1.0, 2.5] {
        let o = Options {
            lod_bias: bias,
            ..opts(n)
        };
        let img = preview::render(&chain, &m, &Surface::default(), &o).unwrap();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let Some(lod) = expected_lod(x, y, n, size) else {
                    continue;
                };
                let want = (lod + bias as f64).clamp(0.0, max);
                let got = img.get(x, y).x as f64;
                worst = worst.max((got - want).abs());
                checked += 1;
            }
        }
    }
    println!("level of detail: max error {worst:.3} levels over {checked} pixels");
    assert!(checked > 3000);
    assert!(worst < 0.1, "max error {worst} levels");
}

#[test]
fn lod_bias_selects_blurrier_levels() {
    // A checkerboard environment with plain box mipmaps: each unit of bias halves the detail.
    let checker = |d: Vec3| {
        let a = d.normalize();
        let u = (a.x.atan2(a.z) * 8.0).sin() * (a.y.asin() * 8.0).sin();
        let v = if u > 0.0 { 1.0 } else { 0.0 };
        Vec4::new(v, v, v, 1.0)
    };
    let chain = CubeSampler::new(&CubeMap::from_fn(128, checker).with_box_mips(None));
    let single = CubeSampler::new(&CubeMap::from_fn(128, checker));
    let m = material::preset("chrome").unwrap();
    let n = 64;
    let contrast = |img: &Image| {
        // Mean absolute difference between horizontal neighbours on the sphere.
        let mut s = 0.0;
        let mut c = 0;
        for y in 0..n {
            for x in 0..n - 1 {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let (_, dir2) = pixel_ray(x + 1, y, n, 30.0, 4.0);
                if hit_sphere(eye, dir).is_some() && hit_sphere(eye, dir2).is_some() {
                    s += (img.get(x, y).x - img.get(x + 1, y).x).abs() as f64;
                    c += 1;
                }
            }
        }
        s / c as f64
    };
    let mut prev = f64::INFINITY;
    for bias in [0.0, 1.0, 2.0, 3.0, 4.0] {
        let o = Options {
            lod_bias: bias,
            ..opts(n)
        };
        let img = preview::render(&chain, &m, &Surface::default(), &o).unwrap();
        let c = contrast(&img);
        println!("bias {bias}: neighbour contrast {c:.4}");
        assert!(c < prev * 0.9, "bias {bias} must blur more");
        prev = c;
        // A single level has nothing to blur with: the bias changes nothing.
        let flat = preview::render(&single, &m, &Surface::default(), &o).unwrap();
        let flat0 = preview::render(&single, &m, &Surface::default(), &opts(n)).unwrap();
        assert_eq!(flat, flat0);
    }
}
