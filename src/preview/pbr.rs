//! Split-sum image-based lighting for `pbr` materials, as engines shade with a prefiltered GGX
//! chain (Karis, "Real Shading in Unreal Engine 4", 2013), with glTF 2.0's metallic-roughness
//! parameters:
//!
//! - F0 = mix(((ior - 1) / (ior + 1))^2, base_color, metallic) (0.04 for ior 1.5), F90 = 1;
//!   c_diff = base_color (1 - metallic);
//! - specular = prefiltered(R, lod(roughness)) (F0 A + B): the chain sampled along
//!   R = reflect(I, N) at the level whose roughness is the material's (the chain's own
//!   mapping, inverted), trilinear; A, B the DFG terms of [`crate::lut::dfg`] at
//!   (n.v, roughness), bilinear in a 128 x 128 table;
//! - diffuse = c_diff E(N) / pi (Lambert: radiance out = albedo E / pi), E the map's
//!   irradiance as the `irradiance` job sums it, looked up by normal
//!   ([`crate::filter::IrradianceLight`]): not its 9 SH coefficients, which ring around a sun
//!   (a white rough sphere lit by them was 46.7% off on the mean facing the `ibl --sun` test
//!   sky's disc and 154% away from it; its diffuse is now 0.12% off, docs/preview.md).
//!
//! - with `preview --sun`, the sun's own terms ([`super::sun`]) added: Lambert and GGX of a
//!   directional light.
//!
//! Single scattering (no multiscatter energy compensation), and the diffuse term is not
//! weighed by 1 - F: the sum of the two lobes as UE4 shades them.

#![warn(missing_docs)]

use super::load::LoadedEnv;
use super::material::Material;
use super::sun::Sun;
use crate::cube::{CubeMap, CubeSampler, Environment};
use crate::error::{Error, Result};
use crate::filter::RoughnessMapping;
use crate::filter::{self, FilterKind, IrradianceLight};
use crate::ibl::{self, Engine};
use crate::image::Image;
use crate::lut;
use glam::Vec3;
use std::path::Path;
use std::sync::{Arc, OnceLock};

/// Largest face edge of a GGX chain prefiltered at load time (a larger map's level 0 is
/// box-reduced to it first).
pub const PREFILTER_MAX_SIZE: usize = 512;

/// Smallest face edge of a chain prefiltered at load time, as `ibl --target generic`.
pub const PREFILTER_MIN_SIZE: usize = 8;

/// How a chain's levels map to perceptual roughness, and back: the level a `pbr` material of
/// some roughness samples.
#[derive(Clone, Debug, PartialEq)]
pub enum LevelMapping {
    /// Each level's roughness as the chain's description lists it (level 0 first, not
    /// decreasing): the level for a roughness is interpolated linearly between them (exact for
    /// the linear mapping of cubeforge, Bevy and glTF).
    Levels(Vec<f32>),
    /// An engine's own formula over a chain of `count` levels from faces of `size`, continuous
    /// between levels as its shader computes it.
    Engine {
        /// The engine's mapping.
        mapping: RoughnessMapping,
        /// Levels in the chain.
        count: usize,
        /// Face edge of level 0.
        size: usize,
    },
}

impl LevelMapping {
    /// A list of per-level roughness, checked: at least one, each in [0, 1], not decreasing.
    pub fn levels(roughness: Vec<f32>) -> std::result::Result<LevelMapping, String> {
        if roughness.is_empty() {
            return Err("lists no levels".into());
        }
        for (k, r) in roughness.iter().enumerate() {
            if !(r.is_finite() && (0.0..=1.0).contains(r)) {
                return Err(format!("level {k} has roughness {r}, outside 0 to 1"));
            }
            if k > 0 && *r < roughness[k - 1] {
                return Err(format!(
                    "level {k}'s roughness {r} is below level {}'s {}",
                    k - 1,
                    roughness[k - 1]
                ));
            }
        }
        Ok(LevelMapping::Levels(roughness))
    }

    /// Perceptual roughness of each level.
    pub fn level_roughness(&self) -> Vec<f32> {
        match self {
            LevelMapping::Levels(r) => r.clone(),
            LevelMapping::Engine {
                mapping,
                count,
                size,
            } => (0..*count)
                .map(|m| mapping.roughness(m, *count, *size))
                .collect(),
        }
    }

