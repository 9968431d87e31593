//! Tests of the fitted weights and the fast 2^x against the f64 lobe.

use super::fit::weight_f64;
use super::sum::{exp2_small, exp2_weight, ggx_weight, table_weight};
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
                Shape::Table { scale } => table_weight(&w.table, scale, u),
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

/// The whole-lobe tables (Charlie's ring, wide Gaussians) follow the f64 lobe: their weights
/// over the sphere (solid angle is 2 pi du) off it by under 1e-4 of its integral, and the
/// sum's normalisation is the lobe's integral. (Pointwise, Charlie at alpha 1 is off by 0.7%
/// of its peak in the first step, where its sqrt(u) has no slope: 1e-4 steradian.)
#[test]
fn whole_tables_follow_the_lobe() {
    for lobe in [
        Lobe::Charlie { alpha: 0.028 },
        Lobe::Charlie { alpha: 0.25 },
        Lobe::Charlie { alpha: 1.0 },
        Lobe::Gaussian { sigma: 0.3 },
        Lobe::Gaussian { sigma: 1.6 },
    ] {
        let w = Window::whole(lobe, 64, 7, 16, f64::INFINITY).expect("within budget");
        let Shape::Table { scale } = w.shape else {
            panic!("{lobe:?}: a table");
        };
        let integral = lobe.integral();
        let steps = 200_000;
        let du = w.u_cut as f64 / steps as f64;
        let off: f64 = (0..steps)
            .map(|i| {
                let u = (i as f64 + 0.5) * du;
                let got = table_weight(&w.table, scale, u as f32) as f64 * w.norm as f64;
                let want = weight_f64(lobe, 1.0 - u) / integral;
                (got - want).abs() * std::f64::consts::TAU * du
            })
            .sum();
        assert!(off < 1e-4, "{lobe:?}: {off:e}");
    }
}

/// The cosine power's closed-form integral against the midpoint rule on 2^20 steps.
#[test]
fn cosine_integral_in_closed_form() {
    for (p, u_cut) in [(2.0f32, 2.0), (11.3, 0.5), (64.0, 0.1), (2048.0, 0.01)] {
        let got = fit::integral_over_peak(Lobe::CosinePower { power: p }, u_cut);
        let steps = 1 << 20;
        let end = (1.0 - u_cut).clamp(-1.0, 1.0).acos();
        let dt = end / steps as f64;
        let want: f64 = (0..steps)
            .map(|i| {
                let t = (i as f64 + 0.5) * dt;
                t.cos().max(0.0).powf(p as f64) * t.sin()
            })
            .sum::<f64>()
            * dt
            * std::f64::consts::TAU;
        assert!(
            (got / want - 1.0).abs() < 1e-6,
            "power {p}: {got} against {want}"
        );
    }
}
