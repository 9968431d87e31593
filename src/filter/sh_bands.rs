//! Real spherical harmonics of 1 to 5 bands (1 to 25 coefficients per channel), as cmgen
//! (`--sh=bands`) and cmft (five bands) write them, and cmgen's windowing (`--sh-window`): a
//! sinc^4 taper over the bands that trades a little sharpness for less ringing, chosen by hand
//! or, with `auto`, as the mildest taper under which the irradiance is nowhere negative.
//! Higher bands add nothing to the irradiance at band 3 (its cosine factor is 0) and little
//! at band 4 (-pi/24): they matter to the radiance the coefficients describe, and to shaders
//! that convolve them with other lobes.
//!
//! The basis is [`super::sh::BASIS`] continued: the same order (band by band, m from -l to l)
//! and the same sign convention (no Condon-Shortley phase), so the first 9 coefficients of a
//! 3-band set are the order-2 ones every engine target uses.

#![warn(missing_docs)]

use crate::cube::{solid_angle_table, texel_dir, Faces};
use crate::error::{Error, Result};
use glam::{Vec3, Vec4};
use serde::Serialize;
use std::f64::consts::PI;

/// Bands a set may hold: cmft's five (up to l = 4).
pub const MAX_BANDS: usize = 5;

/// Texels per face edge of the grid `--sh-window auto` tests the irradiance on (with the
/// margin that makes it hold between the points).
const GRID: usize = 128;

/// Coefficients of [`MAX_BANDS`] bands.
const MAX_COEFFS: usize = MAX_BANDS * MAX_BANDS;

/// Each basis function beyond band 2 as (formula, l, m, constant): Y = constant * polynomial
/// in the unit direction's x, y, z (Sloan, "Stupid Spherical Harmonics Tricks", appendix,
/// without the Condon-Shortley sign, as the first three bands).
const HIGHER: [(&str, i32, i32, f64); 16] = [
    (
        "0.25 * sqrt(35/(2pi)) * y * (3x^2 - y^2)",
        3,
        -3,
        0.590_043_589_926_643_5,
    ),
    (
        "0.5 * sqrt(105/pi) * x * y * z",
        3,
        -2,
        2.890_611_442_640_554,
    ),
    (
        "0.25 * sqrt(21/(2pi)) * y * (5z^2 - 1)",
        3,
        -1,
        0.457_045_799_464_465_8,
    ),
    (
        "0.25 * sqrt(7/pi) * z * (5z^2 - 3)",
        3,
        0,
        0.373_176_332_590_115_4,
    ),
    (
        "0.25 * sqrt(21/(2pi)) * x * (5z^2 - 1)",
        3,
        1,
        0.457_045_799_464_465_8,
    ),
    (
        "0.25 * sqrt(105/pi) * z * (x^2 - y^2)",
        3,
        2,
        1.445_305_721_320_277,
    ),
    (
        "0.25 * sqrt(35/(2pi)) * x * (x^2 - 3y^2)",
        3,
        3,
        0.590_043_589_926_643_5,
    ),
    (
        "0.75 * sqrt(35/pi) * x * y * (x^2 - y^2)",
        4,
        -4,
        2.503_342_941_796_704_6,
    ),
    (
        "0.75 * sqrt(35/(2pi)) * y * z * (3x^2 - y^2)",
        4,
        -3,
        1.770_130_769_779_930_4,
    ),
    (
        "0.75 * sqrt(5/pi) * x * y * (7z^2 - 1)",
        4,
        -2,
        0.946_174_695_757_560_1,
    ),
    (
        "0.75 * sqrt(5/(2pi)) * y * z * (7z^2 - 3)",
        4,
        -1,
        0.669_046_543_557_289_2,
    ),
    (
        "(3/16) * sqrt(1/pi) * (35z^4 - 30z^2 + 3)",
        4,
        0,
        0.105_785_546_915_204_31,
    ),
    (
        "0.75 * sqrt(5/(2pi)) * x * z * (7z^2 - 3)",
        4,
        1,
        0.669_046_543_557_289_2,
    ),
    (
        "(3/8) * sqrt(5/pi) * (x^2 - y^2) * (7z^2 - 1)",
        4,
        2,
        0.473_087_347_878_780_04,
    ),
    (
        "0.75 * sqrt(35/(2pi)) * x * z * (x^2 - 3y^2)",
        4,
        3,
        1.770_130_769_779_930_4,
    ),
    (
        "(3/16) * sqrt(35/pi) * (x^2 (x^2 - 3y^2) - y^2 (3x^2 - y^2))",
        4,
        4,
        0.625_835_735_449_176_1,
    ),
];

