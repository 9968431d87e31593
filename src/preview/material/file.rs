//! Material files (TOML): a material written out, and read back with every mistake reported at
//! its file and line.

#![warn(missing_docs)]

use super::{check, preset, presets, Material, Model};
use crate::error::{Error, Result};
use crate::preview::Refraction;
use glam::Vec3;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use toml::Spanned;

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
    if let Some(r) = m.refraction {
        let name = match r {
            Refraction::Texts => "texts",
            Refraction::Exact => "exact",
        };
        s.push_str(&format!("refraction = \"{name}\"\n"));
    }
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
        Model::Pbr => {
            s.push_str(&format!("base_color = {}\n", rgb(m.base_color)));
            s.push_str(&format!(
                "metallic = {}\nroughness = {}\n",
                f(m.metallic),
                f(m.roughness)
            ));
            if m.ior != Material::default().ior {
                s.push_str(&format!("ior = {}\n", f(m.ior)));
            }
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

/// A material file as written, each value with where it stands. Unknown keys are errors, so a
/// typo is not silently ignored.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    model: Spanned<Model>,
    reflectivity: Option<Spanned<f32>>,
    transmittance: Option<Spanned<f32>>,
    eta_ratio: Option<Spanned<Eta>>,
    fresnel_bias: Option<Spanned<f32>>,
    fresnel_scale: Option<Spanned<f32>>,
    fresnel_power: Option<Spanned<f32>>,
    decal_color: Option<Spanned<[f32; 3]>>,
    decal: Option<Spanned<PathBuf>>,
    base_color: Option<Spanned<[f32; 3]>>,
    metallic: Option<Spanned<f32>>,
    roughness: Option<Spanned<f32>>,
    ior: Option<Spanned<f32>>,
    refraction: Option<Spanned<Refraction>>,
}

/// The keys of the texts' models, which `pbr` does not take.
const TEXTS_KEYS: [&str; 7] = [
    "reflectivity",
    "transmittance",
    "eta_ratio",
    "fresnel_bias",
    "fresnel_scale",
    "fresnel_power",
    "decal_color",
];

/// The keys only `pbr` takes (glTF's names).
const PBR_KEYS: [&str; 4] = ["base_color", "metallic", "roughness", "ior"];

impl MaterialFile {
    /// Each key the file sets, with the byte offset where its value starts.
    fn keys(&self) -> Vec<(&'static str, usize)> {
        fn at<T>(v: &Option<Spanned<T>>) -> Option<usize> {
            v.as_ref().map(|s| s.span().start)
        }
        [
            ("model", Some(self.model.span().start)),
            ("reflectivity", at(&self.reflectivity)),
            ("transmittance", at(&self.transmittance)),
            ("eta_ratio", at(&self.eta_ratio)),
            ("fresnel_bias", at(&self.fresnel_bias)),
            ("fresnel_scale", at(&self.fresnel_scale)),
            ("fresnel_power", at(&self.fresnel_power)),
            ("decal_color", at(&self.decal_color)),
            ("decal", at(&self.decal)),
            ("base_color", at(&self.base_color)),
            ("metallic", at(&self.metallic)),
            ("roughness", at(&self.roughness)),
            ("ior", at(&self.ior)),
            ("refraction", at(&self.refraction)),
        ]
        .into_iter()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .collect()
    }
}

/// Line (from 1) of byte offset `at` in `text`.
fn line_at(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// Parses a material file's text; `path` names it in errors and anchors a relative `decal`.
/// Every error names the file, and the line where the file says it.
pub fn parse_toml(text: &str, path: &Path) -> Result<Material> {
    let file: MaterialFile = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_at(text, s.start));
        let msg = e.message().replace('\n', " ");
        Error::recipe(path, line, msg.trim())
    })?;
    let keys = file.keys();
    let line_of = |key: &str| {
        keys.iter()
            .find(|(k, _)| *k == key)
            .map(|(_, at)| line_at(text, *at))
    };
    let bad = |key: &str, msg: String| Error::recipe(path, line_of(key), msg);
    let model = *file.model.get_ref();
    for (key, _) in &keys {
        if model == Model::Pbr && TEXTS_KEYS.contains(key) {
            return Err(bad(
                key,
                format!(
                    "{key} is not a parameter of model \"pbr\" (it takes base_color, metallic, roughness, ior and decal)"
                ),
            ));
        }
        if model != Model::Pbr && PBR_KEYS.contains(key) {
            return Err(bad(key, format!("{key} applies to model \"pbr\" only")));
        }
        if *key == "refraction" && !matches!(model, Model::Refract | Model::Dispersion) {
            return Err(bad(
                key,
                "refraction (texts or exact) applies to models \"refract\" and \"dispersion\""
                    .into(),
            ));
        }
    }
    let d = Material::default();
    let eta_ratio = match file.eta_ratio.as_ref().map(|e| e.get_ref()) {
        Some(Eta::One(e)) => Vec3::splat(*e),
        Some(Eta::Rgb(e)) => Vec3::from_array(*e),
        None if matches!(model, Model::Reflect | Model::Pbr) => d.eta_ratio,
        None => {
            return Err(bad(
                "model",
                format!(
                    "model \"{}\" needs eta_ratio (e.g. 0.6667 for air into glass)",
                    model.name()
                ),
            ))
        }
    };
    if model == Model::Refract
        && matches!(
            file.eta_ratio.as_ref().map(|e| e.get_ref()),
            Some(Eta::Rgb(_))
        )
    {
        return Err(bad(
            "eta_ratio",
            "model \"refract\" takes one eta_ratio; per-channel ratios need model \"dispersion\""
                .into(),
        ));
    }
    let num = |v: &Option<Spanned<f32>>, default: f32| v.as_ref().map_or(default, |s| *s.get_ref());
    let rgb = |v: &Option<Spanned<[f32; 3]>>, default: Vec3| {
        v.as_ref()
            .map_or(default, |s| Vec3::from_array(*s.get_ref()))
    };
    let m = Material {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "material".into()),
        model,
        reflectivity: num(&file.reflectivity, d.reflectivity),
        transmittance: num(&file.transmittance, d.transmittance),
        eta_ratio,
        fresnel_bias: num(&file.fresnel_bias, d.fresnel_bias),
        fresnel_scale: num(&file.fresnel_scale, d.fresnel_scale),
        fresnel_power: num(&file.fresnel_power, d.fresnel_power),
        decal_color: rgb(&file.decal_color, d.decal_color),
        decal: file.decal.map(|p| {
            let p = p.into_inner();
            if p.is_relative() {
                path.parent().unwrap_or(Path::new("")).join(p)
            } else {
                p
            }
        }),
        base_color: rgb(&file.base_color, d.base_color),
        metallic: num(&file.metallic, d.metallic),
        roughness: num(&file.roughness, d.roughness),
        ior: num(&file.ior, d.ior),
        refraction: file.refraction.map(Spanned::into_inner),
    };
    check(&m).map_err(|(key, msg)| bad(key, msg))?;
    Ok(m)
}

/// A material named on the command line: a preset, or a `.toml` file.
pub fn resolve(spec: &str, session: crate::io::Session) -> Result<Material> {
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
    session.note(path);
    let text = String::from_utf8(text)
        .map_err(|_| Error::file(path, "a material file must be UTF-8 text (TOML)"))?;
    parse_toml(&text, path)
}
