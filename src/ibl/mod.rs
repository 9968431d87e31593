//! Image-based lighting as each engine loads it: one call from any input to the files of a
//! target (specular chain, diffuse term, SH, lookup tables), in the engine's orientation,
//! roughness-per-level mapping, container and pixel format, with the snippet that loads them.
//!
//! Everything is computed once in cube-map space ([`Lighting`]); an engine only chooses sizes,
//! how roughness spreads over the levels, the turn or mirror its shaders expect, and how the
//! result is packed ([`engines`]).

#![warn(missing_docs)]

pub mod engines;
mod folder;
pub mod panorama;
pub mod sun;
mod sun_snippets;

use crate::convert::{self, Loaded};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::filter::{self, ChainOptions, FilterKind, IrradianceMethod, LevelInfo};
use crate::progress::Progress;
use crate::resample::Orientation;
use std::path::{Path, PathBuf};

/// The engines (and engine families) `ibl` writes for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Engine {
    /// Bevy's `EnvironmentMapLight`: specular and diffuse KTX2 cube maps.
    Bevy,
    /// The Khronos glTF Sample Viewer (glTF-IBL-Sampler's files): GGX, Lambertian and
    /// Charlie KTX2 cube maps and the BRDF lookup tables.
    Gltf,
    /// Babylon.js: one `.env` file.
    Babylon,
    /// Filament (what cmgen deploys): KTX1 specular and irradiance cube maps, SH, a skybox.
    Filament,
    /// Godot 4: an equirect panorama for a `PanoramaSkyMaterial` (Godot filters it itself).
    Godot,
    /// Unity: an equirect EXR imported as a cube map (Unity filters it itself).
    Unity,
    /// Unreal: an equirect HDR imported as a TextureCube (Unreal filters it itself).
    Unreal,
    /// three.js: an UltraHDR equirect for `UltraHDRLoader` and a Radiance `.hdr` fallback,
    /// sized for its PMREM (which filters it), in three.js's equirect mapping.
    Three,
    /// No engine in particular: KTX2 specular and diffuse, SH as JSON, a DFG table.
    Generic,
}

impl Engine {
    /// The name on the command line and in messages.
    pub fn name(self) -> &'static str {
        match self {
            Engine::Bevy => "bevy",
            Engine::Gltf => "gltf",
            Engine::Babylon => "babylon",
            Engine::Filament => "filament",
            Engine::Godot => "godot",
            Engine::Unity => "unity",
            Engine::Unreal => "unreal",
            Engine::Three => "three",
            Engine::Generic => "generic",
        }
    }
}

pub use crate::filter::RoughnessMapping;
pub use folder::specular_of;
pub(crate) use folder::written_by_targets;

/// What a caller may change; None takes the engine's default.
#[derive(Clone, Debug, Default)]
pub struct IblOptions {
    /// File names start with this (`NAME_specular.ktx2`); default "env".
    pub name: Option<String>,
    /// Face edge of the specular chain's level 0.
    pub specular_size: Option<usize>,
    /// The specular chain stops at this face edge.
    pub min_size: Option<usize>,
    /// Face edge of the diffuse (irradiance) cube map.
    pub diffuse_size: Option<usize>,
    /// Importance samples per texel of the first convolved level.
    pub samples: Option<u32>,
    /// How the files are stored: the containers' texel format (None: each engine's own),
    /// KTX2 supercompression, the EXR panorama's sample type, and the exposure (2^EV) the
    /// radiance is scaled by first (a sun within a format's range). Each engine takes what its
    /// files can hold.
    pub encoding: crate::output::Encoding,
    /// glTF: also the Charlie (sheen) chain.
    pub sheen: bool,
    /// Turn the environment about +Y first (degrees; 90 brings +Z to +X), e.g. to put the sun
    /// where the scene wants it.
    pub yaw: f32,
    /// Take the sun out of the maps and hand it to the engine as a directional light
    /// (`sun.json` and the snippet's lines; [`sun`]).
    pub sun: bool,
}

