//! `cubeforge preview`: a material on a sphere lit by an environment map, shaded by the
//! programs of The Cg Tutorial, chapter 7.

use super::{warn, Stages};
use cubeforge::ibl::{self, Engine};
use cubeforge::image::{srgb_to_linear, Image};
use cubeforge::io::{self, FileFormat, Limits, ReadOptions, WriteOptions};
use cubeforge::layout::Kind;
use cubeforge::preview::material::{self, Material, Model};
use cubeforge::preview::pbr::{self, PbrSetup};
use cubeforge::preview::{
    self, grid, Background, Control, LoadedEnv, Options, Parallax, ParallaxMode, Shading, Surface,
};
use cubeforge::tonemap::{self, Tonemap};
use cubeforge::{Error, Result};
use glam::{Vec3, Vec4};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
#[command(
    after_help = "Geometry: the unit sphere at the origin in cube-map space, the camera at \
    (0, 0, D) looking at the origin with +Y up (image right is -X, so the environment reads as \
    its face images do). Materials: reflect, refract and dispersion models of The Cg Tutorial \
    chapter 7, and pbr (glTF metallic-roughness, split-sum GGX + Lambert, a GGX chain \
    prefiltered in memory when ENV is not one); `--material list` prints the presets."
)]
pub struct Args {
    /// Environment: anything `convert` reads (panorama, cross, folder of faces, KTX2 or DDS
    /// with all its levels), or a folder m0/ m1/ ... written by `cubeforge prefilter`.
    #[arg(value_name = "ENV")]
    pub env: Option<PathBuf>,
    /// Output image: .png .jpg .tga (tone-mapped, sRGB) or .exr .hdr (linear radiance); -
    /// for standard output (with --format).
    #[arg(short, long, allow_hyphen_values = true)]
    pub output: Option<PathBuf>,
    /// File type of the output when it is - (standard output): png, jpg, tga, exr or hdr.
    #[arg(long)]
    pub format: Option<String>,
    /// Material: a preset (chrome, mirror-decal, glass, water, diamond, plastic, crystal; pbr,
    /// gold, copper, plastic-glossy, plastic-rough), a .toml material file, or `list` to print
    /// the presets.
    #[arg(short, long, default_value = "chrome")]
    pub material: String,
    /// Image edge in pixels (square; each cell of a --grid).
    #[arg(long, default_value_t = 512)]
    pub size: usize,
    /// Vertical field of view, degrees.
    #[arg(value_parser = super::finite_f32, long, default_value_t = 30.0)]
    pub fov: f32,
    /// Camera distance from the sphere's centre (the sphere has radius 1).
    #[arg(value_parser = super::finite_f32, long, default_value_t = 4.0)]
    pub distance: f32,
    /// Orbit the camera about +Y, degrees (90 puts it on +X, 180 on -Z).
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw: f32,
    /// Orbit the camera towards +Y, degrees (90 looks straight down).
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub pitch: f32,
    /// Compute the vectors per fragment (exact) or per vertex of a tessellated sphere
    /// (interpolated by the rasterizer, as section 7.2.5 compares).
    #[arg(long, value_enum, default_value_t = Shading::PerFragment)]
    pub shading: Shading,
    /// Latitude bands of the per-vertex sphere (longitude segments: twice as many).
    #[arg(long, default_value_t = 16)]
    pub tessellation: usize,
    /// Texture LOD bias added to the level a GPU would pick (needs a prefiltered chain).
    #[arg(value_parser = super::finite_f32, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub lod_bias: f32,
    /// LOD bias a control map's blur of 1 means, when its sidecar JSON does not say.
    #[arg(value_parser = super::finite_f32, long, default_value_t = 4.0)]
    pub max_lod_bias: f32,
    /// Radius of the environment (Brennan's correction for a finite distance; default: infinite).
    #[arg(value_parser = super::finite_f32, long, allow_hyphen_values = true)]
    pub env_radius: Option<f32>,
    /// Centre of the environment's sphere, X,Y,Z (with --env-radius; default 0,0,0).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub env_center: Option<Vec3>,
    /// Brennan's approximation normalize(V) + (P - C) / R, or the exact ray-sphere hit.
    #[arg(long, value_enum)]
    pub parallax: Option<ParallaxMode>,
    /// Decal texture on the sphere's (u, v) (default: the material's decal_color).
    #[arg(long)]
    pub decal: Option<PathBuf>,
    /// Control map from `cubeforge control`: R reflectivity, G transmittance, B blur, A Fresnel mask.
    #[arg(long)]
    pub control: Option<PathBuf>,
    /// Exposure in stops before tone mapping (tone-mapped outputs only).
    #[arg(value_parser = super::finite_f32, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f32,
    /// Tone curve for PNG, JPEG and TGA output (EXR and HDR stay linear).
    #[arg(long, value_enum, default_value_t = Tonemap::None)]
    pub tonemap: Tonemap,
    /// Background: env (the environment), transparent, black, white, grey, #RRGGBB (sRGB) or
    /// R,G,B (linear).
    #[arg(long, default_value = "env")]
    pub background: String,
    /// Samples per pixel, stratified (default 4 for tone-mapped output, 1 for EXR and HDR:
    /// each pixel the radiance through its centre).
    #[arg(long)]
    pub samples: Option<usize>,
    /// Contact sheet of several materials, e.g. chrome,glass,crystal (presets or .toml files).
    #[arg(long, value_delimiter = ',', conflicts_with = "grid_bias")]
    pub grid: Vec<String>,
    /// Contact sheet of one material at several LOD biases, e.g. 0,1,2,3.
    #[arg(value_parser = super::finite_f32, long, value_delimiter = ',', allow_hyphen_values = true)]
    pub grid_bias: Vec<f32>,
    /// Contact sheet of one pbr material at several roughness values, e.g. 0,0.25,0.5,0.75,1:
    /// one row (one per --grid-metallic value).
    #[arg(value_parser = super::finite_f32, long, value_delimiter = ',', conflicts_with_all = ["grid", "grid_bias"])]
    pub grid_roughness: Vec<f32>,
    /// Contact sheet of one pbr material at several metallic values, e.g. 0,1: one row each.
    #[arg(value_parser = super::finite_f32, long, value_delimiter = ',', conflicts_with_all = ["grid", "grid_bias"])]
    pub grid_metallic: Vec<f32>,
    /// pbr materials: read ENV's levels with this engine's roughness mapping (bevy, gltf,
    /// babylon, filament, generic) instead of its description (an ENV without a chain is
    /// prefiltered with that mapping).
    #[arg(long, value_enum)]
    pub target: Option<Engine>,
    /// Layout of ENV (detected from the aspect ratio; square images need sphere, angular or
    /// octahedral).
    #[arg(long, value_enum)]
    pub from: Option<Kind>,
    /// Refuse images with more pixels than this (checked before decoding).
    #[arg(long, default_value_t = Limits::default().max_pixels)]
    pub max_pixels: u64,
    /// Memory a command may plan to use, in bytes or with K, M, G (default: half the
    /// machine's memory, or of a container's limit or ulimit -v).
    #[arg(long, value_parser = super::bytes)]
    pub max_memory: Option<u64>,
}

fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let vals: Vec<f32> = parts
        .iter()
        .map(|p| p.parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("\"{s}\" is not X,Y,Z (three numbers)"))?;
    match vals.as_slice() {
        [x, y, z] if vals.iter().all(|v| v.is_finite()) => Ok(Vec3::new(*x, *y, *z)),
        _ => Err(format!("\"{s}\" is not X,Y,Z (three numbers)")),
    }
}

fn parse_background(s: &str) -> Result<Background> {
    let bad = || {
        Error::usage(format!(
            "--background {s}: use env, transparent, black, white, grey, #RRGGBB or R,G,B"
        ))
    };
    let t = s.trim().to_ascii_lowercase();
    Ok(match t.as_str() {
        "env" => Background::Env,
        "transparent" => Background::Color(Vec4::ZERO),
        "black" => Background::Color(Vec4::new(0.0, 0.0, 0.0, 1.0)),
        "white" => Background::Color(Vec4::ONE),
        "grey" | "gray" => Background::Color(Vec4::new(0.18, 0.18, 0.18, 1.0)),
        hex if hex.starts_with('#') => {
            let h = &hex[1..];
            if h.len() != 6 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
                return Err(bad());
            }
            let c = |i: usize| {
                srgb_to_linear(u8::from_str_radix(&h[i..i + 2], 16).unwrap_or(0) as f32 / 255.0)
            };
            Background::Color(Vec4::new(c(0), c(2), c(4), 1.0))
        }
        _ => {
            let v = parse_vec3(&t).map_err(|_| bad())?;
            if v.min_element() < 0.0 {
                return Err(bad());
            }
            Background::Color(v.extend(1.0))
        }
    })
}

