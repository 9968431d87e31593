//! BRDF lookup tables for split-sum image-based lighting: what a shader multiplies the
//! prefiltered radiance by.
//!
//! Every table is indexed the same way: column x holds n.v = (x + 0.5) / size, row y holds
//! perceptual roughness r = (y + 0.5) / size (alpha = r^2), row 0 first. Row 0 is the top of a
//! PNG and the first row in memory, so a texture uploaded as stored (no flip) is sampled at
//! `uv = (n.v, roughness)` in OpenGL, Vulkan, Direct3D and Metal alike: the layout of the
//! Khronos glTF Sample Viewer's `lut_ggx.png` and of Filament's `dfg.inc` ("GL order").
//! (cmgen's own PNG/EXR output of the DFG table is the other way up: roughness 1 at the top.)
//!
//! - [`dfg`]: the GGX specular response, height-correlated Smith visibility, Schlick Fresnel,
//!   split into two terms of F0. Karis's layout (the default, as the Khronos sampler's
//!   `lut_ggx.png`): R = scale, G = bias, `specular = F0 * R + F90 * G`. Filament's
//!   multiscatter layout ([`LutOptions::multiscatter`]): R = DFG1 = bias, G = DFG2 =
//!   scale + bias (the response with F = 1), `specular = mix(R, G, F0)`, and the energy
//!   compensation for the light lost to single scattering is `1 + F0 * (1 / G - 1)`.
//! - [`charlie`]: the sheen response of the Charlie distribution (Estevez and Kulla) with
//!   Ashikhmin's (Neubelt's) visibility, no Fresnel: `sheen = sheenColor * E`. One value,
//!   stored in R, G and B alike (the Sample Viewer reads `lut_charlie.png`'s B).
//!
//! Each texel is a quasi-Monte Carlo estimate with the Hammersley set (deterministic),
//! importance-sampling the distribution of half vectors; rows in parallel, each texel's sum in
//! a fixed order, so the bytes are the same on every run and thread count.

#![warn(missing_docs)]

use crate::filter::lobe::hammersley;
use crate::image::Image;
use glam::Vec4;
use std::f64::consts::TAU;

/// Table edge when none is asked for: what Filament and the Khronos sampler ship.
pub const DEFAULT_SIZE: usize = 128;

/// Samples per texel when none are asked for. Against a brute-force quadrature: DFG within
/// 3.2e-4, Charlie within 6.7e-4 of its value (1024, Filament's count: 1.0e-3 and 3.2e-3).
pub const DEFAULT_SAMPLES: u32 = 4096;

/// How a table is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LutOptions {
    /// [`dfg`] only: Filament's multiscatter pair (DFG1, DFG2) instead of (scale, bias).
    pub multiscatter: bool,
    /// Hammersley samples per texel.
    pub samples: u32,
}

impl Default for LutOptions {
    fn default() -> Self {
        LutOptions {
            multiscatter: false,
            samples: DEFAULT_SAMPLES,
        }
    }
}

/// (n.v, perceptual roughness) at the centre of texel (x, y) of a `size` table.
pub fn texel_coords(size: usize, x: usize, y: usize) -> (f64, f64) {
    let s = size as f64;
    ((x as f64 + 0.5) / s, (y as f64 + 0.5) / s)
}

/// The split-sum DFG table, `size` x `size`: (scale, bias) in R and G, or with
/// `opts.multiscatter` (DFG1, DFG2); B = 0, A = 1. See the module for the layout.
pub fn dfg(size: usize, opts: &LutOptions) -> Image {
    table(size, opts.samples, ggx_half_vectors, |nv, hs| {
        let (scale, bias) = dfg_sum(nv, hs.alpha, hs);
        if opts.multiscatter {
            Vec4::new(bias as f32, (scale + bias) as f32, 0.0, 1.0)
        } else {
            Vec4::new(scale as f32, bias as f32, 0.0, 1.0)
        }
    })
}

