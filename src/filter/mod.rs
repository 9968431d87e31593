//! Prefiltered mip chains (box, LOD-bias Gaussian, cosine power, GGX, Charlie sheen) and the diffuse side
//! (irradiance, spherical harmonics). Every filter samples the same seamless cube map.

#![warn(missing_docs)]

mod bright;
pub mod brute;
mod diffuse;
mod hybrid;
pub mod lobe;
mod roughness;
pub mod sh;
pub mod sh_bands;
pub mod sh_engines;
mod shape;
mod window;

pub use diffuse::{
    brute_irradiance_with_progress, irradiance, irradiance_with_progress, IrradianceLight,
    IrradianceMethod, IRRADIANCE_LIGHT_SIZE,
};
pub(crate) use roughness::plan_mapped;
pub use roughness::{RoughnessMapping, BABYLON_LOD_GENERATION_SCALE};

use crate::cube::{CubeMap, Faces};
use bright::BrightSum;
use lobe::{Kernel, Lobe};
use serde::{Deserialize, Serialize};

/// The filters of `cubeforge prefilter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum FilterKind {
    /// Plain mipmaps: each level the solid-angle-weighted 2x2 mean of the one above.
    Box,
    /// LOD-bias blur: level m is the base convolved with a Gaussian as wide as its texels.
    Gaussian,
    /// Phong / cosine-power lobes, cmft's gloss scale and bias mapping of level to power.
    Cosine,
    /// Split-sum GGX radiance: level m has roughness m / (levels - 1).
    Ggx,
    /// Charlie sheen radiance (the Khronos glTF-IBL-Sampler's): level m has roughness
    /// m / (levels - 1).
    Charlie,
}

impl FilterKind {
    /// The name on the command line and in `levels.json`.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Box => "box",
            FilterKind::Gaussian => "gaussian",
            FilterKind::Cosine => "cosine",
            FilterKind::Ggx => "ggx",
            FilterKind::Charlie => "charlie",
        }
    }
}

/// cmft's lighting models: how a gloss level's specular power is adjusted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum LightingModel {
    /// The power as cmft's mapping gives it.
    #[default]
    Phong,
    /// Phong with the n.l factor folded in: power + 1.
    Phongbrdf,
    /// Blinn-Phong expressed around the reflection vector: power / 4.
    Blinn,
    /// power / 4 + 1.
    Blinnbrdf,
}

impl LightingModel {
    /// The specular power this model uses for a level of mapped power `power`.
    pub fn apply(self, power: f32) -> f32 {
        match self {
            LightingModel::Phong => power,
            LightingModel::Phongbrdf => power + 1.0,
            LightingModel::Blinn => power / 4.0,
            LightingModel::Blinnbrdf => power / 4.0 + 1.0,
        }
    }
}

/// What to build.
#[derive(Clone, Copy, Debug)]
pub struct ChainOptions {
    /// Which filter makes each level after the first.
    pub filter: FilterKind,
    /// Level count (None: down to 1 x 1).
    pub levels: Option<usize>,
    /// Stop at the level whose faces are this many texels (the smallest at least this
    /// large when the sizes skip it): a 1 x 1 roughness-1 level shows the cube's corners when
    /// sampled at a high LOD bias, so Filament stops at 16. The roughness mapping m / (L - 1)
    /// spans the shortened chain: roughness 1 at its last level. None: no floor. With
    /// `levels` too, the shorter chain wins.
    pub min_size: Option<usize>,
    /// Importance samples per texel at the first filtered level (gaussian, cosine, ggx;
    /// charlie takes 4 times as many), doubled per level after it up to 32 times.
    pub samples: u32,
    /// Cosine only: how fast power rises with glossiness (power = 2^(scale * gloss + bias)).
    pub gloss_scale: f32,
    /// Cosine only: the power exponent at glossiness 0 (the last level).
    pub gloss_bias: f32,
    /// Cosine only: how each level's power is adjusted.
    pub lighting: LightingModel,
}

impl Default for ChainOptions {
    fn default() -> Self {
        ChainOptions {
            filter: FilterKind::Ggx,
            levels: None,
            min_size: None,
            samples: DEFAULT_SAMPLES,
            gloss_scale: 10.0,
            gloss_bias: 1.0,
            lighting: LightingModel::Phong,
        }
    }
}

/// Where `prefilter` chains stop when no floor is given: 16 px faces, as Filament's cmgen and
/// its `IBLPrefilterContext` do. Below that a level is so coarse that sampling it at a high LOD
/// bias shows the cube's faces as flat patches with a box outline on a chrome ball.
pub const DEFAULT_MIN_SIZE: usize = 16;