pub fn run(a: Args, verbose: bool) -> Result<()> {
    if a.material == "list" {
        return super::say(material::list().trim_end());
    }
    let mut stages = Stages::new(verbose);
    let (Some(env_path), Some(output)) = (&a.env, &a.output) else {
        return Err(Error::usage(
            "preview needs an environment and an output: cubeforge preview ENV -o OUTPUT",
        ));
    };
    let plan = check(&a, output)?;
    let env = load_env(env_path, a.from, plan.limits)?;
    let mut inputs: Vec<PathBuf> = env.files.clone();
    let textures = load_textures(&a, &plan.materials, verbose, &mut inputs, &plan.limits)?;
    stages.done("decode");
    let split_sum = if plan.materials.iter().any(|m| m.model == Model::Pbr) {
        let setup = pbr::prepare(&env, env_path, a.target)?;
        if let Some(w) = &setup.warning {
            warn(w);
        }
        stages.done("split-sum");
        stages.note(&setup.note);
        Some(setup)
    } else {
        None
    };
    warn_without_chain(&a, env_path, &env, &plan.materials, &textures);
    let img = render_cells(&a, &plan, &env, split_sum.as_ref(), &textures)?;
    stages.done("render");
    write(&plan, &inputs, &img, &mut stages)?;
    stages.total();
    Ok(())
}

/// What the options ask for, all checked before the (possibly slow) decode.
struct Plan {
    output: PathBuf,
    to_stdout: bool,
    tone_mapped: bool,
    /// The material, or each of a --grid.
    materials: Vec<Material>,
    opts: Options,
    limits: Limits,
}

