//! `cubeforge preview`: a material on a sphere lit by an environment map, shaded by the
//! programs of The Cg Tutorial, chapter 7.

use cubeforge::internals::ibl::Engine;
use cubeforge::internals::image::srgb_to_linear;
use cubeforge::internals::io::FileFormat;
use cubeforge::internals::layout::Kind;
use cubeforge::internals::preview::material;
use cubeforge::internals::preview::{
    Background, Options, Parallax, ParallaxMode, Refraction, Shading,
};
use cubeforge::internals::tonemap::Tonemap;
use cubeforge::{Error, PreviewJob, Result};
use glam::{Vec3, Vec4};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = format!("{GEOMETRY}\n\n{EXAMPLES}"))]
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
    /// Refract and dispersion materials: the texts' one refraction at the front (texts), or
    /// the solid sphere's path, in at the front and out at the back with the Fresnel split at
    /// each surface and the bounces inside, per channel for dispersion (exact; per fragment).
    /// A material file's `refraction = "texts"|"exact"` wins over it.
    #[arg(long, value_enum, default_value_t = Refraction::Texts)]
    pub refraction: Refraction,
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
    /// Exposure in stops: radiance scaled by 2^EV, before the tone curve of PNG, JPEG and TGA
    /// output (EXR and HDR keep it linear, scaled).
    #[arg(value_parser = super::exposure, long, value_name = "EV", default_value_t = 0.0, allow_hyphen_values = true)]
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
    /// pbr materials: take ENV's sun out of the map and shine it as a directional light
    /// (Lambert and GGX), as `ibl --sun` hands it to an engine.
    #[arg(long)]
    pub sun: bool,
    /// pbr materials: a grey floor under the sphere, lit by the map and the sun (--sun), with
    /// the sphere's shadow.
    #[arg(long)]
    pub ground: bool,
    /// Layout of ENV (detected from the aspect ratio; square images need sphere, angular or
    /// octahedral).
    #[arg(long, value_enum)]
    pub from: Option<Kind>,
    #[command(flatten)]
    pub limits: super::LimitArgs,
}

const GEOMETRY: &str = "Geometry: the unit sphere at the origin in cube-map space, the camera at \
(0, 0, D) looking at the origin with +Y up (image right is -X, so the environment reads as \
its face images do). Materials: reflect, refract and dispersion models of The Cg Tutorial \
chapter 7, and pbr (glTF metallic-roughness, split-sum GGX + Lambert, a GGX chain \
prefiltered in memory when ENV is not one); `--material list` prints the presets.";

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # a chrome ball lit by the panorama
  cubeforge preview panorama.hdr -o chrome.png
  # three of the Cg Tutorial's materials side by side
  cubeforge preview panorama.hdr -o sheet.png --grid chrome,glass,crystal
  # a solid glass ball: refracted in and out, reflections and bounces inside (a lens)
  cubeforge preview panorama.hdr -o glass.png -m glass --refraction exact
  # glTF metallic-roughness (split-sum GGX) at three roughness values
  cubeforge preview panorama.hdr -o pbr.png -m pbr --grid-roughness 0,0.5,1";

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

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<PreviewJob> {
    let (Some(env), Some(output)) = (a.env, a.output) else {
        return Err(Error::usage(
            "preview needs an environment and an output: cubeforge preview ENV -o OUTPUT",
        ));
    };
    // An `ibl` output folder: its specular chain (or panorama), as `view` shows it; a pbr
    // material reads the chain by the engine --target names.
    let env = cubeforge::internals::ibl::specular_of(&env).map_or(env, |(file, _)| file);
    let output = super::destination(&output, a.format.as_deref(), FileFormat::is_image)?;
    if a.env_radius.is_none() && (a.env_center.is_some() || a.parallax.is_some()) {
        return Err(Error::usage(
            "--env-center and --parallax need --env-radius (the environment's distance)",
        ));
    }
    let view = Options {
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
        samples: a
            .samples
            .unwrap_or_else(|| PreviewJob::default_samples(&output)),
        background: parse_background(&a.background)?,
        refraction: a.refraction,
        ground: a.ground,
    };
    let job = PreviewJob {
        from: a.from,
        material: a.material,
        grid: a.grid,
        grid_bias: a.grid_bias,
        grid_roughness: a.grid_roughness,
        grid_metallic: a.grid_metallic,
        view,
        decal: a.decal,
        control: a.control,
        max_lod_bias: a.max_lod_bias,
        tone: (a.exposure, a.tonemap),
        target: a.target,
        sun: a.sun,
        limits: a.limits.limits(),
        ..PreviewJob::new(env, output)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    if a.material == "list" {
        return super::say(material::list().trim_end());
    }
    let output = a.output.clone().unwrap_or_default();
    super::execute(job(a)?, &output, verbose, depfile)
}
