//! The interactive viewer's files: a static page (index.html, its scripts) and the scene it
//! draws (data.js: the map's levels as RGB16F, pbr's GGX chain, irradiance cube and DFG
//! table, the decal
//! and control map, the materials and what `info` says of the map). Data travels as scripts,
//! not fetched files, so the page opens from disk (`file://`) as well as from any server.
//! The renderer (viewer.js) is the preview's scene on the GPU: its programs are written from
//! the same formulas as [`crate::preview`]'s, and the tests hold the two to each other.

#![warn(missing_docs)]

use crate::cube::CubeSampler;
use crate::image::Image;
use crate::preview::material::{presets, Material, Model};
use crate::preview::pbr::{self, PbrSetup};
use crate::preview::LoadedEnv;
use base64::Engine as _;
use serde_json::{json, Value};

mod page;

pub use page::{files, paths};

/// Rows of the pbr roughness -> level table (read linearly between rows).
const LOD_ROWS: usize = 257;

/// Face edge of the irradiance cube the page's pbr diffuse reads: the CPU preview's
/// irradiance ([`crate::filter::IrradianceLight`]) at its texel centres, looked up bilinearly
/// by the GPU (the sun's terminator is where the two part; docs/view.md gives the figure).
pub const IRRADIANCE_SIZE: usize = 128;

/// What the page draws, besides the environment.
#[derive(Default)]
pub struct Extras<'a> {
    /// The decal on the sphere's (u, v).
    pub decal: Option<&'a Image>,
    /// A control map and the LOD bias its blur = 1 stands for.
    pub control: Option<(&'a Image, f32)>,
    /// What `info` reports of the input (shown on the page).
    pub info: Option<Value>,
    /// The input's name, for the page's title.
    pub name: String,
}

fn b64(halves: &[u16]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytemuck::cast_slice(halves))
}

fn half(v: f32) -> u16 {
    half::f16::from_f32(crate::io::finite(v, crate::io::HALF_MAX)).to_bits()
}

/// Every level of a cube sampler, faces +X -X +Y -Y +Z -Z, rows from the top, RGB16F (no
/// lookup reads alpha: a quarter less to carry and decode).
fn chain_json(s: &CubeSampler) -> Value {
    let mut data = Vec::new();
    let mut levels = Vec::new();
    for level in 0..s.level_count() {
        let n = s.level_size(level);
        levels.push(n);
        for face in 0..6 {
            for y in 0..n {
                for p in s.row(level, face, y) {
                    data.extend([p.x, p.y, p.z].map(half));
                }
            }
        }
    }
    json!({ "levels": levels, "data": b64(&data) })
}

fn image_json(img: &Image) -> Value {
    let data: Vec<u16> = img
        .pixels
        .iter()
        .flat_map(|p| [p.x, p.y, p.z, p.w].map(half))
        .collect();
    json!({ "width": img.width, "height": img.height, "data": b64(&data) })
}

fn material_json(m: &Material) -> Value {
    let model = match m.model {
        Model::Reflect => "reflect",
        Model::Refract => "refract",
        Model::Dispersion => "dispersion",
        Model::Pbr => "pbr",
    };
    json!({
        "model": model,
        "reflectivity": m.reflectivity,
        "transmittance": m.transmittance,
        "eta_ratio": m.eta_ratio.to_array(),
        "fresnel_bias": m.fresnel_bias,
        "fresnel_scale": m.fresnel_scale,
        "fresnel_power": m.fresnel_power,
        "decal_color": m.decal_color.to_array(),
        "base_color": m.base_color.to_array(),
        "metallic": m.metallic,
        "roughness": m.roughness,
        "f0": m.dielectric_f0(),
        // A material's own refraction wins over the page's choice, as over preview's flag.
        "refraction": m.refraction.map(|r| match r {
            crate::preview::Refraction::Texts => "texts",
            crate::preview::Refraction::Exact => "exact",
        }),
    })
}

/// The scene as the page reads it: `window.cubeforgeScene = {...}`, its strings escaped so
/// that the script can stand inline in a page whatever the input's name and path hold.
pub fn scene_script(env: &LoadedEnv, setup: &PbrSetup, extras: &Extras) -> String {
    let split = &setup.split_sum;
    let lod_table: Vec<f32> = (0..LOD_ROWS)
        .map(|i| split.lod(i as f32 / (LOD_ROWS - 1) as f32))
        .collect();
    let irradiance = CubeSampler::new(&split.diffuse().to_cube(IRRADIANCE_SIZE));
    let materials: serde_json::Map<String, Value> = presets()
        .iter()
        .map(|(m, _)| (m.name.clone(), material_json(m)))
        .collect();
    let scene = json!({
        "name": extras.name,
        // Values above 1: the page's tone curve is ACES unless its query names one.
        "hdr": env.hdr,
        "env": chain_json(&env.sampler),
        "pbr": {
            "chain": setup.chain.as_ref().map(chain_json),
            "lod_table": lod_table,
            "irradiance": chain_json(&irradiance),
            "roughness": split.mapping().level_roughness(),
        },
        "dfg": image_json(pbr::dfg_table()),
        "decal": extras.decal.map(image_json),
        "control": extras.control.map(|(img, max)| {
            let mut v = image_json(img);
            v["max_lod_bias"] = json!(max);
            v
        }),
        "materials": materials,
        "info": extras.info,
    });
    format!(
        "window.cubeforgeScene = {};\n",
        page::script_json(&scene.to_string())
    )
}

/// Bytes the page's data takes for `env` (half floats, base64), for the memory plan.
pub fn data_bytes(face: u64, levels: u64) -> u64 {
    let texels: u64 = (0..levels.max(1))
        .map(|l| 6 * (face >> l).max(1).pow(2))
        .sum();
    texels * 8 * 4 / 3
}