/// Checks everything that can be checked before anything is read, in the order the errors
/// are reported.
fn check(a: &Args, output: &Path) -> Result<Plan> {
    let (output, to_stdout) = super::output_name(output, a.format.as_deref())?;
    let tone_mapped = match FileFormat::from_extension(&output) {
        Some(f) if f.is_container() => {
            return Err(Error::file(
                &output,
                "the preview is an image: name it .png .jpg .tga .exr or .hdr",
            ))
        }
        Some(f) => super::tone_applies(
            &output,
            io::largest_value(f, Default::default()).is_none(),
            a.exposure,
            a.tonemap,
        ),
        None => return Err(io::unknown_ext(&output)),
    };
    let specs: Vec<String> = if a.grid.is_empty() {
        vec![a.material.clone()]
    } else {
        a.grid.clone()
    };
    let materials: Vec<Material> = specs
        .iter()
        .map(|s| material::resolve(s.trim()))
        .collect::<Result<_>>()?;
    check_pbr(a, &materials)?;
    if a.env_radius.is_none() && (a.env_center.is_some() || a.parallax.is_some()) {
        return Err(Error::usage(
            "--env-center and --parallax need --env-radius (the environment's distance)",
        ));
    }
    let opts = Options {
        size: a.size,
        fov: a.fov,
        distance: a.distance,
        yaw: a.yaw,
        pitch: a.pitch,
        shading: a.shading,
        tessellation: a.tessellation,
        lod_bias: a.lod_bias,
        parallax: a.env_radius.map(|radius| Parallax {
            radius,
            center: a.env_center.unwrap_or(Vec3::ZERO),
            mode: a.parallax.unwrap_or_default(),
        }),
        samples: a.samples.unwrap_or(if tone_mapped { 4 } else { 1 }),
        background: parse_background(&a.background)?,
    };
    opts.validate()?;
    // Finite already (its parser); it must also not be negative.
    if a.max_lod_bias < 0.0 {
        return Err(Error::usage("--max-lod-bias must be a number >= 0"));
    }
    let cells = a
        .grid
        .len()
        .max(a.grid_bias.len())
        .max(a.grid_roughness.len().max(1) * a.grid_metallic.len().max(1));
    let limits = super::limits(a.max_pixels, a.max_memory);
    // The picture (every cell of a grid) against the pixel limit, before anything is read.
    let pixels = (a.size as u64).saturating_mul(a.size as u64) * cells as u64;
    if pixels > limits.max_pixels {
        return Err(Error::usage(format!(
            "--size {} makes {pixels} pixels, over the limit of {} (--max-pixels)",
            a.size, limits.max_pixels
        )));
    }
    // Each cell's picture and its samples' buffers, RGBA f32, beside the environment as its
    // headers describe it (its decode's peak checked too): all before any file is decoded.
    let read = ReadOptions {
        limits,
        linear: false,
        as_stored: false,
    };
    let mut input = match &a.env {
        Some(env) => {
            cubeforge::chain::plan(std::slice::from_ref(env), a.from, &read)?.working_bytes()
        }
        None => 0,
    };
    // The textures on the sphere, kept while it renders: the decal, the control map, the
    // materials' own decals (the largest one's decode on top).
    let mut textures: Vec<&PathBuf> = a.decal.iter().chain(&a.control).collect();
    if a.decal.is_none() {
        textures.extend(materials.iter().filter_map(|m| m.decal.as_ref()));
    }
    textures.sort();
    textures.dedup();
    let mut peak = 0u64;
    for t in textures {
        if let Some(c) = io::claim(t, &read)? {
            input = input.saturating_add(c.held_bytes);
            peak = peak.max(c.decode_bytes - c.held_bytes.min(c.decode_bytes));
        }
    }
    input = input.saturating_add(peak);
    limits.check_memory(
        format_args!("--size {}", a.size),
        pixels.saturating_mul(16 * 3).saturating_add(input),
    )?;
    Ok(Plan {
        output,
        to_stdout,
        tone_mapped,
        materials,
        opts,
        limits,
    })
}

/// The pbr options: sweeps of a pbr material with values in [0, 1], a --target that applies.
fn check_pbr(a: &Args, materials: &[Material]) -> Result<()> {
    let sweeps = [
        ("--grid-roughness", &a.grid_roughness),
        ("--grid-metallic", &a.grid_metallic),
    ];
    for (name, values) in sweeps {
        if values.is_empty() {
            continue;
        }
        if materials[0].model != Model::Pbr {
            return Err(Error::usage(format!(
                "{name} needs a pbr material (pbr, gold, copper, plastic-glossy, plastic-rough or a file with model = \"pbr\"); \"{}\" has model \"{}\"",
                materials[0].name,
                materials[0].model.name()
            )));
        }
        if let Some(v) = values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
            return Err(Error::usage(format!(
                "{name} values must be between 0 and 1 (got {v})"
            )));
        }
    }
    if let Some(e) = a.target {
        if !materials.iter().any(|m| m.model == Model::Pbr) {
            return Err(Error::usage(
                "--target picks the roughness mapping a pbr material reads the chain with; the material is not pbr",
            ));
        }
        if ibl::engines::filters_itself(e) {
            return Err(Error::usage(format!(
                "--target {}: that engine prefilters the panorama itself, with a mapping of its own; use bevy, gltf, babylon, filament or generic",
                e.name()
            )));
        }
    }
    Ok(())
}