/// The Charlie sheen table, `size` x `size`: the directional albedo E(n.v, roughness) in R, G
/// and B; A = 1. See the module for the layout.
pub fn charlie(size: usize, opts: &LutOptions) -> Image {
    table(size, opts.samples, charlie_half_vectors, |nv, hs| {
        let e = charlie_sum(nv, hs) as f32;
        Vec4::new(e, e, e, 1.0)
    })
}

/// The DFG terms at one point: (scale, bias) with `samples` Hammersley samples.
pub fn dfg_at(n_dot_v: f64, roughness: f64, samples: u32) -> (f64, f64) {
    let mut hs = HalfVectors::default();
    ggx_half_vectors(roughness, reset(&mut hs, samples));
    dfg_sum(n_dot_v, hs.alpha, &hs)
}

/// Importance-sampled half vectors of one roughness (one table row): the sampling depends on
/// roughness only, so each row computes them once and every n.v reuses them.
#[derive(Default)]
struct HalfVectors {
    /// alpha = roughness^2.
    alpha: f64,
    /// (cos phi, sin phi) of each sample: the same for every row.
    phis: Vec<(f64, f64)>,
    /// The CDF value u that places each sample's angle to the normal, and the sample's weight
    /// (see [`reset`]).
    us: Vec<(f64, f64)>,
    /// Unit half vectors, +Z the normal, and their weights.
    h: Vec<([f64; 3], f64)>,
}

/// The Hammersley set of `samples` points, with the first coordinate t mapped to u = 1 - t^2
/// (weight 2t). Both estimators carry a factor v.h / n.h, which grows as 1 / sqrt(1 - u)
/// towards the horizon of h: at grazing n.v that tail holds much of the integral and plain
/// u = t sampled it in too few, large, uneven samples (2% off at n.v = 0.004). In t the
/// integrand is bounded: the tables converge at every texel.
fn reset(hs: &mut HalfVectors, samples: u32) -> &mut HalfVectors {
    let n = samples.max(1);
    hs.phis.clear();
    hs.us.clear();
    for i in 0..n {
        let (t, v) = hammersley(i, n);
        let (t, phi) = (t as f64, TAU * v as f64);
        hs.phis.push((phi.cos(), phi.sin()));
        hs.us.push((1.0 - t * t, 2.0 * t));
    }
    hs
}

/// Fills `hs.h` from `hs.us` given cos(theta) of each.
fn set_half_vectors(hs: &mut HalfVectors, cos_theta: impl Fn(f64) -> f64) {
    hs.h.clear();
    for (&(u, w), &(c, s)) in hs.us.iter().zip(&hs.phis) {
        let ct = cos_theta(u).clamp(0.0, 1.0);
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        hs.h.push(([st * c, st * s, ct], w));
    }
}

/// GGX (Trowbridge-Reitz) half vectors: pdf(h) = D(h) n.h.
fn ggx_half_vectors(roughness: f64, hs: &mut HalfVectors) {
    let a = roughness * roughness;
    hs.alpha = a;
    // (a^2 - 1) as (a - 1)(a + 1): exact near a = 1.
    set_half_vectors(hs, |u| {
        ((1.0 - u) / (1.0 + (a - 1.0) * (a + 1.0) * u)).sqrt()
    });
}

/// Charlie half vectors: pdf(h) = D(h) n.h, whose CDF in theta is sin(theta)^(1/alpha + 2).
fn charlie_half_vectors(roughness: f64, hs: &mut HalfVectors) {
    // Alpha 0 is a distribution on the horizon: keep it a (very narrow) lobe.
    let a = (roughness * roughness).max(1e-7);
    hs.alpha = a;
    set_half_vectors(hs, |u| {
        let sin_t = u.powf(a / (2.0 * a + 1.0));
        (1.0 - sin_t * sin_t).max(0.0).sqrt()
    });
}

/// Height-correlated Smith visibility G2 / (4 n.l n.v) for GGX (Heitz 2014).
#[inline]
fn v_smith_ggx_correlated(nv: f64, nl: f64, a: f64) -> f64 {
    let a2 = a * a;
    let gv = nl * (nv * nv * (1.0 - a2) + a2).sqrt();
    let gl = nv * (nl * nl * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl)
}

