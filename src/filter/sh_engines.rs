//! The engines' own forms of order-2 spherical harmonics, computed here so that the codecs
//! (KTX 1's `sh` key, Babylon's .env manifest) only serialise numbers: Filament's irradiance
//! over pi with the basis constants folded in, and Babylon's irradiance polynomial.

use super::sh::{basis, irradiance, irradiance_over_pi, BASIS};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Filament's `sh` coefficients from order-2 radiance coefficients in cubeforge's basis
/// ([`crate::filter::sh::BASIS`], per channel): what `cmgen --sh-shader` (and `--deploy`)
/// computes, the irradiance divided by pi with each basis constant folded in, so that
/// `E(n) / pi = sh[0] + sh[1] y + sh[2] z + sh[3] x + sh[4] xy + sh[5] yz + sh[6] (3z^2 - 1) +
/// sh[7] xz + sh[8] (x^2 - y^2)`, the polynomial Filament's shader evaluates. Filament's
/// Condon-Shortley signs on the basis and on its constants cancel, so none appear here.
pub fn filament_sh(radiance: &[[f64; 3]; 9]) -> [[f64; 3]; 9] {
    let e = irradiance(radiance);
    std::array::from_fn(|i| e[i].map(|v| v * BASIS[i].3 / std::f64::consts::PI))
}

/// Babylon's irradiance polynomial: `E(n) / pi` as Babylon builds it from a cube map
/// (`CubeMapToSphericalPolynomialTools`), per channel [r, g, b], evaluated by its shader as
/// `x nx + y ny + z nz + xx nx^2 + yy ny^2 + zz nz^2 + yz ny nz + zx nz nx + xy nx ny` when it
/// uses the polynomial, or turned back into harmonics (`SphericalHarmonics.FromPolynomial`,
/// see [`SphericalPolynomial::irradiance_over_pi`]) when it uses those.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SphericalPolynomial {
    /// Coefficient of nx.
    pub x: [f64; 3],
    /// Coefficient of ny.
    pub y: [f64; 3],
    /// Coefficient of nz.
    pub z: [f64; 3],
    /// Coefficient of nx^2.
    pub xx: [f64; 3],
    /// Coefficient of ny^2.
    pub yy: [f64; 3],
    /// Coefficient of nz^2.
    pub zz: [f64; 3],
    /// Coefficient of ny nz.
    pub yz: [f64; 3],
    /// Coefficient of nz nx.
    pub zx: [f64; 3],
    /// Coefficient of nx ny.
    pub xy: [f64; 3],
}

// Babylon's constants, as its source writes them (SphericalPolynomial.updateFromHarmonics and
// SphericalHarmonics.FromPolynomial): Ramamoorthi and Hanrahan's c4, 2 c2, c5, 2 c5, c1, 2 c1,
// and their inverses (0.886277 is Babylon's own rounding of c4 = 0.886227).
const C4: f64 = 0.886277;
const C2X2: f64 = 1.02333;
const C5: f64 = 0.247708;
const C5X2: f64 = 0.495417;
const C1: f64 = 0.429043;
const C1X2: f64 = 0.858086;

impl SphericalPolynomial {
    /// The nine coefficients in the order Babylon's `.env` manifest names them (x, y, z,
    /// xx, yy, zz, yz, zx, xy): what `io::babylon_env` writes.
    pub fn coefficients(&self) -> [[f64; 3]; 9] {
        [
            self.x, self.y, self.z, self.xx, self.yy, self.zz, self.yz, self.zx, self.xy,
        ]
    }

    /// The polynomial Babylon stores for a cube map whose order-2 radiance coefficients (in
    /// cubeforge's basis, [`crate::filter::sh::BASIS`], per channel) are `radiance`: the
    /// harmonics of `E / pi` (radiance times pi, 2pi/3, pi/4 per band, over pi; Babylon's
    /// basis differs from cubeforge's only by Condon-Shortley signs, which cancel here) put
    /// through Babylon's `updateFromHarmonics`, constants and all. Non-finite values become 0.
    pub fn from_radiance_sh(radiance: &[[f64; 3]; 9]) -> SphericalPolynomial {
        // E / pi; a finite value stays finite when divided by pi, so this is the test Babylon's
        // coefficients had.
        let e = irradiance_over_pi(radiance);
        let h = |i: usize| e[i].map(|v| if v.is_finite() { v } else { 0.0 });
        let lin = |i: usize, k: f64| h(i).map(|v| k * v / PI);
        let comb = |a: f64, b: f64, c: f64| -> [f64; 3] {
            std::array::from_fn(|ch| (a * h(0)[ch] + b * h(6)[ch] + c * h(8)[ch]) / PI)
        };
        SphericalPolynomial {
            x: lin(3, C2X2),
            y: lin(1, C2X2),
            z: lin(2, C2X2),
            xx: comb(C4, -C5, C1),
            yy: comb(C4, -C5, -C1),
            zz: comb(C4, C5X2, 0.0),
            yz: lin(5, C1X2),
            zx: lin(7, C1X2),
            xy: lin(4, C1X2),
        }
    }

    /// The polynomial at unit direction `n`, as Babylon's polynomial shader path evaluates it.
    pub fn evaluate(&self, n: Vec3) -> [f64; 3] {
        let (x, y, z) = (n.x as f64, n.y as f64, n.z as f64);
        std::array::from_fn(|c| {
            self.x[c] * x
                + self.y[c] * y
                + self.z[c] * z
                + self.xx[c] * x * x
                + self.yy[c] * y * y
                + self.zz[c] * z * z
                + self.yz[c] * y * z
                + self.zx[c] * z * x
                + self.xy[c] * x * y
        })
    }

    /// `E(n) / pi` as Babylon's harmonics shader path computes it from this polynomial
    /// (`SphericalHarmonics.FromPolynomial`, `preScaleForRendering`, then the basis at `n`):
    /// the diffuse light a white Lambertian surface facing `n` reflects.
    pub fn irradiance_over_pi(&self, n: Vec3) -> [f64; 3] {
        let b = basis(n);
        std::array::from_fn(|c| {
            // Harmonics in cubeforge's (positive) basis: Babylon's signs cancel again.
            let l00 = (0.376127 * self.xx[c] + 0.376127 * self.yy[c] + 0.376126 * self.zz[c]) * PI;
            let l1 = 0.977204 * PI;
            let l2 = 1.16538 * PI;
            let l20 = (1.34567 * self.zz[c] - 0.672834 * self.xx[c] - 0.672834 * self.yy[c]) * PI;
            let l22 = 1.16538 * (self.xx[c] - self.yy[c]) * PI;
            l00 * b[0]
                + l1 * (self.y[c] * b[1] + self.z[c] * b[2] + self.x[c] * b[3])
                + l2 * (self.xy[c] * b[4] + self.yz[c] * b[5] + self.zx[c] * b[7])
                + l20 * b[6]
                + l22 * b[8]
        })
    }
}
