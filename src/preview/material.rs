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

#![warn(missing_docs)]

use crate::error::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

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
}

impl Model {
    /// The name material files and labels use.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Model::Reflect => "reflect",
            Model::Refract => "refract",
            Model::Dispersion => "dispersion",
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
    /// A decal texture named by a material file (relative to the file).
    pub decal: Option<PathBuf>,
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
    vec![
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
                ..base
            },
            "Fresnel and chromatic dispersion (C7E5v/C7E6f): glass with indices 1.44, 1.5, 1.56 for red, green, blue",
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
        s.push_str(&format!("{:<13} {}\n", m.name, what));
        for line in to_toml(&m).lines() {
            s.push_str(&format!("{:<13}   {line}\n", ""));
        }
    }
    s
}

/// A material as the TOML a file would hold (only the parameters its model uses).
pub fn to_toml(m: &Material) -> String {
    let f = |v: f32| {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0');
        if s.ends_with('.') {
            format!("{s}0")
        } else {
            s.to_string()
        }
    };
    let rgb = |v: Vec3| format!("[{}, {}, {}]", f(v.x), f(v.y), f(v.z));
    let mut s = format!("model = \"{}\"\n", m.model.name());
    match m.model {
        Model::Reflect => {
            s.push_str(&format!("reflectivity = {}\n", f(m.reflectivity)));
            s.push_str(&format!("decal_color = {}\n", rgb(m.decal_color)));
        }
        Model::Refract => {
            s.push_str(&format!("eta_ratio = {}\n", f(m.eta_ratio.x)));
            s.push_str(&format!("transmittance = {}\n", f(m.transmittance)));
            s.push_str(&format!("decal_color = {}\n", rgb(m.decal_color)));
        }
        Model::Dispersion => {
            s.push_str(&format!("eta_ratio = {}\n", rgb(m.eta_ratio)));
            s.push_str(&format!(
                "fresnel_bias = {}\nfresnel_scale = {}\nfresnel_power = {}\n",
                f(m.fresnel_bias),
                f(m.fresnel_scale),
                f(m.fresnel_power)
            ));
        }
    }
    s
}

/// `eta_ratio` in a file: one ratio for all channels, or red, green, blue.
#[derive(Deserialize)]
#[serde(untagged)]
enum Eta {
    One(f32),
    Rgb([f32; 3]),
}

/// A material file as written. Unknown keys are errors, so a typo is not silently ignored.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    model: Model,
    reflectivity: Option<f32>,
    transmittance: Option<f32>,
    eta_ratio: Option<Eta>,
    fresnel_bias: Option<f32>,
    fresnel_scale: Option<f32>,
    fresnel_power: Option<f32>,
    decal_color: Option<[f32; 3]>,
    decal: Option<PathBuf>,
}

/// Parses a material file's text; `path` names it in errors and anchors a relative `decal`.
pub fn parse_toml(text: &str, path: &Path) -> Result<Material> {
    let file: MaterialFile = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        let msg = e.message().replace('\n', " ");
        Error::recipe(path, line, msg.trim())
    })?;
    let bad = |msg: String| Error::file(path, msg);
    let d = Material::default();
    let eta_ratio = match file.eta_ratio {
        Some(Eta::One(e)) => Vec3::splat(e),
        Some(Eta::Rgb(e)) => Vec3::from_array(e),
        None if file.model == Model::Reflect => d.eta_ratio,
        None => {
            return Err(bad(format!(
                "model \"{}\" needs eta_ratio (e.g. 0.6667 for air into glass)",
                file.model.name()
            )))
        }
    };
    if file.model == Model::Refract && matches!(file.eta_ratio, Some(Eta::Rgb(_))) {
        return Err(bad(
            "model \"refract\" takes one eta_ratio; per-channel ratios need model \"dispersion\""
                .into(),
        ));
    }
    let m = Material {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "material".into()),
        model: file.model,
        reflectivity: file.reflectivity.unwrap_or(d.reflectivity),
        transmittance: file.transmittance.unwrap_or(d.transmittance),
        eta_ratio,
        fresnel_bias: file.fresnel_bias.unwrap_or(d.fresnel_bias),
        fresnel_scale: file.fresnel_scale.unwrap_or(d.fresnel_scale),
        fresnel_power: file.fresnel_power.unwrap_or(d.fresnel_power),
        decal_color: file
            .decal_color
            .map(Vec3::from_array)
            .unwrap_or(d.decal_color),
        decal: file.decal.map(|p| {
            if p.is_relative() {
                path.parent().unwrap_or(Path::new("")).join(p)
            } else {
                p
            }
        }),
    };
    check(&m).map_err(bad)?;
    Ok(m)
}

/// Checks that parameters are usable: finite, blend weights in [0, 1], ratios positive.
pub fn validate(m: &Material) -> Result<()> {
    check(m).map_err(Error::usage)
}

fn check(m: &Material) -> std::result::Result<(), String> {
    let unit = |name: &str, v: f32| {
        if v.is_finite() && (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            Err(format!("{name} must be between 0 and 1 (got {v})"))
        }
    };
    unit("reflectivity", m.reflectivity)?;
    unit("transmittance", m.transmittance)?;
    for c in m.decal_color.to_array() {
        if !c.is_finite() || c < 0.0 {
            return Err(format!(
                "decal_color values must be finite and not negative (got {c})"
            ));
        }
    }
    for e in m.eta_ratio.to_array() {
        if !e.is_finite() || e <= 0.0 {
            return Err(format!("eta_ratio must be positive (got {e})"));
        }
    }
    for (name, v) in [
        ("fresnel_bias", m.fresnel_bias),
        ("fresnel_scale", m.fresnel_scale),
        ("fresnel_power", m.fresnel_power),
    ] {
        if !v.is_finite() {
            return Err(format!("{name} must be a finite number (got {v})"));
        }
    }
    if m.fresnel_power < 0.0 {
        return Err(format!(
            "fresnel_power must not be negative (got {})",
            m.fresnel_power
        ));
    }
    Ok(())
}

/// A material named on the command line: a preset, or a `.toml` file.
pub fn resolve(spec: &str) -> Result<Material> {
    if let Some(m) = preset(spec) {
        return Ok(m);
    }
    let path = Path::new(spec);
    let is_file_like = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
        || spec.contains('/')
        || spec.contains('\\');
    if !is_file_like {
        let names: Vec<String> = presets().into_iter().map(|(m, _)| m.name).collect();
        return Err(Error::usage(format!(
            "unknown material \"{spec}\": use one of {} or a .toml file ({} list shows them)",
            names.join(", "),
            crate::error::param("material")
        )));
    }
    let text = crate::io::read_file(path)?;
    let text = String::from_utf8(text)
        .map_err(|_| Error::file(path, "a material file must be UTF-8 text (TOML)"))?;
    parse_toml(&text, path)
}