    /// The fractional level that holds perceptual `roughness`, clamped to the chain.
    pub fn lod(&self, roughness: f32) -> f32 {
        match self {
            LevelMapping::Engine {
                mapping,
                count,
                size,
            } => mapping.lod(roughness, *count, *size),
            LevelMapping::Levels(levels) => {
                let r = roughness.clamp(0.0, 1.0);
                if r <= levels[0] {
                    return 0.0;
                }
                for k in 1..levels.len() {
                    if r <= levels[k] {
                        let (lo, hi) = (levels[k - 1], levels[k]);
                        return (k - 1) as f32 + (r - lo) / (hi - lo);
                    }
                }
                (levels.len() - 1) as f32
            }
        }
    }
}

/// The DFG table every `pbr` render reads: [`crate::lut::dfg`] at the default size and sample
/// count (Karis's layout, R scale and G bias), computed once per process.
pub fn dfg_table() -> &'static Image {
    static TABLE: OnceLock<Image> = OnceLock::new();
    TABLE.get_or_init(|| lut::dfg(lut::DEFAULT_SIZE, &lut::LutOptions::default()))
}

/// What split-sum shading reads besides the prefiltered chain: the chain's roughness
/// mapping, the map's irradiance and the DFG table.
#[derive(Clone, Debug)]
pub struct SplitSum {
    mapping: LevelMapping,
    /// The map's irradiance, looked up by normal.
    diffuse: Arc<IrradianceLight>,
    dfg: &'static Image,
    /// The sun taken out of the map, shone as a directional light (`preview --sun`).
    sun: Option<Sun>,
}

impl SplitSum {
    /// Split-sum lighting from a chain's mapping and its map's irradiance.
    pub fn new(mapping: LevelMapping, diffuse: IrradianceLight) -> SplitSum {
        SplitSum {
            mapping,
            diffuse: Arc::new(diffuse),
            dfg: dfg_table(),
            sun: None,
        }
    }

    /// The same lighting with `sun` added as a directional light ([`Sun::shade`]): for a map
    /// whose sun was taken out ([`super::sun::take_out`]).
    pub fn with_sun(self, sun: Option<Sun>) -> SplitSum {
        SplitSum { sun, ..self }
    }

    /// The directional light added to the map's, if any.
    pub fn sun(&self) -> Option<&Sun> {
        self.sun.as_ref()
    }

    /// Split-sum lighting for a chain whose level 0 is `cube`'s (its irradiance as the
    /// `irradiance` command sums it, [`filter::IRRADIANCE_LIGHT_SIZE`] faces).
    pub fn for_cube(cube: &CubeMap, mapping: LevelMapping) -> SplitSum {
        SplitSum::new(
            mapping,
            IrradianceLight::new(cube, filter::IRRADIANCE_LIGHT_SIZE),
        )
    }

    /// The map's irradiance the diffuse term reads.
    pub fn diffuse(&self) -> &IrradianceLight {
        &self.diffuse
    }

    /// The chain's mapping of levels to roughness.
    pub fn mapping(&self) -> &LevelMapping {
        &self.mapping
    }

    /// The fractional level holding `roughness`.
    pub fn lod(&self, roughness: f32) -> f32 {
        self.mapping.lod(roughness)
    }

    /// (A, B) of the DFG table at (n.v, roughness), bilinear between texel centres (clamped
    /// at the table's edges): specular = prefiltered (F0 A + F90 B).
    #[inline]
    pub fn dfg(&self, n_dot_v: f32, roughness: f32) -> (f32, f32) {
        let s = self.dfg.width as f32;
        let t = self.dfg.bilinear(
            n_dot_v.clamp(0.0, 1.0) * s,
            roughness.clamp(0.0, 1.0) * s,
            false,
        );
        (t.x, t.y)
    }

    /// Irradiance over pi at unit normal `n`: what a white Lambertian surface reflects.
    #[inline]
    pub fn irradiance_over_pi(&self, n: Vec3) -> Vec3 {
        self.diffuse.at(n)
    }