/// (formula, l, m, constant) of coefficient `i` (0 to 24).
pub fn describe(i: usize) -> (&'static str, i32, i32, f64) {
    if i < 9 {
        super::sh::BASIS[i]
    } else {
        HIGHER[i - 9]
    }
}

/// The first `bands * bands` basis functions at unit direction `d`, into `out`.
pub fn basis_into(d: Vec3, bands: usize, out: &mut [f64; MAX_COEFFS]) {
    let low = super::sh::basis(d);
    out[..9].copy_from_slice(&low);
    if bands <= 3 {
        return;
    }
    let (x, y, z) = (d.x as f64, d.y as f64, d.z as f64);
    let (x2, y2, z2) = (x * x, y * y, z * z);
    let polys3 = [
        y * (3.0 * x2 - y2),
        x * y * z,
        y * (5.0 * z2 - 1.0),
        z * (5.0 * z2 - 3.0),
        x * (5.0 * z2 - 1.0),
        z * (x2 - y2),
        x * (x2 - 3.0 * y2),
    ];
    for (k, p) in polys3.iter().enumerate() {
        out[9 + k] = HIGHER[k].3 * p;
    }
    if bands <= 4 {
        return;
    }
    let polys4 = [
        x * y * (x2 - y2),
        y * z * (3.0 * x2 - y2),
        x * y * (7.0 * z2 - 1.0),
        y * z * (7.0 * z2 - 3.0),
        35.0 * z2 * z2 - 30.0 * z2 + 3.0,
        x * z * (7.0 * z2 - 3.0),
        (x2 - y2) * (7.0 * z2 - 1.0),
        x * z * (x2 - 3.0 * y2),
        x2 * (x2 - 3.0 * y2) - y2 * (3.0 * x2 - y2),
    ];
    for (k, p) in polys4.iter().enumerate() {
        out[16 + k] = HIGHER[7 + k].3 * p;
    }
}

/// The clamped cosine's convolution factor for band `l` (Ramamoorthi and Hanrahan 2001):
/// pi, 2pi/3, pi/4, 0, -pi/24; zero for every odd band above 1.
pub fn cosine_band(l: usize) -> f64 {
    match l {
        0 => PI,
        1 => 2.0 * PI / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // 2 pi (-1)^(l/2 + 1) / ((l + 2)(l - 1)) * l! / (2^l (l/2)!^2)
            let h = l / 2;
            let sign = if h % 2 == 1 { 1.0 } else { -1.0 };
            let fact = |n: usize| (1..=n).map(|k| k as f64).product::<f64>();
            let binom = fact(l) / (fact(h) * fact(h) * (1u64 << l) as f64);
            2.0 * PI * sign / (((l + 2) * (l - 1)) as f64) * binom
        }
    }
}

/// How a set's bands are tapered: cmgen's `--sh-window`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum ShWindow {
    /// The exact projection (cubeforge's default; cmgen's `--sh-window=no`).
    #[default]
    None,
    /// The largest cutoff under which the irradiance is nowhere negative (cmgen's default).
    Auto,
    /// A sinc^4 taper reaching zero at this band (cmgen's `--sh-window=CUTOFF`).
    Cutoff(f64),
}

impl std::str::FromStr for ShWindow {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<ShWindow, String> {
        match s {
            "no" | "none" => Ok(ShWindow::None),
            "auto" => Ok(ShWindow::Auto),
            _ => match s.parse::<f64>() {
                Ok(c) if c.is_finite() && c > 0.0 => Ok(ShWindow::Cutoff(c)),
                _ => Err(format!(
                    "{s:?}: use no, auto, or a cutoff band greater than 0 (e.g. 6)"
                )),
            },
        }
    }
}

/// cmgen's window weight of band `l` for a cutoff: 1 at band 0, (sin x / x)^4 with
/// x = pi l / cutoff below the cutoff, 0 from it on.
pub fn window_weight(l: usize, cutoff: f64) -> f64 {
    if l == 0 {
        1.0
    } else if l as f64 >= cutoff {
        0.0
    } else {
        let x = PI * l as f64 / cutoff;
        (x.sin() / x).powi(4)
    }
}

