//! From a lobe to the numbers the sum uses: the log-weight polynomial a window evaluates, and
//! the f64 lobe the fits (and the tests, and the GGX core's share) are measured against.

use super::MAX_DEGREE;
use crate::filter::lobe::Lobe;

/// The polynomial q of [`Shape::Exp2`] for `lobe` on 0 < u <= `u_cut`, of the lowest degree
/// whose weights (its f32 coefficients, evaluated in f64) are within 2e-7 of the lobe's
/// relative to it (else the closest fit of degree up to MAX_DEGREE). Chebyshev interpolation on t = u / u_cut,
/// turned into powers of t and then of u in f64 (the coefficients fall fast: the log weights
/// are nearly linear in u).
pub(super) fn fit_log_weight(lobe: Lobe, u_cut: f64) -> [f32; MAX_DEGREE + 1] {
    let peak = weight_f64(lobe, 1.0).ln();
    let q = |t: f64| {
        let u = t * u_cut;
        (weight_f64(lobe, 1.0 - u).ln() - peak) / (u * std::f64::consts::LN_2)
    };
    let horner = |c: &[f32], t: f64| c.iter().rev().fold(0.0, |a, &k| a * t + k as f64);
    let mut best = ([0.0; MAX_DEGREE + 1], f64::INFINITY);
    for degree in 1..=MAX_DEGREE {
        let n = degree + 1;
        // Chebyshev nodes on (0, 1) and the interpolant's coefficients.
        let nodes: Vec<f64> = (0..n)
            .map(|k| 0.5 + 0.5 * (std::f64::consts::PI * (k as f64 + 0.5) / n as f64).cos())
            .collect();
        let values: Vec<f64> = nodes.iter().map(|&t| q(t)).collect();
        let cheb: Vec<f64> = (0..n)
            .map(|j| {
                let s: f64 = (0..n)
                    .map(|k| {
                        let a = std::f64::consts::PI * j as f64 * (k as f64 + 0.5) / n as f64;
                        values[k] * a.cos()
                    })
                    .sum();
                s * if j == 0 { 1.0 } else { 2.0 } / n as f64
            })
            .collect();
        // T_j(2t - 1) as powers of t, by the three-term recurrence.
        let mut power = [0.0f64; MAX_DEGREE + 1];
        let (mut prev, mut cur) = (vec![1.0], vec![-1.0, 2.0]);
        for (j, c) in cheb.iter().enumerate() {
            let t_j: &[f64] = if j == 0 { &prev } else { &cur };
            for (p, t) in power.iter_mut().zip(t_j) {
                *p += c * t;
            }
            if j >= 1 {
                let mut next = vec![0.0; cur.len() + 1];
                for (i, &v) in cur.iter().enumerate() {
                    next[i + 1] += 4.0 * v;
                    next[i] -= 2.0 * v;
                }
                for (i, &v) in prev.iter().enumerate() {
                    next[i] -= v;
                }
                prev = std::mem::replace(&mut cur, next);
            }
        }
        let mut scale = 1.0;
        let coeffs = power.map(|c| {
            let c = (c * scale) as f32;
            scale /= u_cut;
            c
        });
        let error = (0..=4096)
            .map(|i| {
                let t = (i as f64 / 4096.0).max(1e-9);
                let u = t * u_cut;
                ((u * horner(&coeffs, u) - u * q(t)) * std::f64::consts::LN_2)
                    .exp_m1()
                    .abs()
            })
            .fold(0.0, f64::max);
        if error < best.1 {
            best = (coeffs, error);
        }
        if error <= 2e-7 {
            break;
        }
    }
    best.0
}

/// The share of `lobe`'s mass (weighted by solid angle) within `reach` radians of its axis:
/// the midpoint rule on 2^16 steps either side of the reach, in f64.
pub(crate) fn share_within(lobe: Lobe, reach: f32) -> f64 {
    let mass = |a: f64, b: f64| {
        const STEPS: usize = 1 << 16;
        let dt = (b - a) / STEPS as f64;
        (0..STEPS)
            .map(|i| {
                let t = a + (i as f64 + 0.5) * dt;
                weight_f64(lobe, t.cos()) * t.sin()
            })
            .sum::<f64>()
            * dt
    };
    let r = (reach as f64).min(std::f64::consts::PI);
    let core = mass(0.0, r);
    let total = core + mass(r, std::f64::consts::PI);
    if total > 0.0 {
        core / total
    } else {
        1.0
    }
}

/// The lobe's weight at cosine `c`, in f64 for the fits and the tests.
pub(super) fn weight_f64(lobe: Lobe, c: f64) -> f64 {
    match lobe {
        Lobe::CosinePower { power } => c.max(0.0).powf(power as f64),
        Lobe::Gaussian { sigma } => {
            let a = c.clamp(-1.0, 1.0).acos();
            (-a * a / (2.0 * sigma as f64 * sigma as f64)).exp()
        }
        // In f64 from 1 - c: the core of a narrow GGX lobe lies within 1e-4 of c = 1.
        Lobe::Ggx { alpha } => {
            let a2 = alpha as f64 * alpha as f64;
            let d = a2 + 0.5 * (1.0 - c) * (1.0 - a2);
            if c > 0.0 {
                a2 / (std::f64::consts::PI * d * d) * c
            } else {
                0.0
            }
        }
        // (2 + 1/alpha) ((1 - c) / 2)^(1 / (2 alpha)) / (2 pi) c, as `shape::charlie_d`.
        Lobe::Charlie { alpha } => {
            let a = (alpha as f64).max(1e-4);
            let sin2 = ((1.0 - c) * 0.5).max(0.0);
            if c > 0.0 {
                (2.0 + 1.0 / a) * sin2.powf(0.5 / a) / std::f64::consts::TAU * c
            } else {
                0.0
            }
        }
    }
}

/// The integral over the sphere of `lobe`'s weight over its peak, out to 1 - cos = `u_cut` (2:
/// the whole sphere), per steradian: the midpoint rule on 2^16 steps of the angle, in f64.
pub(super) fn integral_over_peak(lobe: Lobe, u_cut: f64) -> f64 {
    // A cosine power's in closed form, 2 pi (1 - c0^(p+1)) / (p + 1): the 2^16 steps cost
    // each level of the cosine chain 3 ms before its sum began, 15% of the chain on 16 cores.
    if let Lobe::CosinePower { power } = lobe {
        let p = power as f64;
        let c0 = (1.0 - u_cut).clamp(0.0, 1.0);
        return std::f64::consts::TAU * (1.0 - c0.powf(p + 1.0)) / (p + 1.0);
    }
    const STEPS: usize = 1 << 16;
    let end = (1.0 - u_cut).clamp(-1.0, 1.0).acos();
    let dt = end / STEPS as f64;
    let sum: f64 = (0..STEPS)
        .map(|i| {
            let t = (i as f64 + 0.5) * dt;
            weight_f64(lobe, t.cos()) * t.sin()
        })
        .sum();
    sum * dt * std::f64::consts::TAU / weight_f64(lobe, 1.0)
}