    /// The radiance a `pbr` material of base colour `base` sends towards `v` at unit normal
    /// `n` (both may come interpolated, they are normalised here), with `r` the lookup vector
    /// (reflect(I, N), parallax-corrected) and `bias` added to the level.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn shade<E: Environment + ?Sized>(
        &self,
        env: &E,
        m: &Material,
        base: Vec3,
        n: Vec3,
        v: Vec3,
        r: Vec3,
        bias: f32,
    ) -> Vec3 {
        let n = n.normalize_or_zero();
        let nv = n.dot(v.normalize_or_zero()).clamp(0.0, 1.0);
        let f0 = Vec3::splat(m.dielectric_f0()).lerp(base, m.metallic);
        let (a, b) = self.dfg(nv, m.roughness);
        let prefiltered = if r == Vec3::ZERO {
            Vec3::ZERO
        } else {
            env.lookup(r, self.lod(m.roughness) + bias).truncate()
        };
        let c_diff = base * (1.0 - m.metallic);
        let diffuse = c_diff * self.irradiance_over_pi(n);
        let direct = self.sun.map_or(Vec3::ZERO, |s| {
            s.shade(c_diff, f0, m.roughness, n, v.normalize_or_zero())
        });
        diffuse + prefiltered * (f0 * a + Vec3::splat(b)) + direct
    }
}

/// An environment made ready for `pbr` materials, and what the user should hear about it.
pub struct PbrSetup {
    /// The lighting to render with.
    pub split_sum: SplitSum,
    /// The GGX chain made in memory, when the environment's own levels are not one (render
    /// `pbr` materials with [`PbrSetup::sampler`]; the texts' materials keep the map as read).
    pub chain: Option<CubeSampler>,
    /// What was read or made (for `-v`).
    pub note: String,
    /// What the user should know even without `-v`: the chain was not used as it is.
    pub warning: Option<String>,
}

impl std::fmt::Debug for PbrSetup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PbrSetup")
            .field("split_sum", &self.split_sum)
            .field("chain_levels", &self.chain.as_ref().map(|c| c.levels()))
            .field("note", &self.note)
            .field("warning", &self.warning)
            .finish()
    }
}

impl PbrSetup {
    /// The environment's own chain, read with `mapping` (its level 0 gives the irradiance).
    fn own_chain(level0: &CubeMap, mapping: LevelMapping, note: String) -> PbrSetup {
        PbrSetup {
            split_sum: SplitSum::for_cube(level0, mapping),
            chain: None,
            note,
            warning: None,
        }
    }

    /// The chain `pbr` materials sample: the one made in memory, or `env`'s own.
    pub fn sampler<'a>(&'a self, env: &'a LoadedEnv) -> &'a CubeSampler {
        self.chain.as_ref().unwrap_or(&env.sampler)
    }
}

