//! The materials: the programs of The Cg Tutorial, chapter 7, as functions, and the parameter
//! sets (presets from table 7-2, or TOML files) they run with.
//!
//! - `reflect` (C7E1v/C7E2f): color = lerp(decal, texCUBE(env, reflect(I, N)), reflectivity)
//! - `refract` (C7E3v/C7E4f): color = lerp(decal, texCUBE(env, refract(normalize(I), N, eta)),
//!   transmittance)
//! - `dispersion` (C7E5v/C7E6f): R = reflect(I, N); T_c = refract(normalize(I), N, eta_c) per
//!   channel; factor = clamp(bias + scale (1 + dot(normalize(I), N))^power, 0, 1);
//!   color = lerp(refracted, reflected, factor)
//!
//! with I = P - eye (not normalised where the texts do not normalise it) and N the unit normal.
//!
//! And one model that is not the texts': `pbr`, the metallic-roughness material of glTF 2.0
//! shaded with the split-sum approximation engines use (see [`super::pbr`]).

#![warn(missing_docs)]

mod file;

pub use file::{parse_toml, resolve, to_toml};

use super::Refraction;
use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Which of the texts' program pairs a material runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Model {
    /// C7E1v/C7E2f: reflection blended with the decal by `reflectivity`.
    Reflect,
    /// C7E3v/C7E4f: refraction blended with the decal by `transmittance`.
    Refract,
    /// C7E5v/C7E6f: Fresnel-weighted reflection over per-channel refraction.
    Dispersion,
    /// glTF's metallic-roughness material, split-sum GGX specular plus Lambert diffuse.
    Pbr,
}

impl Model {
    /// The name material files and labels use.
    pub fn name(self) -> &'static str {
        match self {
            Model::Reflect => "reflect",
            Model::Refract => "refract",
            Model::Dispersion => "dispersion",
            Model::Pbr => "pbr",
        }
    }
}

/// A material: the model and the texts' uniform parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Preset name or file stem (labels, messages).
    pub name: String,
    /// Which program pair shades it.
    pub model: Model,
    /// C7E2f `reflectivity` (reflect; dispersion where a control map's Fresnel mask is 0).
    pub reflectivity: f32,
    /// C7E4f `transmittance` (refract).
    pub transmittance: f32,
    /// `etaRatio`: incident over transmitted index of refraction; refract uses x, dispersion
    /// x, y, z for red, green, blue.
    pub eta_ratio: Vec3,
    /// C7E5v `fresnelBias`: the reflection factor is `bias + scale * (1 + I.N)^power`,
    /// clamped to [0, 1] (dispersion).
    pub fresnel_bias: f32,
    /// C7E5v `fresnelScale` (dispersion).
    pub fresnel_scale: f32,
    /// C7E5v `fresnelPower` (dispersion).
    pub fresnel_power: f32,
    /// The decal colour (linear RGB) where no decal texture is given.
    pub decal_color: Vec3,
    /// A decal texture named by a material file (relative to the file); for `pbr` the base
    /// colour texture, multiplied by `base_color` as glTF's baseColorTexture.
    pub decal: Option<PathBuf>,
    /// `pbr`: glTF `baseColorFactor` (linear RGB, each in [0, 1]): the diffuse albedo of a
    /// dielectric, F0 of a metal.
    pub base_color: Vec3,
    /// `pbr`: glTF `metallicFactor`, 0 dielectric to 1 metal.
    pub metallic: f32,
    /// `pbr`: glTF `roughnessFactor`, perceptual roughness (GGX alpha = roughness^2).
    pub roughness: f32,
    /// `pbr`: index of refraction of the dielectric (KHR_materials_ior; 1.5 gives glTF's
    /// F0 = 0.04): F0 = ((ior - 1) / (ior + 1))^2.
    pub ior: f32,
    /// `refract` and `dispersion`: a material file's `refraction`, which wins over the
    /// preview's option (None: the option decides).
    pub refraction: Option<Refraction>,
}

impl Material {
    /// `pbr`: the dielectric's reflectance at normal incidence, ((ior - 1) / (ior + 1))^2.
    pub fn dielectric_f0(&self) -> f32 {
        let r = (self.ior - 1.0) / (self.ior + 1.0);
        r * r
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "material".into(),
            model: Model::Reflect,
            reflectivity: 1.0,
            transmittance: 1.0,
            eta_ratio: Vec3::ONE,
            fresnel_bias: 0.0,
            fresnel_scale: 1.0,
            fresnel_power: 5.0,
            decal_color: Vec3::splat(0.5),
            decal: None,
            base_color: Vec3::splat(0.5),
            metallic: 0.0,
            roughness: 0.5,
            ior: 1.5,
            refraction: None,
        }
    }
}

