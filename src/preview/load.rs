//! Reading what the preview shows: the environment (with its chain when it has one) and the
//! textures on the sphere, with a control map's sidecar.

#![warn(missing_docs)]

use crate::convert::{self, Source};
use crate::cube::{CubeSampler, Environment};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::input::{Input, InputKind};
use crate::io::{self, Decoded, Limits, ReadOptions};
use crate::resample::Resampler;
use std::path::{Path, PathBuf};

/// An environment ready for the preview, with what the user should be told about it.
pub struct LoadedEnv {
    /// The cube map with every level it brings, ready for seamless lookups.
    pub sampler: CubeSampler,
    /// Every file read.
    pub files: Vec<PathBuf>,
    /// Holds values above 1.
    pub hdr: bool,
    /// NaN, infinite or negative values replaced by 0 on read (values above 1e28 by 1e28).
    pub replaced_values: usize,
    /// The chain's description (levels.json, the KTX2 key, the DDS sidecar), when it has one
    /// that parses: how each level was made.
    pub levels: Option<crate::chain::LevelsFile>,
}

impl LoadedEnv {
    /// How many levels the chain has: 1 means no prefiltered chain, so blur and `--lod-bias`
    /// have nothing to select.
    pub fn levels(&self) -> usize {
        Environment::levels(&self.sampler)
    }
}

/// Loads an environment for the preview, with the warnings of its load. A KTX2 or DDS cube
/// map keeps all its stored levels (they are the prefiltered chain); a directory holding `m0/`,
/// `m1/`, ... (from `cubeforge prefilter`) is read level by level; anything else `convert`
/// reads becomes a one-level cube map at the input's resolution.
pub fn load_environment(input: &Input) -> Result<(LoadedEnv, Vec<String>)> {
    if input.kind() == InputKind::Chain {
        let (c, warnings) = input.load_chain()?;
        let env = LoadedEnv {
            sampler: CubeSampler::new(&c.cube),
            files: c.files,
            hdr: c.meta.hdr,
            replaced_values: c.meta.replaced_values,
            levels: c.levels,
        };
        return Ok((env, warnings));
    }
    let (loaded, warnings) = input.load()?;
    let (cube, levels) = match &loaded.source {
        Source::Cube(c) => {
            let path = &input.paths()[0];
            let levels = io::FileFormat::from_extension(path).and_then(|f| {
                crate::chain::container_levels(path, f, input.read_options().limits.session)
            });
            (CubeSampler::new(c), levels)
        }
        Source::Projection(..) | Source::Reduced(_) => {
            let size = loaded.face_size().max(1);
            let cube = convert::to_cube(&loaded, size, &Resampler::default());
            (CubeSampler::new(&cube), None)
        }
    };
    let env = LoadedEnv {
        sampler: cube,
        files: loaded.files.clone(),
        hdr: loaded.hdr,
        replaced_values: loaded.meta.replaced_values,
        levels,
    };
    Ok((env, warnings))
}

/// Reads a 2D texture for the sphere (decal: colour, sRGB-decoded; control map: `linear`)
/// within the command's `limits`.
pub fn read_texture(path: &Path, linear: bool, limits: &Limits) -> Result<Image> {
    let opts = ReadOptions {
        linear,
        limits: *limits,
        as_stored: false,
        ..Default::default()
    };
    match crate::convert::read(path, &opts)?.0 {
        Decoded::Image(img) => Ok(img),
        Decoded::Cube(_) => Err(Error::file(
            path,
            "holds a cube map; a texture on the sphere must be a 2D image",
        )),
    }
}

/// The sidecar a control map's `max_lod_bias` is stored in: `MAP.json` (e.g. `mask.png.json`)
/// or the map's name with `.json` for its extension (`mask.json`), whichever exists.
pub(crate) fn control_sidecar(map: &Path) -> Option<PathBuf> {
    let mut appended = map.as_os_str().to_owned();
    appended.push(".json");
    [PathBuf::from(appended), map.with_extension("json")]
        .into_iter()
        .find(|p| p.is_file() && p != map)
}

/// Reads a control map (linear data) and its `max_lod_bias`: from the sidecar when there is
/// one, else `default_max`. Returns the map, the value and the sidecar used.
pub fn read_control(
    path: &Path,
    default_max: f32,
    limits: &Limits,
) -> Result<(Image, f32, Option<PathBuf>)> {
    let img = read_texture(path, true, limits)?;
    let Some(side) = control_sidecar(path) else {
        return Ok((img, default_max, None));
    };
    limits.session.note(&side);
    let text = String::from_utf8(io::read_file(&side)?)
        .map_err(|_| Error::file(&side, "not UTF-8 text"))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::file(&side, format!("not valid JSON: {e}")))?;
    let max = match json.get("max_lod_bias") {
        None => default_max,
        Some(v) => v
            .as_f64()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| Error::file(&side, "max_lod_bias must be a number >= 0"))?
            as f32,
    };
    Ok((img, max, Some(side)))
}
