//! Each engine's files: sizes, orientation, containers and the snippet that loads them.

use super::{Defaults, Delivery, Engine, IblOptions, Lighting, RoughnessMapping};
use crate::chain::LevelsFile;
use crate::convert::Loaded;
use crate::cube::CubeMap;
use crate::error::Result;
use crate::filter::ChainOptions;
use crate::image::Image;
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
    /// The caller's turn, then the engine's view of cube-map space.
    pub orientation: Orientation,
}

impl Context<'_> {
    pub(super) fn path(&self, suffix: &str) -> PathBuf {
        self.out.join(format!("{}{suffix}", self.name))
    }

    /// Resamples the input as the engine sees it.
    pub(super) fn resampler(&self) -> crate::resample::Resampler {
        crate::resample::Resampler {
            orientation: self.orientation,
            ..crate::resample::Resampler::default()
        }
    }
}

/// The file that holds each engine's specular chain, by its suffix after the folder's name:
/// written here, and looked for by `folder::specular_of` (in this order) when a folder is
/// read back.
pub(super) const SPECULAR_FILES: [(&str, Engine); 4] = [
    (GLTF_SPECULAR, Engine::Gltf),
    (FILAMENT_SPECULAR, Engine::Filament),
    (BABYLON_SPECULAR, Engine::Babylon),
    (BEVY_SPECULAR, Engine::Bevy),
];
const GLTF_SPECULAR: &str = "_ggx.ktx2";
const FILAMENT_SPECULAR: &str = "_ibl.ktx";
const BABYLON_SPECULAR: &str = ".env";
/// Bevy's and the generic target's specular chain; the generic one has [`GENERIC_SH`] beside it.
const BEVY_SPECULAR: &str = "_specular.ktx2";
/// The generic target's SH file, which tells its folder from Bevy's.
pub(super) const GENERIC_SH: &str = "_sh.json";

/// The specular chain and the diffuse cube as KTX2 files `NAME{spec}` and `NAME{diff}`, in the
/// caller's format (RGBA16F by default): what bevy, gltf and generic all ship.
struct Ktx2Pair {
    spec: PathBuf,
    diff: PathBuf,
    format: GpuFormat,
    files: Vec<(PathBuf, Vec<u8>)>,
}

fn ktx2_pair(l: &Lighting, ctx: &Context, spec: &str, diff: &str) -> Result<Ktx2Pair> {
    let format = ctx.opts.encoding.gpu_format.unwrap_or(GpuFormat::Rgba16f);
    let (spec, diff) = (ctx.path(spec), ctx.path(diff));
    let files = vec![
        (
            spec.clone(),
            ktx2(&spec, &l.specular, Some(&describe(l)), format, ctx)?,
        ),
        (diff.clone(), ktx2(&diff, &l.diffuse, None, format, ctx)?),
    ];
    Ok(Ktx2Pair {
        spec,
        diff,
        format,
        files,
    })
}

/// Sizes, roughness mapping and orientation of each engine (the sources of each choice are
/// in docs/engines.md's `ibl` table).
pub fn defaults(engine: Engine) -> Defaults {
    let linear = |specular_size, min_size, diffuse_size| Defaults {
        specular_size,
        min_size,
        diffuse_size,
        mapping: RoughnessMapping::Linear,
        orientation: Orientation::default(),
    };
    match engine {
        // Bevy looks its cube maps up at (x, y, -z) of the world direction: the cube as is.
        Engine::Bevy => linear(512, 8, 32),
        // glTF-IBL-Sampler's cubes hold the panorama at u = 0.5 + atan2(z, x) / 2pi: X and Z
        // swapped, which is a mirror of X after a quarter turn; the Sample Viewer turns it back
        // with its default 90-degree environment rotation.
        Engine::Gltf => Defaults {
            orientation: Orientation {
                yaw: 90.0,
                mirror: true,
                ..Orientation::default()
            },
            ..linear(256, 16, 64)
        },
        // Babylon (left-handed) looks the cube up with the world direction: as is.
        Engine::Babylon => Defaults {
            mapping: RoughnessMapping::Babylon,
            ..linear(256, 1, 32)
        },
        // cmgen mirrors X by default, and Filament looks the cube up with the world direction.
        Engine::Filament => Defaults {
            mapping: RoughnessMapping::Filament,
            orientation: Orientation {
                mirror: true,
                ..Orientation::default()
            },
            ..linear(256, 16, 32)
        },
        // These filter the panorama themselves; sizes do not apply.
        Engine::Godot | Engine::Unity | Engine::Unreal => linear(512, 1, 32),
        // three.js's equirect mapping (`equirectUv`: u = 0.5 + atan2(z, x) / 2pi, v up) shows
        // a panorama un-mirrored in its right-handed world, its centre at +X: a quarter turn
        // puts the centre at +Z, as the other targets have it. PMREM makes faces of a quarter
        // of the width (a power of two, at least 256).
        Engine::Three => Defaults {
            orientation: Orientation {
                yaw: 90.0,
                ..Orientation::default()
            },
            ..linear(256, 1, 32)
        },
        Engine::Generic => linear(256, 8, 32),
    }
}