/// Cg's `reflect`: I - 2 N dot(N, I). N must be unit; the result is as long as I.
#[inline]
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - 2.0 * n * n.dot(i)
}

/// The texts' reference `refract` (section 7.3.2), for unit I and N: the transmitted vector,
/// or the zero vector on total internal reflection (cosT2 <= 0).
#[inline]
pub fn refract(i: Vec3, n: Vec3, eta_ratio: f32) -> Vec3 {
    let cos_i = (-i).dot(n);
    let cos_t2 = 1.0 - eta_ratio * eta_ratio * (1.0 - cos_i * cos_i);
    let t = eta_ratio * i + (eta_ratio * cos_i - cos_t2.abs().sqrt()) * n;
    if cos_t2 > 0.0 {
        t
    } else {
        Vec3::ZERO
    }
}

/// Equation 7-3 for unit I and N, clamped to [0, 1] (the texts leave the clamp to COLOR
/// interpolation; here it is explicit).
#[inline]
pub fn fresnel(i: Vec3, n: Vec3, bias: f32, scale: f32, power: f32) -> f32 {
    let base = (1.0 + i.dot(n)).max(0.0);
    let p = if power == power.round() && power.abs() <= 32.0 {
        base.powi(power as i32)
    } else {
        base.powf(power)
    };
    (bias + scale * p).clamp(0.0, 1.0)
}

/// Ratio of indices of refraction from table 7-2: air (taken as vacuum, 1.0) into `n`.
fn eta(n: f32) -> f32 {
    1.0 / n
}

/// The built-in materials, with a line saying what each is.
pub fn presets() -> Vec<(Material, &'static str)> {
    let base = Material::default();
    let mut all = vec![
        (
            Material {
                name: "chrome".into(),
                model: Model::Reflect,
                reflectivity: 1.0,
                ..base.clone()
            },
            "a perfect mirror: reflect with reflectivity 1 (C7E1v/C7E2f)",
        ),
        (
            Material {
                name: "mirror-decal".into(),
                model: Model::Reflect,
                reflectivity: 0.6,
                decal_color: Vec3::new(0.75, 0.12, 0.05),
                ..base.clone()
            },
            "reflection over a decal (red unless --decal): reflect with reflectivity 0.6",
        ),
        (
            Material {
                name: "glass".into(),
                model: Model::Refract,
                eta_ratio: Vec3::splat(eta(1.5)),
                transmittance: 1.0,
                ..base.clone()
            },
            "refract from air into glass, eta_ratio 1/1.5 (table 7-2; C7E3v/C7E4f)",
        ),
        (
            Material {
                name: "water".into(),
                model: Model::Refract,
                eta_ratio: Vec3::splat(eta(1.3333)),
                transmittance: 1.0,
                ..base.clone()
            },
            "refract from air into water, eta_ratio 1/1.3333 (table 7-2)",
        ),
        (
            Material {
                name: "diamond".into(),
                model: Model::Refract,
                eta_ratio: Vec3::splat(eta(2.417)),
                transmittance: 1.0,
                ..base.clone()
            },
            "refract from air into diamond, eta_ratio 1/2.417 (table 7-2)",
        ),
        (
            Material {
                name: "plastic".into(),
                model: Model::Refract,
                eta_ratio: Vec3::splat(eta(1.5)),
                transmittance: 0.55,
                decal_color: Vec3::new(0.05, 0.25, 0.8),
                ..base.clone()
            },
            "tinted translucent plastic: refract, eta_ratio 1/1.5 (table 7-2), transmittance 0.55 over a blue decal",
        ),
        (
            Material {
                name: "crystal".into(),
                model: Model::Dispersion,
                eta_ratio: Vec3::new(eta(1.44), eta(1.5), eta(1.56)),
                fresnel_bias: 0.1,
                fresnel_scale: 1.0,
                fresnel_power: 2.0,
                ..base.clone()
            },
            "Fresnel and chromatic dispersion (C7E5v/C7E6f): glass with indices 1.44, 1.5, 1.56 for red, green, blue",
        ),
    ];
    all.extend(pbr_presets(base));
    all
}