/// Importance samples per texel when none are asked for: enough for smooth GGX levels at interactive sizes.
pub const DEFAULT_SAMPLES: u32 = 64;

/// Texels brighter than this many times the mean luminance are convolved exactly.
pub(crate) const BRIGHT_RATIO: f32 = 64.0;

/// What one level holds, for levels.json and container metadata.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelInfo {
    /// Mip level, 0 the largest.
    pub level: usize,
    /// Face edge of this level, texels.
    pub size: usize,
    /// The chain's filter (level 0 is the source for every filter but box).
    pub filter: FilterKind,
    /// GGX and Charlie: perceptual roughness, level / (levels - 1).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub roughness: Option<f32>,
    /// GGX and Charlie: alpha = roughness^2, the value the distribution takes.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub alpha: Option<f32>,
    /// Cosine: the specular power after the lighting model.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub power: Option<f32>,
    /// Gaussian standard deviation, radians.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub sigma: Option<f32>,
    /// Importance samples per texel (None: the level was copied or box-reduced, or its narrow
    /// cosine or Gaussian lobe summed exactly over the texels it covers; for a glossy GGX
    /// level, those of its tail: its core is summed exactly).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub samples: Option<u32>,
    /// How far the final rescale to the base's flux moved the level (the largest channel's
    /// factor minus 1), for the tests that report it; not written to files.
    #[serde(skip)]
    pub rescale: Option<f32>,
}

/// cmft's mapping of a level to a specular power: glossiness falls linearly from 1 at level
/// 0 to 0 at the last level, power = 2^(scale * glossiness + bias).
pub(crate) fn specular_power(level: usize, count: usize, scale: f32, bias: f32) -> f32 {
    let gloss = (1.0 - level as f32 / (count as f32 - (1.0 + 1e-7))).max(0.0);
    2f32.powf(scale * gloss + bias)
}

use crate::cube::texel_angle;

impl ChainOptions {
    /// How many levels a chain from a base of face edge `base` gets: `levels`, at most the
    /// full chain, cut at `min_size`; at least 1.
    pub fn level_count(&self, base: usize) -> usize {
        let full = CubeMap::full_chain_len(base);
        let mut count = self.levels.unwrap_or(usize::MAX).clamp(1, full);
        if let Some(min) = self.min_size {
            let keep = (0..full).take_while(|&m| (base >> m).max(1) >= min).count();
            count = count.min(keep.max(1));
        }
        count
    }
}

/// A level's work, for progress bars: an exact sum costs about what 64 samples do.
pub fn level_cost(i: &LevelInfo) -> u64 {
    let per_texel = match (i.samples, i.power.or(i.sigma)) {
        (Some(s), _) => s as u64,
        (None, Some(_)) => 64,
        _ => 1,
    };
    (6 * i.size * i.size) as u64 * per_texel
}

/// Per-level lobes (None: the level is copied or box-reduced, not convolved).
pub fn plan(opts: &ChainOptions, base: usize) -> Vec<(LevelInfo, Option<Lobe>)> {
    let count = opts.level_count(base);
    let mut plan: Vec<(LevelInfo, Option<Lobe>)> = (0..count)
        .map(|m| {
            let size = (base >> m).max(1);
            let mut info = LevelInfo {
                level: m,
                size,
                filter: opts.filter,
                roughness: None,
                alpha: None,
                power: None,
                sigma: None,
                samples: None,
                rescale: None,
            };
            let lobe = match opts.filter {
                FilterKind::Box => None,
                FilterKind::Gaussian => {
                    let sigma = texel_angle(size);
                    info.sigma = Some(sigma);
                    Some(Lobe::Gaussian { sigma })
                }
                FilterKind::Cosine => {
                    let p = opts.lighting.apply(specular_power(
                        m,
                        count,
                        opts.gloss_scale,
                        opts.gloss_bias,
                    ));
                    info.power = Some(p);
                    Some(Lobe::CosinePower { power: p })
                }
                FilterKind::Ggx | FilterKind::Charlie => {
                    let r = if count > 1 {
                        m as f32 / (count - 1) as f32
                    } else {
                        0.0
                    };
                    info.roughness = Some(r);
                    info.alpha = Some(r * r);
                    // Level 0 is the mirror: the source itself. (Charlie at roughness 0 is a
                    // distribution on the horizon of h; the Khronos sampler's level 0 comes
                    // down to the mirror lookup too: its only sample above n.l = 0 is h = n.)
                    let alpha = r * r;
                    (m > 0).then_some(if opts.filter == FilterKind::Ggx {
                        Lobe::Ggx { alpha }
                    } else {
                        Lobe::Charlie { alpha }
                    })
                }
            };
            (info, lobe)
        })
        .collect();
    // Wider lobes need more samples for the same accuracy, and smaller levels can afford them:
    // double per level from the first convolved one, up to 32 times the base count. Charlie's
    // lobe is a ring around the axis, spread over far more of the sphere than a GGX lobe of
    // the same roughness: it starts at 4 times the count (next to a 10^5 sun, 64 samples
    // were 10% off the exact convolution, 256 2.4%, as GGX with 64).
    let start = opts
        .samples
        .max(1)
        .saturating_mul(if opts.filter == FilterKind::Charlie {
            4
        } else {
            1
        });
    let first = plan.iter().position(|(_, l)| l.is_some()).unwrap_or(0);
    let source_levels = CubeMap::full_chain_len(base);
    for (info, lobe) in &mut plan {
        // Narrow cosine and Gaussian lobes are summed exactly: no samples.
        if lobe.is_some_and(|l| window::Window::plan(l, base, source_levels).is_none()) {
            let doublings = (info.level - first).min(5) as u32;
            info.samples = Some(start.saturating_mul(1 << doublings));
        }
    }
    plan
}

