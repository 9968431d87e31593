//! `preview --sun` (issue 49): the map's sun taken out and shone back as a directional light,
//! as `ibl --sun` hands it to an engine, so that the preview shows what an engine lit by those
//! files shows (and the sun is not counted twice).
//!
//! The light adds the analytic terms an engine's punctual light adds to the split-sum ones:
//! with E its irradiance (the map's units times steradians, [`crate::flux::sun::Light`]), L
//! the unit vector towards it and H = normalize(L + V),
//!
//! - diffuse: c_diff E max(n.l, 0) / pi (Lambert, the cosine the SH only approximate);
//! - specular: D(H) Vis F(v.h) E n.l, glTF 2.0's GGX: alpha = roughness^2,
//!   D = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2), the height-correlated Smith
//!   Vis = 0.5 / (n.l sqrt((n.v)^2 (1 - alpha^2) + alpha^2) + n.v sqrt((n.l)^2 (1 - alpha^2)
//!   + alpha^2)) and Schlick's F = F0 + (1 - F0) (1 - v.h)^5 (the DFG table's terms).
//!
//! The sun is a point (its half-degree disc is left out); the sphere casts no shadow on itself
//! beyond n.l.

#![warn(missing_docs)]

use super::load::LoadedEnv;
use crate::cube::{CubeMap, CubeSampler};
use crate::flux::{sun, Grid};
use crate::image::Image;
use glam::Vec3;
use std::f32::consts::PI;

/// A directional light: where it is and what it gives a surface facing it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector towards the light (cube-map space).
    pub direction: Vec3,
    /// RGB irradiance on a surface facing it, in the map's units times steradians.
    pub irradiance: Vec3,
}

impl From<&sun::Light> for Sun {
    fn from(l: &sun::Light) -> Sun {
        Sun {
            direction: l.direction.normalize_or_zero(),
            irradiance: Vec3::new(
                l.irradiance[0] as f32,
                l.irradiance[1] as f32,
                l.irradiance[2] as f32,
            ),
        }
    }
}

impl Sun {
    /// The radiance the light sends towards `v` from a surface of unit normal `n` with diffuse
    /// colour `c_diff`, specular F0 `f0` and perceptual `roughness` (F90 = 1).
    #[inline]
    pub fn shade(&self, c_diff: Vec3, f0: Vec3, roughness: f32, n: Vec3, v: Vec3) -> Vec3 {
        let l = self.direction;
        let nl = n.dot(l);
        if nl <= 0.0 {
            return Vec3::ZERO;
        }
        let nv = n.dot(v).max(1e-4);
        let h = (l + v).normalize_or_zero();
        let (nh, vh) = (n.dot(h).max(0.0), v.dot(h).max(0.0));
        let a2 = (roughness * roughness).powi(2).max(1e-8);
        let t = nh * nh * (a2 - 1.0) + 1.0;
        let d = a2 / (PI * t * t);
        let vis = 0.5
            / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
        let f = f0 + (Vec3::ONE - f0) * (1.0 - vh).powi(5);
        (c_diff / PI + f * (d * vis)) * self.irradiance * nl
    }
}

/// `env` with its sun taken out of level 0 (the sky around it filled in, as `ibl --sun` does;
/// the other levels dropped, as they hold the sun blurred: a chain is made again from what is
/// left), and the sun; `env` as it is and None when the map has none.
pub fn take_out(env: LoadedEnv) -> (LoadedEnv, Option<sun::Light>) {
    let s = &env.sampler;
    let n = s.size();
    let mut faces: [Image; 6] =
        std::array::from_fn(|f| Image::from_fn(n, n, |x, y| s.texel(0, f, x, y)));
    let grid = Grid::Cube(n);
    let lights = sun::find(grid, &faces.iter().collect::<Vec<_>>());
    let Some(light) = lights.sun else {
        return (env, None);
    };
    sun::remove(grid, &mut faces, &light, lights.threshold);
    let cube = CubeMap {
        levels: vec![faces],
    };
    let env = LoadedEnv {
        sampler: CubeSampler::new(&cube),
        levels: None,
        ..env
    };
    (env, Some(light))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A white Lambertian surface facing the light reflects E / pi; at 60 degrees half that.
    #[test]
    fn lambert_takes_the_cosine() {
        let s = Sun {
            direction: Vec3::Y,
            irradiance: Vec3::splat(PI),
        };
        let v = Vec3::new(0.0, 0.6, 0.8);
        let at = |n: Vec3| s.shade(Vec3::ONE, Vec3::ZERO, 1.0, n, v);
        // F0 = 0 still leaves Schlick's grazing term; small at these angles.
        assert!((at(Vec3::Y).x - 1.0).abs() < 0.02, "{}", at(Vec3::Y));
        let n60 = Vec3::new(0.0, 0.5, 0.75f32.sqrt());
        assert!((at(n60).x - 0.5).abs() < 0.02, "{}", at(n60));
        assert_eq!(at(-Vec3::Y), Vec3::ZERO);
    }

    /// The GGX lobe integrates to at most the light: a white metal lit by the sun, summed over
    /// the views of the hemisphere with their cosine, reflects at most E n.l (energy kept), and
    /// at least single scattering's albedo at roughness 1 (about 0.32 of it).
    #[test]
    fn the_specular_lobe_keeps_energy() {
        let s = Sun {
            direction: Vec3::new(0.3, 0.9, 0.1).normalize(),
            irradiance: Vec3::ONE,
        };
        for roughness in [0.3f32, 0.6, 1.0] {
            let steps = 256;
            let mut sum = 0.0;
            for j in 0..steps {
                for i in 0..steps * 2 {
                    let ct = (j as f32 + 0.5) / steps as f32;
                    let phi = (i as f32 + 0.5) / (steps * 2) as f32 * 2.0 * PI;
                    let st = (1.0 - ct * ct).sqrt();
                    let v = Vec3::new(st * phi.cos(), ct, st * phi.sin());
                    let r = s.shade(Vec3::ZERO, Vec3::ONE, roughness, Vec3::Y, v).x;
                    sum += r * ct * (1.0 / steps as f32) * (2.0 * PI / (steps * 2) as f32);
                }
            }
            let e = s.direction.y;
            assert!(
                sum <= e * 1.001 && sum > 0.28 * e,
                "{roughness}: {sum} of {e}"
            );
        }
    }
}