/// Reads the environment, warning about values replaced on read.
fn load_env(env_path: &Path, from: Option<Kind>, limits: Limits) -> Result<LoadedEnv> {
    let read = ReadOptions {
        limits,
        linear: false,
        as_stored: false,
    };
    let env = preview::load_environment(env_path, from, &read)?;
    if env.replaced_values > 0 {
        warn(format!(
            "{}: replaced {} NaN, infinite or negative values by 0 (and values above 1e28 by 1e28)",
            env_path.display(),
            env.replaced_values
        ));
    }
    Ok(env)
}

/// The textures on the sphere, each read once.
struct Textures {
    /// --decal, which overrides the materials' own.
    decal: Option<Image>,
    /// --control and the LOD bias its blur of 1 means.
    control: Option<(Image, f32)>,
    /// Decals named by material files.
    file_decals: Vec<(PathBuf, Image)>,
}

/// Reads the decal, the control map (and its sidecar) and the materials' decals, adding each
/// file to `inputs` (which the output must not overwrite).
fn load_textures(
    a: &Args,
    materials: &[Material],
    verbose: bool,
    inputs: &mut Vec<PathBuf>,
    limits: &Limits,
) -> Result<Textures> {
    let decal_img = a
        .decal
        .as_ref()
        .map(|p| preview::read_texture(p, false, limits))
        .transpose()?;
    inputs.extend(a.decal.iter().cloned());
    let control = match &a.control {
        Some(p) => {
            let (img, max, side) = preview::read_control(p, a.max_lod_bias, limits)?;
            inputs.push(p.clone());
            if verbose {
                match &side {
                    Some(s) => super::tell(format_args!(
                        "cubeforge: control map blur 1 = LOD bias {max} (from {})",
                        s.display()
                    )),
                    None => super::tell(format_args!(
                        "cubeforge: control map blur 1 = LOD bias {max} (--max-lod-bias)"
                    )),
                }
            }
            Some((img, max))
        }
        None => None,
    };
    // Decals named by material files, read once each.
    let mut file_decals: Vec<(PathBuf, Image)> = Vec::new();
    if decal_img.is_none() {
        for m in materials {
            if let Some(p) = &m.decal {
                if !file_decals.iter().any(|(q, _)| q == p) {
                    file_decals.push((p.clone(), preview::read_texture(p, false, limits)?));
                    inputs.push(p.clone());
                }
            }
        }
    }
    Ok(Textures {
        decal: decal_img,
        control,
        file_decals,
    })
}

/// Blur (a LOD bias, or a control map's) asked of an environment without a chain does nothing:
/// say so rather than render a sharp picture silently.
/// (pbr materials always sample a chain, made in memory when ENV has none.)
fn warn_without_chain(
    a: &Args,
    env_path: &Path,
    env: &LoadedEnv,
    materials: &[Material],
    textures: &Textures,
) {
    if materials.iter().all(|m| m.model == Model::Pbr) {
        return;
    }
    let wants_blur = a.lod_bias != 0.0
        || a.grid_bias.iter().any(|b| *b != 0.0)
        || textures
            .control
            .as_ref()
            .is_some_and(|(img, max)| *max > 0.0 && img.pixels.iter().any(|p| p.z > 0.0));
    if env.levels() == 1 && wants_blur {
        warn(format!(
            "{} has one level: LOD bias and blur need a prefiltered mip chain (make one with `cubeforge prefilter`); rendering without blur",
            env_path.display()
        ));
    }
}

