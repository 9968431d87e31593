//! Each engine's files: sizes, orientation, containers and the snippet that loads them.

use super::{Defaults, Delivery, Engine, IblOptions, Lighting, RoughnessMapping};
use crate::chain::LevelsFile;
use crate::convert::Loaded;
use crate::cube::CubeMap;
use crate::error::Result;
use crate::filter::{sh, ChainOptions};
use crate::io::{self, FileFormat, GpuFormat};
use crate::resample::Orientation;
use std::path::{Path, PathBuf};

/// Where and under which name an engine's files go.
pub struct Context<'a> {
    /// The output folder.
    pub out: &'a Path,
    /// File-name stem.
    pub name: &'a str,
    /// The caller's choices.
    pub opts: &'a IblOptions,
    /// Files read (never overwritten).
    pub inputs: &'a [PathBuf],
    /// The input, for targets that ship the environment itself (skyboxes, panoramas).
    pub loaded: &'a Loaded,
}

impl Context<'_> {
    fn path(&self, suffix: &str) -> PathBuf {
        self.out.join(format!("{}{suffix}", self.name))
    }
}

/// Sizes, roughness mapping and orientation of each engine.
pub fn defaults(engine: Engine) -> Defaults {
    let linear = |specular_size, min_size, diffuse_size| Defaults {
        specular_size,
        min_size,
        diffuse_size,
        mapping: RoughnessMapping::Linear,
        orientation: Orientation::default(),
    };
    match engine {
        Engine::Bevy => linear(512, 1, 32),
        Engine::Gltf => linear(256, 1, 64),
        Engine::Babylon => linear(256, 1, 32),
        Engine::Filament => Defaults {
            mapping: RoughnessMapping::Filament,
            ..linear(256, 16, 32)
        },
        Engine::Godot | Engine::Unity | Engine::Unreal => linear(512, 1, 32),
        Engine::Generic => linear(256, 1, 32),
    }
}

/// Packs the computed lighting as `engine` loads it.
pub fn pack(engine: Engine, l: &Lighting, ctx: &Context) -> Result<Delivery> {
    match engine {
        Engine::Bevy => bevy(l, ctx),
        Engine::Generic => generic(l, ctx),
        _ => Err(crate::Error::usage(format!(
            "--target {} is not available yet",
            engine.name()
        ))),
    }
}

/// A KTX2 cube map of `cube` in `format`, its levels described in the metadata.
fn ktx2(cube: &CubeMap, levels: Option<&LevelsFile>, format: GpuFormat) -> Vec<u8> {
    match levels {
        Some(d) => {
            let json = d.to_json();
            io::ktx2::encode_with_metadata(cube, format, &[(io::ktx2::LEVELS_KEY, &json)])
        }
        None => io::ktx2::encode(cube, format),
    }
}

fn describe(l: &Lighting) -> LevelsFile {
    LevelsFile::new(
        &ChainOptions::default(),
        l.specular.size(),
        l.levels.clone(),
    )
}

/// Counts texels the containers clamp.
fn clamped(path: &Path, format: GpuFormat, cubes: &[&CubeMap]) -> Option<String> {
    io::clamp_warning(
        path,
        FileFormat::Ktx2,
        format,
        cubes.iter().flat_map(|c| c.levels.iter().flatten()),
    )
}

fn bevy(l: &Lighting, ctx: &Context) -> Result<Delivery> {
    let format = ctx.opts.gpu_format.unwrap_or(GpuFormat::Rgba16f);
    let spec = ctx.path("_specular.ktx2");
    let diff = ctx.path("_diffuse.ktx2");
    let files = vec![
        (spec.clone(), ktx2(&l.specular, Some(&describe(l)), format)),
        (diff.clone(), ktx2(&l.diffuse, None, format)),
    ];
    let snippet = format!(
        r#"// Bevy: both files in assets/; the specular chain's level m holds roughness m / (levels - 1).
commands.spawn((
    Camera3d::default(),
    EnvironmentMapLight {{
        diffuse_map: asset_server.load("{d}"),
        specular_map: asset_server.load("{s}"),
        intensity: 1000.0, // cd/m^2 per unit of the map: match your exposure
        ..default()
    }},
));"#,
        d = file_name(&diff),
        s = file_name(&spec),
    );
    Ok(Delivery {
        clamped: clamped(&spec, format, &[&l.specular, &l.diffuse]),
        files,
        snippet,
        levels: Vec::new(),
    })
}

fn generic(l: &Lighting, ctx: &Context) -> Result<Delivery> {
    let format = ctx.opts.gpu_format.unwrap_or(GpuFormat::Rgba16f);
    let spec = ctx.path("_specular.ktx2");
    let diff = ctx.path("_diffuse.ktx2");
    let shp = ctx.path("_sh.json");
    let sh_json = serde_json::to_vec_pretty(&sh::ShFile::new(&l.sh)).unwrap_or_default();
    let files = vec![
        (spec.clone(), ktx2(&l.specular, Some(&describe(l)), format)),
        (diff.clone(), ktx2(&l.diffuse, None, format)),
        (shp.clone(), sh_json),
    ];
    let snippet = format!(
        "{s}: GGX chain, level m of L holds perceptual roughness m / (L - 1), alpha = roughness^2;\n\
         {d}: Lambertian irradiance over pi (multiply by the albedo);\n\
         {h}: the same diffuse term as 9 SH coefficients (irradiance_over_pi).",
        s = file_name(&spec),
        d = file_name(&diff),
        h = file_name(&shp),
    );
    Ok(Delivery {
        clamped: clamped(&spec, format, &[&l.specular, &l.diffuse]),
        files,
        snippet,
        levels: Vec::new(),
    })
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}