/// Roughness values as a message lists them.
fn list(r: &[f32]) -> String {
    r.iter()
        .map(|v| format!("{}", (v * 1000.0).round() / 1000.0))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Makes `env` (read from `name`) ready for `pbr` materials. A GGX chain keeps its levels and
/// their roughness from its description (levels.json, the KTX2 key, the DDS sidecar), or
/// `target`'s mapping when one is named; anything else (one level, another filter's chain, a
/// chain that does not say its roughness) gets a GGX chain prefiltered from its level 0 in
/// memory, with `target`'s mapping or the linear one ([`PbrSetup::chain`]).
pub fn prepare(env: &LoadedEnv, name: &Path, target: Option<Engine>) -> Result<PbrSetup> {
    let engine_mapping = match target {
        Some(e) if ibl::panorama::filters_itself(e) => {
            return Err(Error::usage(format!(
                "{} {}: that engine prefilters the panorama itself, with a mapping of its own; use bevy, gltf, babylon, filament or generic",
                crate::error::param("target"),
                e.name()
            )))
        }
        Some(e) => Some((e, ibl::engines::defaults(e).mapping)),
        None => None,
    };
    let count = env.levels();
    let size = env.sampler.size();
    let shown = name.display();
    let level0 = level0(&env.sampler);
    if count > 1 {
        if let Some((e, mapping)) = engine_mapping {
            let m = LevelMapping::Engine {
                mapping,
                count,
                size,
            };
            let note = format!(
                "{shown}: {count} levels read with {}'s roughness mapping: {}",
                e.name(),
                list(&m.level_roughness())
            );
            return Ok(PbrSetup::own_chain(&level0, m, note));
        }
        let why = match &env.levels {
            Some(d) if d.filter != FilterKind::Ggx => {
                format!("is a {} chain, not GGX", d.filter.name())
            }
            Some(d) if d.levels.len() != count => format!(
                "has {count} levels but its description lists {}",
                d.levels.len()
            ),
            Some(d) => {
                let r: Option<Vec<f32>> = d.levels.iter().map(|l| l.roughness).collect();
                match r.map(LevelMapping::levels) {
                    Some(Ok(m)) => {
                        let note = format!(
                            "{shown}: GGX chain of {count} levels, roughness {} (its description)",
                            list(&m.level_roughness())
                        );
                        return Ok(PbrSetup::own_chain(&level0, m, note));
                    }
                    Some(Err(e)) => format!("has a description whose {e}"),
                    None => "has a description without every level's roughness".into(),
                }
            }
            None => format!(
                "has {count} levels but does not say their roughness (levels.json, NAME.ktx2.levels.json or the KTX2 key {}; {} ENGINE reads an engine's chain as it is)",
                crate::io::ktx2::LEVELS_KEY,
                crate::error::param("target")
            ),
        };
        let (setup, made) = prefiltered(level0, engine_mapping, size);
        return Ok(PbrSetup {
            warning: Some(format!(
                "{shown} {why}: prefiltered a GGX chain from its level 0 in memory ({made})"
            )),
            ..setup
        });
    }
    let (setup, made) = prefiltered(level0, engine_mapping, size);
    Ok(PbrSetup {
        note: format!("{shown}: one level; prefiltered a GGX chain in memory: {made}"),
        ..setup
    })
}

/// Level 0 of a sampler's chain as a cube map.
fn level0(s: &CubeSampler) -> CubeMap {
    let n = s.size();
    let faces = std::array::from_fn(|f| Image::from_fn(n, n, |x, y| s.texel(0, f, x, y)));
    CubeMap {
        levels: vec![faces],
    }
}

/// A GGX chain prefiltered from `level0` (box-reduced to [`PREFILTER_MAX_SIZE`] first), with
/// the engine's mapping or the linear one.
fn prefiltered(
    level0: CubeMap,
    engine: Option<(Engine, RoughnessMapping)>,
    size: usize,
) -> (PbrSetup, String) {
    let base = if size > PREFILTER_MAX_SIZE {
        let mut mips = level0.with_box_mips(None);
        let k = mips
            .levels
            .iter()
            .position(|l| l[0].width <= PREFILTER_MAX_SIZE)
            .unwrap_or(0);
        CubeMap {
            levels: vec![mips.levels.swap_remove(k)],
        }
    } else {
        level0
    };
    let n = base.size();
    let mapping = engine.map_or(RoughnessMapping::Linear, |(_, m)| m);
    let (chain, levels) = ibl::mapped_chain(
        &base,
        FilterKind::Ggx,
        mapping,
        PREFILTER_MIN_SIZE.min(n),
        filter::DEFAULT_SAMPLES,
    );
    let count = levels.len();
    let m = match engine {
        Some(_) => LevelMapping::Engine {
            mapping,
            count,
            size: n,
        },
        None => LevelMapping::Levels(levels.iter().map(|l| l.roughness.unwrap_or(0.0)).collect()),
    };
    let made = format!(
        "{count} levels, faces {n} to {}{}, roughness {}{}",
        chain.levels[count - 1][0].width,
        if n < size {
            format!(" (level 0 box-reduced from {size})")
        } else {
            String::new()
        },
        list(&m.level_roughness()),
        engine.map_or(String::new(), |(e, _)| format!(" ({}'s mapping)", e.name()))
    );
    let split_sum = SplitSum::for_cube(&chain, m);
    (
        PbrSetup {
            split_sum,
            chain: Some(CubeSampler::new(&chain)),
            note: format!("prefiltered a GGX chain in memory: {made}"),
            warning: None,
        },
        made,
    )
}