/// The cells of a roughness / metallic sweep of `m`, row by row (one row per metallic value),
/// and the row's length.
fn sweep(a: &Args, m: &Material) -> (Vec<(Material, f32, String)>, usize) {
    let opt = |v: &[f32]| -> Vec<Option<f32>> {
        if v.is_empty() {
            vec![None]
        } else {
            v.iter().copied().map(Some).collect()
        }
    };
    let (metals, roughs) = (opt(&a.grid_metallic), opt(&a.grid_roughness));
    let mut jobs = Vec::new();
    for metal in &metals {
        for rough in &roughs {
            let mut cell = m.clone();
            let mut label = Vec::new();
            if let Some(v) = metal {
                cell.metallic = *v;
                label.push(format!("m {v}"));
            }
            if let Some(v) = rough {
                cell.roughness = *v;
                label.push(format!("r {v}"));
            }
            jobs.push((cell, a.lod_bias, label.join("  ")));
        }
    }
    (jobs, roughs.len())
}

/// One render per cell (materials, biases of the one material, or its roughness and metallic
/// values), tone-mapped when the output is; a grid becomes a contact sheet.
fn render_cells(
    a: &Args,
    plan: &Plan,
    env: &LoadedEnv,
    pbr_setup: Option<&PbrSetup>,
    textures: &Textures,
) -> Result<Image> {
    let materials = &plan.materials;
    let swept = !a.grid_roughness.is_empty() || !a.grid_metallic.is_empty();
    let mut columns = None;
    let jobs: Vec<(Material, f32, String)> = if swept {
        let (jobs, cols) = sweep(a, &materials[0]);
        columns = Some(cols);
        jobs
    } else if !a.grid_bias.is_empty() {
        a.grid_bias
            .iter()
            .map(|b| (materials[0].clone(), *b, format!("bias {b}")))
            .collect()
    } else {
        materials
            .iter()
            .map(|m| (m.clone(), a.lod_bias, m.name.clone()))
            .collect()
    };
    let mut rendered: Vec<(Image, String)> = Vec::with_capacity(jobs.len());
    for (m, bias, label) in jobs {
        let decal = textures.decal.as_ref().or_else(|| {
            m.decal.as_ref().and_then(|p| {
                textures
                    .file_decals
                    .iter()
                    .find(|(q, _)| q == p)
                    .map(|(_, i)| i)
            })
        });
        let surface = Surface {
            decal,
            control: textures.control.as_ref().map(|(img, max)| Control {
                map: img,
                max_lod_bias: *max,
            }),
        };
        let o = Options {
            lod_bias: bias,
            ..plan.opts
        };
        let bar = super::progress(o.size as u64, format!("preview {label}"));
        // pbr materials sample the GGX chain (perhaps made in memory), the others the map.
        let (sampler, split_sum) = match pbr_setup {
            Some(p) if m.model == Model::Pbr => (p.sampler(env), Some(&p.split_sum)),
            _ => (&env.sampler, None),
        };
        let mut img = preview::render_lit(sampler, split_sum, &m, &surface, &o, &|n| {
            if let Some(b) = &bar {
                b.inc(n);
            }
        })?;
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        if plan.tone_mapped {
            tonemap::apply(&mut img, a.tonemap, a.exposure);
        }
        rendered.push((img, label));
    }
    Ok(if let Some(cols) = columns {
        grid::contact_sheet_columns(&rendered, cols)
    } else if a.grid.is_empty() && a.grid_bias.is_empty() {
        rendered.swap_remove(0).0
    } else {
        grid::contact_sheet(&rendered)
    })
}

/// Encodes the picture and writes it (or sends it to standard output), refusing to overwrite
/// an input and warning about clamped values.
fn write(plan: &Plan, inputs: &[PathBuf], img: &Image, stages: &mut Stages) -> Result<()> {
    let output = &plan.output;
    cubeforge::output::refuse_inputs(std::slice::from_ref(output), inputs)?;
    if let Some(f) = io::FileFormat::from_extension(output) {
        if let Some(w) = io::clamp_warning(output, f, Default::default(), [img]) {
            super::warn(w);
        }
    }
    let bytes = io::encode_image(output, img, &WriteOptions::default())?;
    stages.done("encode");
    super::deliver(&[(output.clone(), bytes)], &[], plan.to_stdout)?;
    stages.done("write");
    Ok(())
}
