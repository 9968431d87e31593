//! Roughness per level: how a specular chain spreads perceptual roughness over its levels,
//! one fact that the chains (`plan_mapped`), the engines' deliveries and the preview's
//! split-sum lookup all read.

use super::lobe::Lobe;
use super::{plan, ChainOptions, LevelInfo};

/// Babylon.js's `lodGenerationScale`: its shaders pick lod = log2(width * alpha) * 0.8.
pub const BABYLON_LOD_GENERATION_SCALE: f64 = 0.8;

/// How perceptual roughness spreads over a specular chain's levels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RoughnessMapping {
    /// Level m of L holds roughness m / (L - 1) (Bevy, the glTF Sample Viewer, cubeforge).
    Linear,
    /// Filament: lod = m / (L - 1) and roughness = 1 - sqrt(1 - lod), so the small levels,
    /// which cost least, hold the rough end.
    Filament,
    /// Babylon.js: level m of a chain of level-0 width w holds GGX alpha = 2^(m / 0.8) / w
    /// (its `lodGenerationScale` 0.8), up to 1; roughness = sqrt(alpha).
    Babylon,
}

impl RoughnessMapping {
    /// Perceptual roughness of level `m` of a chain of `count` levels from faces of `size`.
    pub fn roughness(self, m: usize, count: usize, size: usize) -> f32 {
        let lod = if count > 1 {
            m as f32 / (count - 1) as f32
        } else {
            0.0
        };
        match self {
            RoughnessMapping::Linear => lod,
            RoughnessMapping::Filament => 1.0 - (1.0 - lod).max(0.0).sqrt(),
            RoughnessMapping::Babylon if m == 0 => 0.0,
            RoughnessMapping::Babylon => {
                // Babylon's shaders pick lod = log2(width * alpha) * lodGenerationScale.
                let scale = BABYLON_LOD_GENERATION_SCALE as f32;
                let alpha = (2f32.powf(m as f32 / scale) / size as f32).min(1.0);
                alpha.sqrt()
            }
        }
    }

    /// The fractional level an engine's shader samples for perceptual `roughness` (the
    /// inverse of [`RoughnessMapping::roughness`], continuous between levels as the shaders
    /// compute it), clamped to the chain.
    pub fn lod(self, roughness: f32, count: usize, size: usize) -> f32 {
        let top = count.saturating_sub(1) as f32;
        let r = roughness.clamp(0.0, 1.0);
        let lod = match self {
            RoughnessMapping::Linear => r * top,
            // lod / top = 1 - (1 - r)^2 = r (2 - r).
            RoughnessMapping::Filament => r * (2.0 - r) * top,
            RoughnessMapping::Babylon => {
                let scale = BABYLON_LOD_GENERATION_SCALE as f32;
                (size as f32 * r * r).max(1e-30).log2() * scale
            }
        };
        lod.clamp(0.0, top)
    }
}

/// The plan of `opts`'s chain from faces of `size`, each level's lobe set to the roughness
/// `mapping` gives it (GGX, or Charlie for a sheen chain).
pub(crate) fn plan_mapped(
    opts: &ChainOptions,
    size: usize,
    mapping: RoughnessMapping,
) -> Vec<(LevelInfo, Option<Lobe>)> {
    let count = opts.level_count(size);
    let mut plan = plan(opts, size);
    for (info, lobe) in &mut plan {
        let r = mapping.roughness(info.level, count, size);
        let alpha = r * r;
        info.roughness = Some(r);
        info.alpha = Some(alpha);
        *lobe = lobe.map(|l| match l {
            Lobe::Charlie { .. } => Lobe::Charlie { alpha },
            _ => Lobe::Ggx { alpha },
        });
    }
    plan
}