/// Builds the chain from a base cube map (level 0 at the output size). Calls `progress` once
/// per finished level with its index.
pub fn prefilter(
    base: &CubeMap,
    opts: &ChainOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> (CubeMap, Vec<LevelInfo>) {
    let plan = plan(opts, base.size());
    prefilter_planned(base, opts, plan, progress)
}

/// [`prefilter_planned`] that reports to `progress`: one bar named after the filter and the
/// base size, advanced by each finished level's [`level_cost`].
pub fn prefilter_reported(
    base: &CubeMap,
    opts: &ChainOptions,
    plan: Vec<(LevelInfo, Option<Lobe>)>,
    progress: &dyn crate::progress::Progress,
) -> (CubeMap, Vec<LevelInfo>) {
    let costs: Vec<u64> = plan.iter().map(|(i, _)| level_cost(i)).collect();
    let label = format!("{} {}", opts.filter.name(), base.size());
    progress.start(costs.iter().sum(), &label);
    let out = prefilter_planned(base, opts, plan, &|level| progress.advance(costs[level]));
    progress.finish();
    out
}

/// [`prefilter`] with a plan the caller adjusted (e.g. another roughness per level).
pub fn prefilter_planned(
    base: &CubeMap,
    opts: &ChainOptions,
    plan: Vec<(LevelInfo, Option<Lobe>)>,
    progress: &(dyn Fn(usize) + Sync),
) -> (CubeMap, Vec<LevelInfo>) {
    let n = base.size();
    if opts.filter == FilterKind::Box {
        let chain = CubeMap {
            levels: vec![base.levels[0].clone()],
        }
        .with_box_mips(Some(plan.len()));
        (0..plan.len()).for_each(progress);
        return (chain, plan.into_iter().map(|(i, _)| i).collect());
    }
    // An HDR sun is convolved exactly; the sampled filters see the rest, at most
    // BRIGHT_RATIO times the mean luminance, so no tap can turn into a firefly.
    let (mut residual, bright) = bright::split_bright(base, BRIGHT_RATIO);
    // Alpha 1 everywhere: the filters carry their weights' total in it (see `by_weight`).
    opaque(&mut residual.levels[0]);
    let src = lobe::source_sampler(&residual);
    // A filter normalised over the sphere keeps the mean radiance: each level's is this.
    let flux = crate::flux::mean_radiance(
        crate::flux::Grid::Cube(n),
        &base.levels[0].iter().collect::<Vec<_>>(),
    );
    // Each level's faces, and the samples it took where that differs from the plan's.
    let levels: Vec<(Faces, (Option<u32>, f32))> = {
        use rayon::prelude::*;
        plan.par_iter()
            .map(|(info, lobe)| {
                let mut samples = info.samples;
                // A small level is filtered at FINE_SIZE, then each texel becomes the
                // solid-angle-weighted mean of those it covers: the filtered radiance over its
                // whole patch, not at its centre, so the level keeps the light.
                let size = fine_size_for(info.size, *lobe);
                let faces = match lobe {
                    None => copy_faces(&base.levels[0]),
                    Some(l) => match exact_window(*l, n, src.level_count(), size, info.size) {
                        Some(w) => {
                            samples = None;
                            window::filter_level(&src, &w, size, &BrightSum::new(&bright, *l))
                        }
                        None => {
                            let count = small_level_samples(
                                info.samples.unwrap_or(opts.samples),
                                info.size,
                            );
                            samples = Some(count);
                            match hybrid::Hybrid::plan(*l, count, n, src.level_count()) {
                                Some(h) => {
                                    samples = Some(h.samples);
                                    h.filter_level(&src, size, &bright)
                                }
                                None => {
                                    let k = Kernel::new(*l, count, n);
                                    lobe::filter_level(&src, &k, size, *l, &bright)
                                }
                            }
                        }
                    },
                };
                let faces = reduce_to(faces, info.size);
                let faces = if lobe.is_some() {
                    by_weight(faces)
                } else {
                    faces
                };
                // A copy of the base has its flux to the bit: its factor would be exactly 1
                // (a 512 px level 0 spent a sum and a pass over 25 MB finding that out).
                let (faces, rescale) = match lobe {
                    Some(_) => keep_flux(faces, flux),
                    None => (faces, 0.0),
                };
                progress(info.level);
                (faces, (samples, rescale))
            })
            .collect()
    };
    let (levels, done): (Vec<Faces>, Vec<(Option<u32>, f32)>) = levels.into_iter().unzip();
    let infos = plan
        .into_iter()
        .zip(done)
        .map(|((info, _), (samples, rescale))| LevelInfo {
            samples,
            rescale: Some(rescale),
            ..info
        })
        .collect();
    (CubeMap { levels }, infos)
}

/// The exact sum for a level of `lobe` filtered at `size` from a source of edge `src_size`:
/// a window, or the whole lobe where that is cheap and reads a finer source (a small level's
/// window runs on one only 1.4 lobe widths per texel: the Gaussian's level 2 of a 64 px chain
/// was 0.78% off brute force, whole 0.37%); lobes no window holds, whole within
/// [`window::WHOLE_BUDGET`]; None: sampled.
fn exact_window(
    lobe: Lobe,
    src_size: usize,
    levels: usize,
    size: usize,
    level_size: usize,
) -> Option<window::Window> {
    use window::{Window, CHARLIE_WHOLE_BUDGET, SMALL_BUDGET, WHOLE_BUDGET};
    match Window::plan(lobe, src_size, levels) {
        // The whole lobe where it reads a finer source than the window would, cheaply.
        Some(w) => match Window::whole(lobe, src_size, levels, size, SMALL_BUDGET) {
            Some(whole) if whole.level() < w.level() => Some(whole),
            _ => Some(w),
        },
        // Levels over 32 px stay sampled: summed whole, the middle levels of a 256 chain
        // made it slower by half again or more (their tests reach 64 px chains' level 1).
        None if level_size > WHOLE_MAX_SIZE && !matches!(lobe, Lobe::Charlie { .. }) => None,
        None => {
            let budget = match lobe {
                Lobe::Charlie { .. } => CHARLIE_WHOLE_BUDGET,
                _ => WHOLE_BUDGET,
            };
            Window::whole(lobe, src_size, levels, size, budget)
        }
    }
}

/// The largest level (edge, texels) a GGX or Gaussian lobe is summed whole for.
const WHOLE_MAX_SIZE: usize = 32;

/// Importance samples a sampled level may take in all, counted on its own texels: 256 to
/// each texel up to 64 px (2^22, 128 at 64 px, made the GGX 256 chain 20% faster and left the
/// split-sum preview's 64 px level 1.57% off its brute-force render next to a sun, over its
/// 1.4% bound).
const SAMPLE_BUDGET: u64 = 1 << 23;

/// `samples`, or more where six faces of `size` texels can afford them within
/// [`SAMPLE_BUDGET`] (a power of two, at most 256): GGX's level 1 of a 64 px chain, a hybrid
/// whose 32-sample tail left 1.31% against brute force (128: 0.41%, issue 45). Levels from
/// 128 px up take at most 64.
fn small_level_samples(samples: u32, size: usize) -> u32 {
    let afford = SAMPLE_BUDGET / (6 * size * size).max(1) as u64;
    let afford = if afford == 0 {
        0
    } else {
        1u32 << afford.min(256).ilog2()
    };
    samples.max(afford)
}

/// Levels smaller than this many texels are filtered at their size doubled until it is at
/// least this, then reduced (see `prefilter_planned`).
const FINE_SIZE: usize = 16;

/// The size a level of edge `size` is filtered at: doubled until it is at least
/// [`FINE_SIZE`].
pub(crate) fn fine_size(size: usize) -> usize {
    let mut fine = size.max(1);
    while fine < FINE_SIZE {
        fine *= 2;
    }
    fine
}

/// A sub-patch of an output texel spans at most this fraction of its lobe's width.
const SUB_PATCH_WIDTHS: f32 = 0.5;

/// The size a level of edge `size` filtered with `lobe` is computed at, before each texel
/// becomes the mean of its sub-patches: [`fine_size`], doubled further while a texel is wider
/// than `SUB_PATCH_WIDTHS` of the lobe's width (up to 16 times `size`). A texel holds the mean
/// of the filtered radiance over its patch; where the lobe is narrower than the patch, its
/// centre's value is not that mean (issue 45: cosine level 1 of a 32 px chain, power 512 on
/// 16 px texels, was 7.8% off brute force).
pub(crate) fn fine_size_for(size: usize, lobe: Option<Lobe>) -> usize {
    let mut fine = fine_size(size);
    if let Some(l) = lobe {
        let limit = SUB_PATCH_WIDTHS * l.width();
        while texel_angle(fine) > limit && fine < 16 * size.max(1) {
            fine *= 2;
        }
    }
    fine
}

/// `faces` halved with solid-angle weights until they are `size` texels: each texel the
/// solid-angle-weighted mean of the texels it covers.
pub(crate) fn reduce_to(mut faces: Faces, size: usize) -> Faces {
    while faces[0].width > size {
        let n = faces[0].width;
        let weights = crate::cube::solid_angle_table(n);
        faces = std::array::from_fn(|f| {
            crate::cube::box_reduce_face(&faces[f], n, &weights, glam::Vec4::INFINITY)
        });
    }
    faces
}

/// `faces` scaled, each channel by itself, to the mean radiance `flux`: the sampled filters'
/// estimate of each texel is a ratio of sums over a few hundred samples, whose error leaves
/// up to 0.6% in a level's mean (Charlie's first level on a studio's lamps, at the default
/// samples); the exact filtered map keeps its base's mean, so that error is taken out. The
/// exact sums keep it by themselves (each texel's light divided by its lobe's integral), so
/// there the factor stays within a few 1e-4: returned as the largest channel's factor - 1.
fn keep_flux(mut faces: Faces, flux: [f64; 3]) -> (Faces, f32) {
    let n = faces[0].width;
    let got = crate::flux::mean_radiance(
        crate::flux::Grid::Cube(n),
        &faces.iter().collect::<Vec<_>>(),
    );
    let scale = glam::Vec4::new(
        ratio(flux[0], got[0]),
        ratio(flux[1], got[1]),
        ratio(flux[2], got[2]),
        1.0,
    );
    for face in &mut faces {
        for p in &mut face.pixels {
            *p *= scale;
        }
    }
    let moved = (scale.truncate() - glam::Vec3::ONE)
        .to_array()
        .into_iter()
        .fold(0.0f32, |a, b| if b.abs() > a.abs() { b } else { a });
    (faces, moved)
}

/// `want / got`, or 1 where `got` holds no light to scale.
fn ratio(want: f64, got: f64) -> f32 {
    if got > 1e-12 && want.is_finite() {
        (want / got) as f32
    } else {
        1.0
    }
}

/// Sets every texel's alpha to 1, rows in parallel.
fn opaque(faces: &mut Faces) {
    use rayon::prelude::*;
    for face in faces.iter_mut() {
        face.pixels.par_iter_mut().for_each(|p| p.w = 1.0);
    }
}

/// Each texel's colour over its alpha, then alpha 1. The exact sums divide by the lobe's
/// integral, so on an opaque source their alpha is the lobe's discrete weight total over the
/// texel's patch (the sampled filters' is 1): dividing by it keeps a constant environment
/// exactly constant, and the bright texels, whose weights are in it through their clamped
/// residual, are divided by the same total as the rest (issue 45: they were divided by the
/// lobe's integral and the rest by its weights, 30% apart for a lobe narrower than a texel).
fn by_weight(mut faces: Faces) -> Faces {
    use rayon::prelude::*;
    for face in faces.iter_mut() {
        face.pixels.par_iter_mut().for_each(|p| {
            if p.w > 0.0 {
                *p = (p.truncate() / p.w).extend(1.0);
            }
        });
    }
    faces
}

/// A copy of six faces, rows in parallel (a level-0 copy of a 512 cube is 25 MB).
fn copy_faces(faces: &Faces) -> Faces {
    use rayon::prelude::*;
    let n = faces[0].width;
    let mut out: Faces =
        std::array::from_fn(|f| crate::image::Image::new(faces[f].width, faces[f].height));
    for (dst, src) in out.iter_mut().zip(faces) {
        dst.pixels
            .par_chunks_mut(n.max(1) * 16)
            .zip(src.pixels.par_chunks(n.max(1) * 16))
            .for_each(|(d, s)| d.copy_from_slice(s));
    }
    out
}