/// The files for one engine, and how to load them.
#[derive(Debug)]
pub struct Delivery {
    /// Each file's path and bytes.
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// Code (or import steps) that loads the files in the engine.
    pub snippet: String,
    /// The specular chain's levels, as written.
    pub levels: Vec<LevelInfo>,
    /// Texels beyond a format's range, written as its largest value (None: none).
    pub clamped: Option<String>,
    /// Lossy formats (BC6H, BC7): the specular chain's level 0 as decoded against the map
    /// before encoding, dB (see [`crate::io::container_psnr`]).
    pub psnr: Option<f64>,
}

impl Delivery {
    /// Files and their snippet, with no chain description or quality to report.
    pub(crate) fn new(
        files: Vec<(PathBuf, Vec<u8>)>,
        snippet: String,
        clamped: Option<String>,
    ) -> Delivery {
        Delivery {
            files,
            snippet,
            levels: Vec::new(),
            clamped,
            psnr: None,
        }
    }
}

/// Everything an engine's files are made of, in cube-map space after the engine's turn.
pub struct Lighting {
    /// The GGX chain, level 0 the mirror image.
    pub specular: CubeMap,
    /// What each level holds.
    pub levels: Vec<LevelInfo>,
    /// The Charlie (sheen) chain and its levels, when asked for.
    pub sheen: Option<(CubeMap, Vec<LevelInfo>)>,
    /// The Lambertian irradiance cube, over pi (a white environment gives 1).
    pub diffuse: CubeMap,
    /// Order-2 SH of the radiance, [`crate::filter::sh::BASIS`] order.
    pub sh: [[f64; 3]; 9],
}

/// Face edges and mappings an engine uses by default.
#[derive(Clone, Copy, Debug)]
pub struct Defaults {
    /// Specular level 0.
    pub specular_size: usize,
    /// Smallest specular level.
    pub min_size: usize,
    /// Irradiance cube.
    pub diffuse_size: usize,
    /// Roughness per level.
    pub mapping: RoughnessMapping,
    /// The engine's view of cube-map space: applied to the environment before filtering.
    pub orientation: Orientation,
}

/// The specular chain's face edge, where it stops, and the diffuse map's edge: `opts`, else
/// `engine`'s defaults. A target's default floor never exceeds a small size; a given one is
/// checked by [`deliver`].
pub(crate) fn sizes(engine: Engine, opts: &IblOptions) -> (usize, usize, usize) {
    let d = engines::defaults(engine);
    let specular_size = opts.specular_size.unwrap_or(d.specular_size);
    let min_size = opts.min_size.unwrap_or(d.min_size.min(specular_size));
    (
        specular_size,
        min_size,
        opts.diffuse_size.unwrap_or(d.diffuse_size),
    )
}

/// Builds the specular chain, irradiance and SH for `engine` from `loaded`, then packs them as
/// the engine loads them into files under `out`. `progress` hears each finished stage and
/// follows the chains and the irradiance integral texel by texel.
pub fn deliver(
    loaded: &Loaded,
    engine: Engine,
    out: &Path,
    opts: &IblOptions,
    progress: &dyn Progress,
) -> Result<Delivery> {
    let d = engines::defaults(engine);
    let (specular_size, min_size, diffuse_size) = sizes(engine, opts);
    for (what, v) in [
        ("specular size", specular_size),
        ("diffuse size", diffuse_size),
    ] {
        if v == 0 || v > 8192 {
            return Err(Error::usage(format!("{what} {v}: use 1 to 8192")));
        }
    }
    if min_size == 0 || min_size > specular_size {
        return Err(Error::usage(format!(
            "min size {min_size}: use 1 to the specular size ({specular_size})"
        )));
    }
    if opts.sheen && engine != Engine::Gltf {
        return Err(Error::usage(format!(
            "the sheen (Charlie) chain is for {} gltf",
            crate::error::param("target")
        )));
    }
    let name = opts.name.clone().unwrap_or_else(|| "env".into());
    if name.is_empty() || name.contains(['/', '\\']) || name.starts_with('.') {
        return Err(Error::usage(format!(
            "name {name:?}: a plain file-name stem (no folders, not hidden)"
        )));
    }
    // --sun: every file made from the input without its sun.
    let (without, light) = match opts.sun {
        true => sun::take_out(loaded)?,
        false => (None, None),
    };
    let loaded = without.as_ref().unwrap_or(loaded);
    let ctx = engines::Context {
        out,
        name: &name,
        opts,
        inputs: &loaded.files,
        loaded,
        orientation: combine(opts.yaw, d.orientation),
    };
    let delivery = if panorama::filters_itself(engine) {
        panorama::panorama(engine, &ctx, opts.specular_size)?
    } else {
        let lighting = compute(
            loaded,
            &d,
            &ctx,
            specular_size,
            min_size,
            diffuse_size,
            progress,
        );
        let mut delivery = engines::pack(engine, &lighting, &ctx)?;
        progress.stage("encode");
        delivery.levels = lighting.levels;
        delivery
    };
    let mut delivery = delivery;
    if opts.sun {
        let (json, lines) = sun::deliver(engine, ctx.orientation, light.as_ref());
        delivery.files.push((out.join("sun.json"), json));
        delivery.snippet.push_str(&lines);
    }
    // output::deliver refuses to write over an input.
    Ok(delivery)
}

