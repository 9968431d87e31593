//! The lobes the filters convolve with: each one's weight as a function of the cosine to its
//! axis, its integral over the sphere and how far it reaches. Below both the sampled filter
//! (`lobe`) and the exact sum of the bright texels (`bright`), which share it.

#![warn(missing_docs)]

use std::f32::consts::{PI, TAU};

/// A lobe around the direction being filtered, as a function of the angle to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lobe {
    /// GGX (Trowbridge-Reitz) with alpha = roughness^2, weighted by n.l, n = v = r: the
    /// split-sum radiance prefilter.
    Ggx {
        /// Width: roughness^2, 0 a mirror, 1 the widest.
        alpha: f32,
    },
    /// Charlie sheen (Estevez and Kulla) with alpha = roughness^2, weighted by n.l, n = v = r:
    /// the Khronos glTF-IBL-Sampler's sheen prefilter. Unlike GGX it vanishes at the axis and
    /// peaks towards the horizon (at n.l = 2 alpha / (2 alpha + 1)): a ring, not a spot.
    Charlie {
        /// Width: roughness^2.
        alpha: f32,
    },
    /// cos^power of the angle (Phong lobe around the reflection vector).
    CosinePower {
        /// Exponent: higher is narrower.
        power: f32,
    },
    /// exp(-angle^2 / (2 sigma^2)).
    Gaussian {
        /// Standard deviation, radians.
        sigma: f32,
    },
}

impl Lobe {
    /// Weight of a direction at cosine `c` from the lobe's axis (not normalised), as the
    /// brute-force reference integrates it.
    pub(crate) fn weight(&self, c: f32) -> f32 {
        match *self {
            Lobe::Ggx { alpha } => {
                if c <= 0.0 {
                    return 0.0;
                }
                // Half vector between n and l: n.h = cos(theta / 2).
                let nh = ((1.0 + c) * 0.5).sqrt();
                ggx_d(nh, alpha) * c
            }
            Lobe::Charlie { alpha } => {
                if c <= 0.0 {
                    return 0.0;
                }
                charlie_d(((1.0 + c) * 0.5).sqrt(), alpha) * c
            }
            Lobe::CosinePower { power } => {
                if c <= 0.0 {
                    0.0
                } else {
                    c.powf(power)
                }
            }
            Lobe::Gaussian { sigma } => {
                let a = c.clamp(-1.0, 1.0).acos();
                (-a * a / (2.0 * sigma * sigma)).exp()
            }
        }
    }
}

impl Lobe {
    /// The lobe's integral over the sphere, 2 pi * int w(cos t) sin t dt, by the midpoint rule
    /// on 16384 steps (fine enough for the narrowest lobes of a 4096-face chain).
    pub fn integral(&self) -> f64 {
        let steps = 16384;
        let dt = std::f64::consts::PI / steps as f64;
        let mut sum = 0.0f64;
        for i in 0..steps {
            let t = (i as f64 + 0.5) * dt;
            sum += self.weight(t.cos() as f32) as f64 * t.sin();
        }
        sum * dt * std::f64::consts::TAU
    }
}

impl Lobe {
    /// The angle (radians) over which the weight changes by about e: an output texel's patch
    /// is sampled finer than half of it (see `filter::fine_size_for`). GGX: its core's; Charlie:
    /// its ring's depth towards the horizon, where it peaks.
    pub(crate) fn width(&self) -> f32 {
        match *self {
            Lobe::Ggx { alpha } => 1.3 * alpha,
            Lobe::Charlie { alpha } => 2.0 * alpha / (2.0 * alpha + 1.0),
            Lobe::CosinePower { power } => (1.0 / power.max(1e-6)).sqrt(),
            Lobe::Gaussian { sigma } => sigma,
        }
    }
}

/// GGX normal distribution D(h) for cos(n, h) = `nh`.
#[inline]
pub(crate) fn ggx_d(nh: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = nh * nh * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Charlie sheen distribution D(h) for cos(n, h) = `nh`: (2 + 1/alpha) sin(theta)^(1/alpha)
/// / (2 pi), normalised so that the integral of D(h) (n.h) over the hemisphere is 1.
#[inline]
pub(crate) fn charlie_d(nh: f32, alpha: f32) -> f32 {
    let inv = 1.0 / alpha.max(1e-4);
    let sin2 = (1.0 - nh * nh).max(0.0);
    (2.0 + inv) * sin2.powf(inv * 0.5) / TAU
}

impl Lobe {
    /// The cosine below which the lobe's weight stays under 1e-10 of its peak: bright texels
    /// further out are skipped (a 10^5 sun then moves an output by under 1e-3). Found from
    /// below, so it holds for lobes that peak off the axis too (Charlie's ring).
    pub(crate) fn cutoff_cos(&self) -> f32 {
        const STEPS: usize = 4096;
        let at = |i: usize| -1.0 + 2.0 * i as f32 / STEPS as f32;
        let peak = (0..=STEPS)
            .map(|i| self.weight(at(i)))
            .fold(0.0f32, f32::max);
        let floor = peak * 1e-10;
        // The first grid point at or above the floor, then bisect the step before it.
        let Some(first) = (0..=STEPS).find(|&i| self.weight(at(i)) >= floor) else {
            return -1.0;
        };
        if first == 0 {
            return -1.0;
        }
        let (mut lo, mut hi) = (at(first - 1), at(first));
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if self.weight(mid) >= floor {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        lo
    }
}