/// Radiance coefficients of `bands` bands, tapered by a window or not.
#[derive(Clone, Debug, PartialEq)]
pub struct ShSet {
    /// Bands, 1 to [`MAX_BANDS`].
    pub bands: usize,
    /// `bands * bands` coefficients of the radiance per channel, the window applied.
    pub radiance: Vec<[f64; 3]>,
    /// The cutoff applied (None: the exact projection).
    pub cutoff: Option<f64>,
}

impl ShSet {
    /// Projects six faces onto `bands` bands with exact texel solid angles: rows in parallel,
    /// each row's sums in f64, the rows' added in order (the same on every thread count).
    pub fn project(faces: &Faces, bands: usize) -> Result<ShSet> {
        use rayon::prelude::*;
        if !(1..=MAX_BANDS).contains(&bands) {
            return Err(Error::usage(format!(
                "{} {bands}: use 1 to {MAX_BANDS}",
                crate::error::param("sh_bands")
            )));
        }
        let count = bands * bands;
        let n = faces[0].width;
        let inv = 1.0 / n as f32;
        let angles = solid_angle_table(n);
        let rows: Vec<[[f64; 3]; MAX_COEFFS]> = (0..6 * n)
            .into_par_iter()
            .map(|fy| {
                let (face, y) = (fy / n, fy % n);
                let mut c = [[0.0f64; 3]; MAX_COEFFS];
                let mut ys = [0.0f64; MAX_COEFFS];
                for x in 0..n {
                    basis_into(texel_dir(face, x, y, inv), bands, &mut ys);
                    let v = faces[face].get(x, y);
                    let sa = angles[y * n + x] as f64;
                    for (ci, yi) in c.iter_mut().zip(&ys).take(count) {
                        let w = yi * sa;
                        ci[0] += v.x as f64 * w;
                        ci[1] += v.y as f64 * w;
                        ci[2] += v.z as f64 * w;
                    }
                }
                c
            })
            .collect();
        let mut radiance = vec![[0.0f64; 3]; count];
        for r in &rows {
            for (ci, ri) in radiance.iter_mut().zip(r) {
                for (a, b) in ci.iter_mut().zip(ri) {
                    *a += b;
                }
            }
        }
        Ok(ShSet {
            bands,
            radiance,
            cutoff: None,
        })
    }

    /// The set with `window` applied; `Auto` searches the cutoff as cmgen does (bisection
    /// up to `4 bands + 1`, per channel, the smallest kept; from band 1 rather than `bands`),
    /// but proves the irradiance non-negative over the whole sphere from a 6 x 128 x 128 grid
    /// and a bound between its points (see `nonnegative`) instead of Sloan's closed-form
    /// minimum, so it works for every band count, and leaves a set alone whose irradiance is
    /// already provably nowhere negative.
    pub fn windowed(&self, window: ShWindow) -> ShSet {
        let cutoff = match window {
            ShWindow::None => return self.clone(),
            ShWindow::Cutoff(c) => c,
            ShWindow::Auto => match self.auto_cutoff() {
                Some(c) => c,
                None => return self.clone(),
            },
        };
        let mut out = self.with_cutoff(cutoff);
        out.cutoff = Some(cutoff);
        out
    }

    fn with_cutoff(&self, cutoff: f64) -> ShSet {
        let radiance = self
            .radiance
            .iter()
            .enumerate()
            .map(|(i, c)| c.map(|v| v * window_weight(band(i), cutoff)))
            .collect();
        ShSet {
            bands: self.bands,
            radiance,
            cutoff: self.cutoff,
        }
    }