/// The split-sum (glTF metallic-roughness) presets, after the texts' materials.
fn pbr_presets(base: Material) -> Vec<(Material, &'static str)> {
    vec![
        (
            Material {
                name: "pbr".into(),
                model: Model::Pbr,
                ..base.clone()
            },
            "glTF metallic-roughness, split-sum GGX + Lambert: grey dielectric, roughness 0.5",
        ),
        (
            Material {
                name: "gold".into(),
                model: Model::Pbr,
                base_color: Vec3::new(1.0, 0.766, 0.336),
                metallic: 1.0,
                roughness: 0.3,
                ..base.clone()
            },
            "pbr metal, gold's F0 as Filament lists it (linear 1.0, 0.766, 0.336), roughness 0.3",
        ),
        (
            Material {
                name: "copper".into(),
                model: Model::Pbr,
                base_color: Vec3::new(0.955, 0.638, 0.538),
                metallic: 1.0,
                roughness: 0.45,
                ..base.clone()
            },
            "pbr metal, copper's F0 as Filament lists it (linear 0.955, 0.638, 0.538), roughness 0.45",
        ),
        (
            Material {
                name: "plastic-glossy".into(),
                model: Model::Pbr,
                base_color: Vec3::new(0.05, 0.2, 0.7),
                roughness: 0.15,
                ..base.clone()
            },
            "pbr dielectric (F0 0.04), blue, roughness 0.15",
        ),
        (
            Material {
                name: "plastic-rough".into(),
                model: Model::Pbr,
                base_color: Vec3::new(0.7, 0.08, 0.05),
                roughness: 0.7,
                ..base
            },
            "pbr dielectric (F0 0.04), red, roughness 0.7",
        ),
    ]
}

/// A preset by name.
pub fn preset(name: &str) -> Option<Material> {
    presets()
        .into_iter()
        .map(|(m, _)| m)
        .find(|m| m.name == name)
}

/// The presets as a listing: name, model, description, parameters as a material file says them.
pub fn list() -> String {
    let mut s = String::new();
    for (m, what) in presets() {
        s.push_str(&format!("{:<15} {}\n", m.name, what));
        for line in to_toml(&m).lines() {
            s.push_str(&format!("{:<15}   {line}\n", ""));
        }
    }
    s
}

/// Checks that parameters are usable: finite, blend weights and glTF factors in [0, 1], ratios
/// positive, an index of refraction at least 1.
pub fn validate(m: &Material) -> Result<()> {
    check(m).map_err(|(_, msg)| Error::usage(msg))
}

/// The first unusable parameter: its key in a material file and what is wrong.
pub(crate) fn check(m: &Material) -> std::result::Result<(), (&'static str, String)> {
    let unit = |name: &'static str, v: f32| {
        if v.is_finite() && (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err((name, format!("{name} must be between 0 and 1 (got {v})")))
        }
    };
    unit("reflectivity", m.reflectivity)?;
    unit("transmittance", m.transmittance)?;
    for c in m.decal_color.to_array() {
        if !c.is_finite() || c < 0.0 {
            return Err((
                "decal_color",
                format!("decal_color values must be finite and not negative (got {c})"),
            ));
        }
    }
    for e in m.eta_ratio.to_array() {
        if !e.is_finite() || e <= 0.0 {
            return Err(("eta_ratio", format!("eta_ratio must be positive (got {e})")));
        }
    }
    for (name, v) in [
        ("fresnel_bias", m.fresnel_bias),
        ("fresnel_scale", m.fresnel_scale),
        ("fresnel_power", m.fresnel_power),
    ] {
        if !v.is_finite() {
            return Err((name, format!("{name} must be a finite number (got {v})")));
        }
    }
    if m.fresnel_power < 0.0 {
        return Err((
            "fresnel_power",
            format!(
                "fresnel_power must not be negative (got {})",
                m.fresnel_power
            ),
        ));
    }
    for c in m.base_color.to_array() {
        if !(c.is_finite() && (0.0..=1.0).contains(&c)) {
            return Err((
                "base_color",
                format!("base_color values must be between 0 and 1, linear RGB (got {c})"),
            ));
        }
    }
    unit("metallic", m.metallic)?;
    unit("roughness", m.roughness)?;
    if !(m.ior.is_finite() && m.ior >= 1.0) {
        return Err((
            "ior",
            format!(
                "ior must be a number of at least 1 (got {}; 1.5 gives F0 = 0.04)",
                m.ior
            ),
        ));
    }
    Ok(())
}