/// Ashikhmin's visibility in Neubelt and Pettineo's form, for sheen.
#[inline]
fn v_ashikhmin(nv: f64, nl: f64) -> f64 {
    1.0 / (4.0 * (nl + nv - nl * nv))
}

/// The view vector at n.v, in the x-z plane.
#[inline]
fn view(nv: f64) -> [f64; 3] {
    [(1.0 - nv * nv).max(0.0).sqrt(), 0.0, nv]
}

/// Sums f(l) n.l / pdf(l) over the half vectors, pdf(l) = D(h) n.h / (4 v.h), and returns
/// the (1 - Fc) and Fc weighted means: (scale, bias).
fn dfg_sum(nv: f64, alpha: f64, hs: &HalfVectors) -> (f64, f64) {
    let v = view(nv);
    let (mut scale, mut bias) = (0.0f64, 0.0f64);
    for (h, w) in &hs.h {
        let vh = v[0] * h[0] + v[2] * h[2];
        let nl = 2.0 * vh * h[2] - v[2];
        if nl <= 0.0 || vh <= 0.0 {
            continue;
        }
        // D cancels: D V F n.l / (D n.h / (4 v.h)).
        let g = w * 4.0 * v_smith_ggx_correlated(nv, nl, alpha) * nl * vh / h[2];
        let fc = (1.0 - vh).powi(5);
        scale += (1.0 - fc) * g;
        bias += fc * g;
    }
    let n = hs.h.len().max(1) as f64;
    (scale / n, bias / n)
}

/// The Charlie albedo estimate: V n.l 4 v.h / n.h per sample (D cancels as in [`dfg_sum`]).
fn charlie_sum(nv: f64, hs: &HalfVectors) -> f64 {
    let v = view(nv);
    let mut sum = 0.0f64;
    for (h, w) in &hs.h {
        let vh = v[0] * h[0] + v[2] * h[2];
        let nl = 2.0 * vh * h[2] - v[2];
        if nl <= 0.0 || vh <= 0.0 || h[2] <= 0.0 {
            continue;
        }
        sum += w * 4.0 * v_ashikhmin(nv, nl) * nl * vh / h[2];
    }
    sum / hs.h.len().max(1) as f64
}

/// A `size` x `size` table: each row gets its roughness's half vectors, each texel `texel`.
fn table(
    size: usize,
    samples: u32,
    half_vectors: impl Fn(f64, &mut HalfVectors) + Sync,
    texel: impl Fn(f64, &HalfVectors) -> Vec4 + Sync,
) -> Image {
    let mut base = HalfVectors::default();
    reset(&mut base, samples);
    Image::from_rows(size, size, |y, row| {
        let (_, r) = texel_coords(size, 0, y);
        let mut hs = HalfVectors {
            alpha: 0.0,
            phis: base.phis.clone(),
            us: base.us.clone(),
            h: Vec::with_capacity(base.us.len()),
        };
        half_vectors(r, &mut hs);
        for (x, out) in row.iter_mut().enumerate() {
            let (nv, _) = texel_coords(size, x, y);
            *out = texel(nv, &hs);
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mirror reflects F(n.v) whole: scale + bias -> 1 - 0 and bias -> (1 - n.v)^5.
    #[test]
    fn smooth_limit_is_schlick_fresnel() {
        for nv in [0.1, 0.5, 0.9] {
            let (s, b) = dfg_at(nv, 0.01, 256);
            let fc = (1.0f64 - nv).powi(5);
            assert!((s - (1.0 - fc)).abs() < 2e-3, "{nv}: scale {s}");
            assert!((b - fc).abs() < 2e-3, "{nv}: bias {b}");
        }
    }

    #[test]
    fn same_bytes_whatever_the_thread_count() {
        let opts = LutOptions {
            samples: 64,
            ..LutOptions::default()
        };
        let a = dfg(16, &opts);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| dfg(16, &opts));
        assert_eq!(a, b);
    }
}