    /// None when the exact set's irradiance is already nowhere negative.
    fn auto_cutoff(&self) -> Option<f64> {
        let grid: Vec<Vec3> = (0..6 * GRID * GRID)
            .map(|i| {
                let (face, y, x) = (i / (GRID * GRID), (i / GRID) % GRID, i % GRID);
                texel_dir(face, x, y, 1.0 / GRID as f32)
            })
            .collect();
        if (0..3).all(|c| self.nonnegative(&grid, c)) {
            return None;
        }
        let mut cutoff = (4 * self.bands + 1) as f64;
        for channel in 0..3 {
            // Band 1 leaves the mean alone, never negative: the search starts there (cmgen's
            // starts at `bands`, still negative next to a strong sun at 5 bands).
            let (mut lo, mut hi) = (1.0, cutoff);
            if self.with_cutoff(hi).nonnegative(&grid, channel) {
                continue;
            }
            for _ in 0..16 {
                if lo + 0.1 >= hi {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                if self.with_cutoff(mid).nonnegative(&grid, channel) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            cutoff = cutoff.min(lo);
        }
        Some(cutoff)
    }

    /// Whether one channel's irradiance is non-negative over the whole sphere, not only on
    /// `grid` (issue 45: a 6 x 32 x 32 grid left park's blue at 5 bands negative in 66 of
    /// 393,216 directions). E is a polynomial of degree L (its highest band with weight) on
    /// the sphere; on the great circle from its minimum to the nearest grid point, d radians
    /// away, it is a trigonometric polynomial of degree L with no slope at the minimum, so by
    /// Bernstein's inequality the grid point exceeds the minimum by at most d^2 / 2 L^2 max|E|,
    /// and max|E| <= |c| B / sqrt(4 pi) (Cauchy-Schwarz and the addition theorem, B bands).
    /// Every grid point at least that far above 0 proves E >= 0 everywhere.
    fn nonnegative(&self, grid: &[Vec3], channel: usize) -> bool {
        use rayon::prelude::*;
        let e = self.irradiance();
        let degree = (0..e.len())
            .filter(|&i| e[i][channel] != 0.0)
            .map(band)
            .max()
            .unwrap_or(0) as f64;
        let norm = e
            .iter()
            .map(|c| c[channel] * c[channel])
            .sum::<f64>()
            .sqrt();
        let max_e = norm * self.bands as f64 / (4.0 * PI).sqrt();
        // No point of the sphere is further from a texel centre than a texel's half diagonal
        // at the face centre, atan(sqrt(2) / GRID).
        let d = (2f64.sqrt() / GRID as f64).atan();
        let margin = 0.5 * d * d * degree * degree * max_e;
        let bands = self.bands;
        grid.par_iter().all(|&dir| {
            let mut ys = [0.0f64; MAX_COEFFS];
            basis_into(dir, bands, &mut ys);
            e.iter().zip(&ys).map(|(c, y)| c[channel] * y).sum::<f64>() >= margin
        })
    }

    /// Coefficients of the irradiance E(n) = integral of L(l) max(0, n.l) dl.
    pub fn irradiance(&self) -> Vec<[f64; 3]> {
        self.radiance
            .iter()
            .enumerate()
            .map(|(i, c)| c.map(|v| v * cosine_band(band(i))))
            .collect()
    }

    /// Coefficients of E(n) / pi, what a white Lambertian surface reflects.
    pub fn irradiance_over_pi(&self) -> Vec<[f64; 3]> {
        let e = self.irradiance();
        e.iter().map(|c| c.map(|v| v / PI)).collect()
    }

    /// Every coefficient times `k` (an exposure).
    pub fn scaled(&self, k: f64) -> ShSet {
        ShSet {
            radiance: self.radiance.iter().map(|c| c.map(|v| v * k)).collect(),
            ..self.clone()
        }
    }
}

/// Band of coefficient `i`.
pub fn band(i: usize) -> usize {
    (i as f64).sqrt() as usize
}

/// Evaluates coefficients (any number of bands) at a direction.
pub fn eval(coeffs: &[[f64; 3]], d: Vec3) -> Vec4 {
    let bands = band(coeffs.len().max(1) - 1) + 1;
    let mut ys = [0.0f64; MAX_COEFFS];
    basis_into(d, bands, &mut ys);
    let mut out = [0.0f64; 3];
    for (c, y) in coeffs.iter().zip(&ys) {
        for k in 0..3 {
            out[k] += c[k] * y;
        }
    }
    Vec4::new(out[0] as f32, out[1] as f32, out[2] as f32, 1.0)
}

/// What `--sh FILE.json` holds.
#[derive(Serialize)]
pub struct ShFile {
    /// Highest band: 2 (nine coefficients) by default, up to 4 (25).
    pub order: u32,
    /// Bands, `order + 1`: `bands * bands` coefficients per channel.
    pub bands: u32,
    /// Which basis and coordinate frame the coefficients are in.
    pub basis: &'static str,
    /// (l, m) of each coefficient, in the order of the coefficient lists.
    pub ordering: Vec<[i32; 2]>,
    /// How to evaluate each basis function, in the same order.
    pub constants: Vec<ShConstant>,
    /// cmgen's sinc^4 window, when one was applied: its cutoff band and each band's weight
    /// (already multiplied into every list below).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window: Option<ShWindowFile>,
    /// Coefficients of the radiance L(d) = sum c_i Y_i(d), per channel [r, g, b].
    pub radiance: Vec<[f64; 3]>,
    /// Coefficients of the irradiance E(n) = sum c_i Y_i(n) (band factors pi, 2pi/3, pi/4,
    /// 0, -pi/24).
    pub irradiance: Vec<[f64; 3]>,
    /// Irradiance divided by pi: the value the irradiance cube map stores, and what a shader
    /// multiplies by the diffuse albedo.
    pub irradiance_over_pi: Vec<[f64; 3]>,
    /// How a shader uses the coefficients.
    pub note: &'static str,
}

/// The window of an [`ShFile`].
#[derive(Serialize)]
pub struct ShWindowFile {
    /// The band at which the taper reaches zero.
    pub cutoff: f64,
    /// Weight of each band, 0 first: (sin x / x)^4, x = pi l / cutoff.
    pub weights: Vec<f64>,
}

/// One basis function Y_l^m: its polynomial in (x, y, z) and constant factor.
#[derive(Serialize)]
pub struct ShConstant {
    /// Band, 0 to 4.
    pub l: i32,
    /// Index within the band, -l to l.
    pub m: i32,
    /// Y as the constant times a polynomial in the direction's x, y, z.
    pub formula: &'static str,
    /// The constant's value.
    pub value: f64,
}

impl ShFile {
    /// The file for order-2 radiance coefficients (per channel, [`super::sh::BASIS`] order).
    pub fn new(radiance: &[[f64; 3]; 9]) -> ShFile {
        ShFile::from_set(&ShSet {
            bands: 3,
            radiance: radiance.to_vec(),
            cutoff: None,
        })
    }

    /// The file for a set of any band count, its window noted.
    pub fn from_set(set: &ShSet) -> ShFile {
        let count = set.radiance.len();
        ShFile {
            order: set.bands as u32 - 1,
            bands: set.bands as u32,
            basis: "real spherical harmonics, directions in cube-map space (x, y, z) unit length",
            ordering: (0..count)
                .map(|i| {
                    let b = describe(i);
                    [b.1, b.2]
                })
                .collect(),
            constants: (0..count)
                .map(|i| {
                    let b = describe(i);
                    ShConstant {
                        l: b.1,
                        m: b.2,
                        formula: b.0,
                        value: b.3,
                    }
                })
                .collect(),
            window: set.cutoff.map(|cutoff| ShWindowFile {
                cutoff,
                weights: (0..set.bands)
                    .map(|l| window_weight(l, cutoff))
                    .collect(),
            }),
            radiance: set.radiance.clone(),
            irradiance: set.irradiance(),
            irradiance_over_pi: set.irradiance_over_pi(),
            note: "shader: color = albedo * sum_i irradiance_over_pi[i] * Y_i(n), Y_i = constant * polynomial above",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_factors_are_ramamoorthi_hanrahans() {
        let want = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0, -PI / 24.0];
        for (l, w) in want.iter().enumerate() {
            assert!((cosine_band(l) - w).abs() < 1e-12, "band {l}");
        }
    }

    #[test]
    fn bands_are_orthonormal() {
        // A 256-face cube's exact solid angles integrate products of the basis.
        let n = 128;
        let angles = solid_angle_table(n);
        let mut gram = [[0.0f64; MAX_COEFFS]; MAX_COEFFS];
        let mut ys = [0.0f64; MAX_COEFFS];
        for face in 0..6 {
            for y in 0..n {
                for x in 0..n {
                    basis_into(texel_dir(face, x, y, 1.0 / n as f32), 5, &mut ys);
                    let sa = angles[y * n + x] as f64;
                    for i in 0..MAX_COEFFS {
                        for j in 0..MAX_COEFFS {
                            gram[i][j] += ys[i] * ys[j] * sa;
                        }
                    }
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, g) in row.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((g - want).abs() < 2e-3, "<Y{i}, Y{j}> = {g}");
            }
        }
    }

    #[test]
    fn windows_parse_as_cmgens() {
        assert_eq!("no".parse(), Ok(ShWindow::None));
        assert_eq!("auto".parse(), Ok(ShWindow::Auto));
        assert_eq!("6".parse(), Ok(ShWindow::Cutoff(6.0)));
        assert!("0".parse::<ShWindow>().is_err());
        assert!("x".parse::<ShWindow>().is_err());
        assert_eq!(window_weight(0, 3.0), 1.0);
        assert_eq!(window_weight(3, 3.0), 0.0);
    }
}
