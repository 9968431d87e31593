//! Tests of the fitted weights and the fast 2^x against the f64 lobe.

use super::fit::weight_f64;
use super::sum::{exp2_small, exp2_weight, ggx_weight};
use super::*;

/// Every lobe a window sums (cosine powers from the widest allowed up, Gaussians, GGX
/// cores), its f32 weights against the f64 lobe over the reach: within 1e-6 relative.
#[test]
fn weights_follow_the_lobe() {
    let mut lobes: Vec<(Lobe, f64)> = Vec::new();
    for p in [
        53.0f32, 64.0, 100.0, 152.0, 362.0, 861.0, 2048.0, 8192.0, 1e5, 1e6,
    ] {
        let l = Lobe::CosinePower { power: p };
        lobes.push((l, EPS.powf(1.0 / p as f64).acos()));
    }
    for s in [0.0005f32, 0.001, 0.01, 0.05, 0.1, 0.13] {
        let reach = s as f64 * (2.0 * (1.0 / EPS).ln()).sqrt();
        lobes.push((Lobe::Gaussian { sigma: s }, reach));
    }
    for a in [0.002f32, 0.01, 0.05, 0.06] {
        lobes.push((Lobe::Ggx { alpha: a }, 4.0 * a as f64));
    }
    for (lobe, reach) in lobes {
        assert!(reach < MAX_REACH as f64, "{lobe:?}");
        let w = Window::build(lobe, 0.01, reach, 256, 9, 1.0);
        let peak = weight_f64(lobe, 1.0);
        let mut worst = 0.0f64;
        for i in 0..=10_000 {
            let u = w.u_cut * i as f32 / 10_000.0;
            let got = match w.shape {
                Shape::Exp2 { q } => exp2_weight(&q, u),
                Shape::Ggx { a2, h } => ggx_weight(a2, h, u),
            } as f64;
            let want = weight_f64(lobe, 1.0 - u as f64) / peak;
            worst = worst.max((got / want - 1.0).abs());
        }
        assert!(worst < 1e-6, "{lobe:?}: relative error {worst:e}");
    }
}

/// 2^x against f64 over the log weights' range, integers and halves included.
#[test]
fn exp2_small_is_close() {
    let mut worst = 0.0f64;
    for i in 0..=200_000 {
        let x = -12.0 * i as f32 / 200_000.0;
        let got = exp2_small(x) as f64;
        worst = worst.max((got / (x as f64).exp2() - 1.0).abs());
    }
    assert!(worst < 3e-7, "relative error {worst:e}");
}
