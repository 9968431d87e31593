//! Baking: every channel's source evaluated at the output size and packed into one image.

#![warn(missing_docs)]

use super::recipe::{Recipe, Size, Slot};
use crate::error::Result;
use crate::image::Image;
use crate::io::Limits;
use glam::Vec4;
use serde::Serialize;
use std::path::Path;

/// A baked control map and what went where.
#[derive(Clone, Debug)]
pub struct Baked {
    /// Linear data, R G B A as packed.
    pub image: Image,
    /// The LOD bias that blur = 1 stands for (0 when the recipe has none).
    pub max_lod_bias: f32,
    /// What each channel holds, R G B A.
    pub channels: [ChannelUse; 4],
    /// Parameters the recipe sets but no channel holds.
    pub warnings: Vec<String>,
}

/// What one channel holds and where it came from.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelUse {
    /// The parameter (or constant `zero`/`one`) the channel carries.
    pub holds: Slot,
    /// A one-line description of the source ("checker 8x8 cells; inverted").
    pub source: String,
}

impl Recipe {
    /// Evaluates every packed source at `size` (or the recipe's own size) and packs the planes
    /// into one linear RGBA image; the size is checked against `limits` before allocation.
    pub fn bake(&self, size: Option<Size>, limits: &Limits) -> Result<Baked> {
        let size = self.output_size(size)?;
        let (w, h) = (size.width, size.height);
        limits.check(Path::new("control map"), w as u64, h as u64)?;
        let slots = self.pack.slots();
        let planes: Vec<(Slot, Vec<f32>, String)> = slots
            .iter()
            .map(|&slot| match slot {
                Slot::Zero => (slot, vec![0.0; w * h], "0".to_string()),
                Slot::One => (slot, vec![1.0; w * h], "1".to_string()),
                _ => match self.source(slot) {
                    Some(src) => (slot, src.eval(w, h), src.describe()),
                    None => (slot, vec![0.0; w * h], "0 (not in the recipe)".to_string()),
                },
            })
            .collect();
        let image = Image::from_fn(w, h, |x, y| {
            let i = y * w + x;
            Vec4::new(
                planes[0].1[i],
                planes[1].1[i],
                planes[2].1[i],
                planes[3].1[i],
            )
        });
        let warnings = Slot::PARAMETERS
            .iter()
            .filter(|&&p| self.source(p).is_some() && !slots.contains(&p))
            .map(|p| {
                format!(
                    "{} is set in the recipe but [pack] puts it in no channel",
                    p.name()
                )
            })
            .collect();
        let channels = std::array::from_fn(|i| ChannelUse {
            holds: planes[i].0,
            source: planes[i].2.clone(),
        });
        Ok(Baked {
            image,
            max_lod_bias: self.max_lod_bias.unwrap_or(0.0),
            channels,
            warnings,
        })
    }
}