/// Packs the computed lighting as `engine` loads it.
pub fn pack(engine: Engine, l: &Lighting, ctx: &Context) -> Result<Delivery> {
    let mut delivery = match engine {
        Engine::Bevy => bevy(l, ctx)?,
        Engine::Gltf => gltf(l, ctx)?,
        Engine::Filament => filament(l, ctx)?,
        Engine::Babylon => babylon(l, ctx)?,
        Engine::Generic => generic(l, ctx)?,
        // Their panorama is all they take (`super::panorama`), made before any lighting.
        Engine::Godot | Engine::Unity | Engine::Unreal | Engine::Three => {
            return Err(crate::Error::usage(format!(
                "{} filters its panorama itself: there is no lighting to pack",
                engine.name()
            )))
        }
    };
    // What a lossy format (BC6H) kept of the mirror level, as convert -v reports it.
    let format = ctx.opts.encoding.gpu_format.unwrap_or_default();
    // The first file is the specular chain, a KTX2 for these engines.
    if let (true, Some((_, bytes))) = (format.is_lossy(), delivery.files.first()) {
        if matches!(engine, Engine::Bevy | Engine::Gltf | Engine::Generic) {
            let faces: Vec<&Image> = l.specular.levels[0].iter().collect();
            delivery.psnr = io::container_psnr(bytes, format, &faces);
        }
    }
    Ok(delivery)
}

/// A KTX2 cube map of `cube` in `format`, supercompressed when asked, its levels described in
/// the metadata with `--cubeforge-keys` (the engine's own mapping describes them otherwise).
fn ktx2(
    path: &Path,
    cube: &CubeMap,
    levels: Option<&LevelsFile>,
    format: GpuFormat,
    ctx: &Context,
) -> Result<Vec<u8>> {
    let keys = ctx.opts.encoding.cubeforge_keys;
    let json = levels.filter(|_| keys).map(LevelsFile::to_json);
    let extra: Vec<(&str, &[u8])> = json
        .as_deref()
        .map(|j| (io::ktx2::LEVELS_KEY, j))
        .into_iter()
        .collect();
    io::ktx2::encode_cube_with(cube, format, ctx.opts.encoding.zstd, &extra)
        .map_err(|e| crate::Error::file(path, e))
}