/// The chain, irradiance and SH of `loaded`, turned as the engine expects.
fn compute(
    loaded: &Loaded,
    d: &Defaults,
    ctx: &engines::Context,
    specular_size: usize,
    min_size: usize,
    diffuse_size: usize,
    progress: &dyn Progress,
) -> Lighting {
    let opts = ctx.opts;
    let resampler = ctx.resampler();
    let base = convert::to_cube(loaded, specular_size, &resampler);
    progress.stage("resample");
    let samples = opts.samples.unwrap_or(filter::DEFAULT_SAMPLES);
    let chain = |filter: FilterKind| {
        let (opts, plan) = mapped_plan(filter, d.mapping, specular_size, min_size, samples);
        filter::prefilter_reported(&base, &opts, plan, progress)
    };
    let (specular, levels) = chain(FilterKind::Ggx);
    let sheen = opts.sheen.then(|| chain(FilterKind::Charlie));
    progress.stage("specular");
    // The diffuse term from the base itself: `irradiance_with_progress` box-reduces it to 256
    // faces (flux kept) and sums over a 64-face copy, its peaks at 256. A second resample of
    // the input at 256 read a 16K panorama again (1.1 s of 4.4 on 2 cores, issue 47).
    progress.start(
        6 * diffuse_size as u64,
        &format!("irradiance {diffuse_size}"),
    );
    let (diffuse, sh) =
        filter::irradiance_with_progress(&base, diffuse_size, IrradianceMethod::Brute, &|n| {
            progress.advance(n)
        });
    progress.finish();
    progress.stage("diffuse");
    Lighting {
        specular,
        levels,
        sheen,
        diffuse,
        sh,
    }
}

/// A GGX or Charlie chain from `base` whose level m holds the roughness `mapping` gives it,
/// stopped at faces of `min_size`, with `samples` importance samples at the first filtered
/// level.
pub(crate) fn mapped_chain(
    base: &CubeMap,
    filter: FilterKind,
    mapping: RoughnessMapping,
    min_size: usize,
    samples: u32,
) -> (CubeMap, Vec<LevelInfo>) {
    let (chain_opts, plan) = mapped_plan(filter, mapping, base.size(), min_size, samples);
    filter::prefilter_planned(base, &chain_opts, plan, &|_| {})
}

/// The options and per-level plan of [`mapped_chain`] for a base of face edge `size`.
fn mapped_plan(
    filter: FilterKind,
    mapping: RoughnessMapping,
    size: usize,
    min_size: usize,
    samples: u32,
) -> (ChainOptions, Vec<(LevelInfo, Option<filter::lobe::Lobe>)>) {
    let chain_opts = ChainOptions {
        filter,
        min_size: Some(min_size),
        samples,
        ..ChainOptions::default()
    };
    let plan = filter::plan_mapped(&chain_opts, size, mapping);
    (chain_opts, plan)
}

/// The caller's turn about +Y first, then the engine's view (a turn about +Y and perhaps a
/// mirror of X): the lookup matrices multiply as R(-a) D R(-b) = D R(a - b) with D the mirror.
fn combine(yaw: f32, engine: Orientation) -> Orientation {
    Orientation {
        yaw: if engine.mirror {
            engine.yaw - yaw
        } else {
            engine.yaw + yaw
        },
        ..engine
    }
}