/// Refuses --zstd for targets whose containers have no supercompression.
fn no_zstd(ctx: &Context, what: &str) -> Result<()> {
    match ctx.opts.encoding.zstd {
        Some(_) => Err(crate::Error::usage(format!(
            "{} supercompresses KTX2; {what} has none",
            crate::error::param("zstd")
        ))),
        None => Ok(()),
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
    let Ktx2Pair {
        spec,
        diff,
        format,
        files,
    } = ktx2_pair(l, ctx, BEVY_SPECULAR, "_diffuse.ktx2")?;
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
    Ok(Delivery::new(
        files,
        snippet,
        clamped(&spec, format, &[&l.specular, &l.diffuse]),
    ))
}

/// A 16-bit linear PNG of a lookup table (`charlie`: the sheen table, else the GGX DFG).
/// Each table depends on nothing and takes a quarter of a second: made once per process, so a
/// batch's glTF and Three.js jobs share it.
fn lut_png(path: &Path, charlie: bool) -> Result<Vec<u8>> {
    static MADE: [std::sync::OnceLock<Vec<u8>>; 2] =
        [std::sync::OnceLock::new(), std::sync::OnceLock::new()];
    let made = &MADE[usize::from(charlie)];
    if let Some(bytes) = made.get() {
        return Ok(bytes.clone());
    }
    let bytes = make_lut_png(path, charlie)?;
    Ok(made.get_or_init(|| bytes).clone())
}

fn make_lut_png(path: &Path, charlie: bool) -> Result<Vec<u8>> {
    let opts = crate::lut::LutOptions::default();
    let img = if charlie {
        crate::lut::charlie(crate::lut::DEFAULT_SIZE, &opts)
    } else {
        crate::lut::dfg(crate::lut::DEFAULT_SIZE, &opts)
    };
    let write = io::WriteOptions {
        linear: true,
        png16: true,
        ..io::WriteOptions::default()
    };
    crate::output::encode_image_as(FileFormat::Png, path, &img, &write)
}

fn gltf(l: &Lighting, ctx: &Context) -> Result<Delivery> {
    let Ktx2Pair {
        spec,
        diff,
        format,
        mut files,
    } = ktx2_pair(l, ctx, GLTF_SPECULAR, "_lambertian.ktx2")?;
    let lut = ctx.out.join("lut_ggx.png");
    files.push((lut.clone(), lut_png(&lut, false)?));
    let mut cubes = vec![&l.specular, &l.diffuse];
    let mut sheen_line = String::new();
    if let Some((chain, levels)) = &l.sheen {
        let path = ctx.path("_charlie.ktx2");
        let d = LevelsFile::new(
            &ChainOptions {
                filter: crate::filter::FilterKind::Charlie,
                ..ChainOptions::default()
            },
            chain.size(),
            levels.clone(),
        );
        files.push((path.clone(), ktx2(&path, chain, Some(&d), format, ctx)?));
        let lut_c = ctx.out.join("lut_charlie.png");
        files.push((lut_c.clone(), lut_png(&lut_c, true)?));
        cubes.push(chain);
        sheen_line = format!(
            ",\nu_CharlieEnvSampler = {}, u_CharlieLUT = {} (the sheen albedo E in every channel, clamped at 1 as the Sample Viewer's own table)",
            file_name(&path),
            file_name(&lut_c)
        );
    }
    let snippet = format!(
        "glTF (Khronos glTF Sample Viewer, glTF-IBL-Sampler's files and orientation):\n\
         u_GGXEnvSampler = {s} ({n} levels, lod = roughness * (u_MipCount - 1)),\n\
         u_LambertianEnvSampler = {d}, u_GGXLUT = {t} (R scale, G bias; uv = (n.v, roughness),\n\
         16-bit linear){sheen_line};\n\
         keep u_EnvRotation at its default 90 degrees about +Y (the panorama's centre then faces\n\
         world +Z, the front of glTF assets).",
        s = file_name(&spec),
        d = file_name(&diff),
        t = file_name(&lut),
        n = l.specular.levels.len(),
    );
    Ok(Delivery::new(
        files,
        snippet,
        clamped(&spec, format, &cubes),
    ))
}

fn filament(l: &Lighting, ctx: &Context) -> Result<Delivery> {
    use io::ktx1::{self, KeyValue, Ktx1Format};
    // cmgen's own format: R11F_G11F_B10F.
    let gpu = ctx.opts.encoding.gpu_format.unwrap_or(GpuFormat::Rg11b10);
    let format = Ktx1Format::from_gpu(gpu).map_err(crate::Error::usage)?;
    let sh = crate::filter::sh_engines::filament_sh(&l.sh);
    let levels_json = describe(l).to_json();
    let ibl = ctx.path(FILAMENT_SPECULAR);
    let irr = ctx.path("_irradiance.ktx");
    let sky = ctx.path("_skybox.ktx");
    let sh_txt = ctx.out.join("sh.txt");
    let enc = |cube: &CubeMap, kv: &[KeyValue], path: &Path| {
        ktx1::encode(cube, format, kv).map_err(|e| crate::Error::file(path, e))
    };
    let ibl_bytes = enc(
        &l.specular,
        &[
            ktx1::sh_key_value(&sh),
            KeyValue {
                key: io::ktx2::LEVELS_KEY.into(),
                value: levels_json,
            },
        ],
        &ibl,
    )?;
    let irr_bytes = enc(&l.diffuse, &[], &irr)?;
    // The skybox is the environment itself at the input's resolution, turned as the chain is.
    let sky_size = ctx
        .loaded
        .face_size()
        .clamp(l.specular.size().min(2048), 2048);
    let skybox = crate::convert::to_cube(ctx.loaded, sky_size, &ctx.resampler());
    let sky_bytes = enc(&skybox, &[], &sky)?;
    let names = [
        "L00", "L1-1", "L10", "L11", "L2-2", "L2-1", "L20", "L21", "L22",
    ];
    let mut text = String::new();
    for (c, name) in sh.iter().zip(names) {
        text.push_str(&format!(
            "({:>12.9}, {:>12.9}, {:>12.9}); // {name}, irradiance, pre-scaled base\n",
            c[0], c[1], c[2]
        ));
    }
    let snippet = format!(
        r#"// Filament (as cmgen --deploy): roughness r sits at lod = (levels - 1) * r * (2 - r).
// C++: iblData/skyData hold the files' bytes; createTexture takes (and frees) each bundle.
auto* iblBundle = new image::Ktx1Bundle(iblData, iblSize);   // {i}
auto* skyBundle = new image::Ktx1Bundle(skyData, skySize);   // {k}
filament::math::float3 sh[9];
iblBundle->getSphericalHarmonics(sh);   // the "sh" key (also in sh.txt)
filament::Texture* reflections = ktxreader::Ktx1Reader::createTexture(engine, iblBundle, false);
filament::Texture* skyTexture = ktxreader::Ktx1Reader::createTexture(engine, skyBundle, false);
filament::IndirectLight* light = filament::IndirectLight::Builder().reflections(reflections).irradiance(3, sh).intensity(30000.0f).build(*engine);
filament::Skybox* sky = filament::Skybox::Builder().environment(skyTexture).build(*engine);
scene->setIndirectLight(light);
scene->setSkybox(sky);

// JavaScript (npm filament), after Filament.init(['{i}', '{k}'], ...): createIblFromKtx1
// lights with the reflections alone, so the "sh" key is read and passed here.
const reflections = engine.createTextureFromKtx1('{i}');
const sh = new Filament.Ktx1Bundle(Filament.Buffer(Filament.assets['{i}'])).getMetadata('sh').split(/\s+/, 27).map(parseFloat);
const light = Filament.IndirectLight.Builder().reflections(reflections).irradianceSh(3, sh).intensity(30000).build(engine);
scene.setIndirectLight(light);
scene.setSkybox(engine.createSkyFromKtx1('{k}'));"#,
        i = file_name(&ibl),
        k = file_name(&sky),
    );
    let all: Vec<&Image> = [&l.specular, &l.diffuse, &skybox]
        .into_iter()
        .flat_map(|c| c.levels.iter().flatten())
        .collect();
    Ok(Delivery {
        clamped: io::clamp_warning(&ibl, FileFormat::Ktx1, gpu, all),
        files: vec![
            (ibl, ibl_bytes),
            (irr, irr_bytes),
            (sky, sky_bytes),
            (sh_txt, text.into_bytes()),
        ],
        snippet,
        levels: Vec::new(),
        psnr: None,
    })
}

fn babylon(l: &Lighting, ctx: &Context) -> Result<Delivery> {
    use crate::filter::sh_engines::SphericalPolynomial;
    use io::babylon_env;
    no_zstd(ctx, "Babylon's .env")?;
    if ctx.opts.encoding.gpu_format.is_some() {
        return Err(crate::Error::usage(format!(
            "{}: Babylon's .env holds RGBD PNG faces only",
            crate::error::param("gpu_format")
        )));
    }
    let path = ctx.path(BABYLON_SPECULAR);
    let poly = SphericalPolynomial::from_radiance_sh(&l.sh);
    let bytes = babylon_env::encode(
        &l.specular,
        Some(&poly.coefficients()),
        babylon_env::DEFAULT_LOD_GENERATION_SCALE,
    )
    .map_err(crate::Error::usage)?;
    let snippet = format!(
        r#"// Babylon.js: level m holds GGX alpha = 2^(m / 0.8) / width, what lodGenerationScale 0.8 reads.
scene.environmentTexture = BABYLON.CubeTexture.CreateFromPrefilteredData("{f}", scene);
scene.createDefaultSkybox(scene.environmentTexture, true);"#,
        f = file_name(&path),
    );
    Ok(Delivery {
        clamped: io::clamp_warning(
            &path,
            FileFormat::Env,
            GpuFormat::Rgba16f,
            l.specular.levels.iter().flatten(),
        ),
        files: vec![(path, bytes)],
        snippet,
        levels: Vec::new(),
        psnr: None,
    })
}

fn generic(l: &Lighting, ctx: &Context) -> Result<Delivery> {
    let Ktx2Pair {
        spec,
        diff,
        format,
        mut files,
    } = ktx2_pair(l, ctx, BEVY_SPECULAR, "_diffuse.ktx2")?;
    let shp = ctx.path(GENERIC_SH);
    let dfg = ctx.path("_dfg.png");
    let sh_json =
        serde_json::to_vec_pretty(&crate::filter::sh_bands::ShFile::new(&l.sh)).unwrap_or_default();
    files.push((shp.clone(), sh_json));
    files.push((dfg.clone(), lut_png(&dfg, false)?));
    let snippet = format!(
        "{s}: GGX chain, level m of L holds perceptual roughness m / (L - 1), alpha = roughness^2;\n\
         {d}: Lambertian irradiance over pi (multiply by the albedo);\n\
         {h}: the same diffuse term as 9 SH coefficients (irradiance_over_pi);\n\
         {g}: split-sum DFG, R scale and G bias of F0 at uv = (n.v, roughness), 16-bit linear.",
        g = file_name(&dfg),
        s = file_name(&spec),
        d = file_name(&diff),
        h = file_name(&shp),
    );
    Ok(Delivery::new(
        files,
        snippet,
        clamped(&spec, format, &[&l.specular, &l.diffuse]),
    ))
}

pub(super) fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}
