//! The sun of a map, as a light (issue 49): the brightest compact source, its direction, size,
//! colour and irradiance, so that an engine can cast its shadow while the map keeps the sky.
//!
//! A light is a cluster of texels far brighter than the sky: luminance above [`SUN_RATIO`]
//! times the map's solid-angle-weighted median (the median, not the mean, which a sun
//! moves), gathered around the brightest such texel out to [`REACH_DEG`] by direction (so a
//! sun split over a panorama's seam or a cube's edge stays one). Its direction is the
//! radiance-weighted centroid of its texels; its irradiance, per channel, the integral over
//! its texels of its radiance above the sky around it (the median of a ring from one to two
//! reaches out), in the map's units times steradians; its angular diameter that of a disc with
//! the solid angle of its texels above half its peak. The sun is the light with the most
//! irradiance, when it holds at least [`MIN_SHARE`] of the light the whole sphere sends
//! through a surface facing it; an overcast sky or an interior's soft windows hold none.

use super::Grid;
use crate::image::Image;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A texel belongs to a light above this multiple of the sky's median luminance.
pub const SUN_RATIO: f64 = 600.0;

/// How far (degrees) a light's texels reach from its brightest: a sun with its corona and a
/// lens's glare, not the lamp across the room.
pub const REACH_DEG: f64 = 5.0;

/// The sun's irradiance is at least this share of what the whole map sends through a surface
/// facing it (its cosine-weighted integral): else the map has no sun.
pub const MIN_SHARE: f64 = 0.1;

/// At most this many lights are measured (the sun and the brightest others).
const MAX_LIGHTS: usize = 8;

/// Log2 luminance histogram for the median: 1/64 stop a bin from 2^-64 to 2^64.
const BINS: usize = 128 * 64;

/// One compact light of a map.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Unit vector towards the light, in cubeforge's frame (docs/conventions.md).
    pub direction: Vec3,
    /// Each channel's radiance above the sky around it, integrated over its texels: the
    /// irradiance it gives a surface facing it, in the map's units times steradians.
    pub irradiance: [f64; 3],
    /// Degrees: a disc with the solid angle of its texels above half its peak.
    pub angular_diameter_deg: f64,
    /// Its brightest texel's luminance.
    pub peak: f64,
    /// How many texels it spans.
    pub texels: usize,
}

impl Light {
    /// Its colour: the irradiance over its largest channel.
    pub fn color(&self) -> [f64; 3] {
        let m = self.irradiance.iter().cloned().fold(0.0, f64::max);
        self.irradiance.map(|v| if m > 0.0 { v / m } else { 0.0 })
    }

    /// Rec. 709 luminance of the irradiance.
    pub fn luminance(&self) -> f64 {
        luminance(self.irradiance)
    }
}

/// The lights of a map: the sun, if it has one, and the other compact lights, brightest first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lights {
    /// The brightest compact light, when it holds [`MIN_SHARE`] of the map's light.
    pub sun: Option<Light>,
    /// The others (and the brightest when it is no sun), brightest first.
    pub others: Vec<Light>,
    /// The sky's median luminance the threshold is taken from.
    pub sky: f64,
    /// The luminance above which a texel belongs to a light ([`SUN_RATIO`] times `sky`).
    pub threshold: f64,
}

fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// One texel above the threshold.
#[derive(Clone, Copy)]
struct Candidate {
    dir: DVec3,
    omega: f64,
    rgb: [f64; 3],
    lum: f64,
}

/// Finds and measures the lights of a map given as its grid's images (six faces, or one).
pub fn find(grid: Grid, images: &[&Image]) -> Lights {
    let (w, h) = grid.dims();
    let rows = grid.faces() * h;
    // Each texel's direction, solid angle and radiance, row by row.
    let texel = move |fy: usize, x: usize| -> Option<(DVec3, f64, [f64; 3])> {
        let (face, y) = (fy / h, fy % h);
        let omega = grid.solid_angle(x, y);
        let d = grid.dir(face, x as f32 + 0.5, y as f32 + 0.5)?;
        let p = images[face].pixels[y * w + x];
        (omega > 0.0).then(|| (d.as_dvec3(), omega, [p.x as f64, p.y as f64, p.z as f64]))
    };
    let (median, mean) = median_luminance(rows, w, &texel);
    // A map mostly black (a night, a studio's dark floor) has a median near 0: the sky's level
    // is then taken as a thousandth of the mean, so the whole map does not pass for lights.
    let sky = median.max(mean * 1e-3);
    let threshold = SUN_RATIO * sky.max(1e-12);
    let mut candidates: Vec<Candidate> = (0..rows)
        .into_par_iter()
        .flat_map_iter(|fy| {
            (0..w).filter_map(move |x| {
                let (dir, omega, rgb) = texel(fy, x)?;
                let lum = luminance(rgb);
                (lum > threshold).then_some(Candidate {
                    dir,
                    omega,
                    rgb,
                    lum,
                })
            })
        })
        .collect();
    // Brightest first; ties in the grid's order (the sort is stable): the same on every run.
    candidates.sort_by(|a, b| b.lum.total_cmp(&a.lum));
    let reach = REACH_DEG.to_radians().cos();
    let mut taken = vec![false; candidates.len()];
    let mut clusters: Vec<Vec<usize>> = Vec::new();
    while clusters.len() < MAX_LIGHTS {
        let Some(seed) = taken.iter().position(|t| !t) else {
            break;
        };
        let axis = candidates[seed].dir;
        let members: Vec<usize> = (seed..candidates.len())
            .filter(|&i| !taken[i] && candidates[i].dir.dot(axis) >= reach)
            .collect();
        for &i in &members {
            taken[i] = true;
        }
        clusters.push(members);
    }
    let axes: Vec<DVec3> = clusters.iter().map(|m| centroid(&candidates, m)).collect();
    let skies = ring_medians(rows, w, &texel, &axes);
    let mut lights: Vec<Light> = clusters
        .iter()
        .zip(axes.iter().zip(skies))
        .map(|(m, (&axis, sky))| measure(&candidates, m, axis, sky))
        .collect();
    lights.sort_by(|a, b| b.luminance().total_cmp(&a.luminance()));
    let facing = lights
        .first()
        .map(|l| cosine_integral(rows, w, &texel, l.direction.as_dvec3()));
    let sun = match (lights.first(), facing) {
        (Some(l), Some(e)) if e > 0.0 && l.luminance() >= MIN_SHARE * e => Some(lights.remove(0)),
        _ => None,
    };
    Lights {
        sun,
        others: lights,
        sky,
        threshold,
    }
}

/// Most sky texels a filled texel is interpolated from (the nearest ones).
const FILL_SAMPLES: usize = 4096;

/// Takes `light` out of the map: its texels (above `threshold`, within [`REACH_DEG`] of it)
/// are replaced by the sky around them, each the inverse-square-distance mean of the nearest
/// texels that are not its (its glow and the sky), so the fill continues what surrounds it.
/// Returns the light taken out per channel: the texels' radiance less their fill, times their
/// solid angle (the map's flux drops by it over 4 pi).
pub fn remove(grid: Grid, images: &mut [Image], light: &Light, threshold: f64) -> [f64; 3] {
    let (w, h) = grid.dims();
    let axis = light.direction.as_dvec3();
    let reach = REACH_DEG.to_radians().cos();
    let around = (2.0 * REACH_DEG).to_radians().cos();
    // Each row's texels near the light, rows in parallel, in the grid's order.
    enum Near {
        Member(usize, usize, usize),
        Sky(f64, DVec3, [f64; 3]),
    }
    let imgs: &[Image] = images;
    let near: Vec<Near> = (0..grid.faces() * h)
        .into_par_iter()
        .flat_map_iter(|fy| {
            let (face, y) = (fy / h, fy % h);
            (0..w).filter_map(move |x| {
                let d = grid.dir(face, x as f32 + 0.5, y as f32 + 0.5)?.as_dvec3();
                let c = d.dot(axis);
                if c < around || grid.solid_angle(x, y) <= 0.0 {
                    return None;
                }
                let p = imgs[face].pixels[y * w + x];
                let rgb = [p.x as f64, p.y as f64, p.z as f64];
                Some(if c >= reach && luminance(rgb) > threshold {
                    Near::Member(face, x, y)
                } else {
                    Near::Sky(1.0 - c, d, rgb)
                })
            })
        })
        .collect();
    let mut members = Vec::new();
    let mut sky: Vec<(f64, DVec3, [f64; 3])> = Vec::new();
    for n in near {
        match n {
            Near::Member(face, x, y) => {
                let d = grid
                    .dir(face, x as f32 + 0.5, y as f32 + 0.5)
                    .unwrap_or(Vec3::Z);
                members.push((face, x, y, d.as_dvec3()));
            }
            Near::Sky(u, d, rgb) => sky.push((u, d, rgb)),
        }
    }
    // The nearest sky texels to the light (ties in the grid's order: the sort is stable).
    sky.sort_by(|a, b| a.0.total_cmp(&b.0));
    sky.truncate(FILL_SAMPLES);
    let mut taken = [0.0f64; 3];
    for (face, x, y, d) in members {
        let (mut sum, mut weight) = ([0.0f64; 3], 0.0f64);
        for (_, s, rgb) in &sky {
            // 1 - cos is half the squared chord: an inverse-square weight of the distance.
            let wgt = 1.0 / (1.0 - d.dot(*s)).max(1e-12);
            for k in 0..3 {
                sum[k] += wgt * rgb[k];
            }
            weight += wgt;
        }
        let fill = if weight > 0.0 {
            sum.map(|v| v / weight)
        } else {
            [0.0; 3]
        };
        let p = &mut images[face].pixels[y * w + x];
        let omega = grid.solid_angle(x, y);
        for k in 0..3 {
            taken[k] += (p[k] as f64 - fill[k]) * omega;
        }
        *p = glam::Vec4::new(fill[0] as f32, fill[1] as f32, fill[2] as f32, p.w);
    }
    taken
}

/// The solid-angle-weighted median luminance, from a histogram of log2 luminance, and the
/// mean.
fn median_luminance(
    rows: usize,
    w: usize,
    texel: &(impl Fn(usize, usize) -> Option<(DVec3, f64, [f64; 3])> + Sync),
) -> (f64, f64) {
    let bin =
        |l: f64| ((l.max(1e-300).log2() + 64.0) * 64.0).clamp(0.0, (BINS - 1) as f64) as usize;
    // Each band of ROWS rows' histogram and light (bands in parallel), added in band order:
    // the same bits on every thread count, a histogram a band, not a row.
    const ROWS: usize = 64;
    let per_row: Vec<(Vec<f64>, f64)> = (0..rows.div_ceil(ROWS))
        .into_par_iter()
        .map(|band| {
            let mut hist = vec![0.0f64; BINS];
            let mut light = 0.0;
            for fy in band * ROWS..rows.min((band + 1) * ROWS) {
                for x in 0..w {
                    if let Some((_, omega, rgb)) = texel(fy, x) {
                        let l = luminance(rgb);
                        hist[bin(l)] += omega;
                        light += l * omega;
                    }
                }
            }
            (hist, light)
        })
        .collect();
    let mut hist = vec![0.0f64; BINS];
    let mut light = 0.0;
    for (h, l) in &per_row {
        for (a, b) in hist.iter_mut().zip(h) {
            *a += b;
        }
        light += l;
    }
    let total: f64 = hist.iter().sum();
    let mean = if total > 0.0 { light / total } else { 0.0 };
    let mut run = 0.0;
    for (i, v) in hist.iter().enumerate() {
        run += v;
        if run >= total / 2.0 {
            return (((i as f64 + 0.5) / 64.0 - 64.0).exp2(), mean);
        }
    }
    (0.0, mean)
}

/// The cosine-weighted integral of luminance over the hemisphere around `axis`.
fn cosine_integral(
    rows: usize,
    w: usize,
    texel: &(impl Fn(usize, usize) -> Option<(DVec3, f64, [f64; 3])> + Sync),
    axis: DVec3,
) -> f64 {
    let per_row: Vec<f64> = (0..rows)
        .into_par_iter()
        .map(|fy| {
            (0..w)
                .filter_map(|x| texel(fy, x))
                .map(|(d, omega, rgb)| d.dot(axis).max(0.0) * luminance(rgb) * omega)
                .sum()
        })
        .collect();
    per_row.iter().sum()
}

/// The radiance-weighted centroid of `members` (indices into `all`, brightest first).
fn centroid(all: &[Candidate], members: &[usize]) -> DVec3 {
    let mut sum = DVec3::ZERO;
    for &i in members {
        let c = &all[i];
        sum += c.dir * c.lum * c.omega;
    }
    sum.normalize_or(all[members[0]].dir)
}

/// Measures the light of `members` around `axis`, standing on `sky`.
fn measure(all: &[Candidate], members: &[usize], axis: DVec3, sky: [f64; 3]) -> Light {
    let mut irradiance = [0.0f64; 3];
    for &i in members {
        let c = &all[i];
        for (k, e) in irradiance.iter_mut().enumerate() {
            *e += (c.rgb[k] - sky[k]).max(0.0) * c.omega;
        }
    }
    let peak = all[members[0]].lum;
    let half: f64 = members
        .iter()
        .filter(|&&i| all[i].lum >= peak / 2.0)
        .map(|&i| all[i].omega)
        .sum();
    // A cap of solid angle s has half-angle acos(1 - s / 2 pi).
    let diameter = 2.0 * (1.0 - half / std::f64::consts::TAU).clamp(-1.0, 1.0).acos();
    Light {
        direction: axis.as_vec3(),
        irradiance,
        angular_diameter_deg: diameter.to_degrees(),
        peak,
        texels: members.len(),
    }
}

/// For each axis, each channel's median radiance over the ring from one to two reaches
/// around it: the sky a light stands on. One pass over the texels for every axis.
fn ring_medians(
    rows: usize,
    w: usize,
    texel: &(impl Fn(usize, usize) -> Option<(DVec3, f64, [f64; 3])> + Sync),
    axes: &[DVec3],
) -> Vec<[f64; 3]> {
    let (inner, outer) = (
        REACH_DEG.to_radians().cos(),
        (2.0 * REACH_DEG).to_radians().cos(),
    );
    let found: Vec<(usize, [f64; 3])> = (0..rows)
        .into_par_iter()
        .flat_map_iter(|fy| {
            (0..w).flat_map(move |x| {
                let hit = texel(fy, x);
                axes.iter().enumerate().filter_map(move |(a, axis)| {
                    let (d, _, rgb) = hit?;
                    let c = d.dot(*axis);
                    (c < inner && c >= outer).then_some((a, rgb))
                })
            })
        })
        .collect();
    axes.iter()
        .enumerate()
        .map(|(a, _)| {
            let mut ring: Vec<[f64; 3]> = found
                .iter()
                .filter(|(k, _)| *k == a)
                .map(|(_, v)| *v)
                .collect();
            let mut out = [0.0; 3];
            if ring.is_empty() {
                return out;
            }
            for (k, o) in out.iter_mut().enumerate() {
                ring.sort_by(|p, q| p[k].total_cmp(&q[k]));
                *o = ring[ring.len() / 2][k];
            }
            out
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{equirect, Projection};
    use glam::Vec4;

    /// A sky of 0.5 to 1 with a disc of `radius_deg` and radiance `sun` around `at`, as a
    /// `w` x `w/2` panorama, each texel the mean of 8 x 8 sub-samples (so the disc's edge is
    /// covered in part).
    fn sky_with_sun(w: usize, at: Vec3, radius_deg: f32, sun: Vec3) -> Image {
        let h = w / 2;
        let cos_r = radius_deg.to_radians().cos();
        Image::from_fn(w, h, |x, y| {
            let mut acc = Vec3::ZERO;
            for j in 0..8 {
                for i in 0..8 {
                    let u = (x as f32 + (i as f32 + 0.5) / 8.0) / w as f32;
                    let v = (y as f32 + (j as f32 + 0.5) / 8.0) / h as f32;
                    let d = equirect::uv_to_dir(u, v);
                    let sky = Vec3::new(0.5, 0.7, 1.0) * (0.5 + 0.5 * d.y.max(0.0));
                    acc += if d.dot(at) >= cos_r { sun + sky } else { sky };
                }
            }
            (acc / 64.0).extend(1.0)
        })
    }

    /// A known disc: direction within 0.5 degree, irradiance within 3%, size within 20%.
    #[test]
    fn a_known_disc_is_found_and_measured() {
        let at = Vec3::new(0.4, 0.5, -0.6).normalize();
        let (radius, sun) = (1.0f32, Vec3::new(30000.0, 26000.0, 20000.0));
        let img = sky_with_sun(2048, at, radius, sun);
        let lights = find(Grid::Projection(Projection::Equirect, 2048, 1024), &[&img]);
        let s = lights.sun.expect("a sun");
        let off = s.direction.angle_between(at).to_degrees();
        let cap = std::f64::consts::TAU * (1.0 - (radius as f64).to_radians().cos());
        let want = [sun.x as f64 * cap, sun.y as f64 * cap, sun.z as f64 * cap];
        let err = (0..3)
            .map(|c| (s.irradiance[c] / want[c] - 1.0).abs())
            .fold(0.0, f64::max);
        let size = s.angular_diameter_deg / (2.0 * radius as f64);
        assert!(off < 0.5, "direction {off} degrees off");
        assert!(err < 0.03, "irradiance {:?} against {want:?}", s.irradiance);
        assert!(
            (size - 1.0).abs() < 0.2,
            "diameter {}",
            s.angular_diameter_deg
        );
    }

    /// Taking a known disc out: no texel left far above the sky, and the map's flux drops by
    /// the sun's irradiance over 4 pi, within 0.5% of the flux.
    #[test]
    fn a_removed_sun_leaves_the_sky_and_its_light() {
        let at = Vec3::new(-0.3, 0.6, 0.5).normalize();
        let mut img = sky_with_sun(1024, at, 1.5, Vec3::new(25000.0, 22000.0, 18000.0));
        let grid = Grid::Projection(Projection::Equirect, 1024, 512);
        let before = super::super::mean_radiance(grid, &[&img]);
        let lights = find(grid, &[&img]);
        let s = lights.sun.expect("a sun");
        let taken = remove(grid, std::slice::from_mut(&mut img), &s, lights.threshold);
        let after = super::super::mean_radiance(grid, &[&img]);
        let four_pi = 4.0 * std::f64::consts::PI;
        for c in 0..3 {
            let want = before[c] - s.irradiance[c] / four_pi;
            assert!(
                (after[c] / want - 1.0).abs() < 5e-3,
                "channel {c}: {} vs {want}",
                after[c]
            );
            assert!((after[c] - (before[c] - taken[c] / four_pi)).abs() < 1e-6 * before[c]);
        }
        let top = img
            .pixels
            .iter()
            .map(|p| p.truncate().max_element())
            .fold(0.0, f32::max);
        assert!(top < 1.5, "the brightest texel left is {top}");
    }

    /// A sun on the panorama's seam is one light, at its place.
    #[test]
    fn a_sun_on_the_seam_stays_one() {
        // u = 0 and 1 meet at -Z in cubeforge's equirect.
        let at = Vec3::new(0.0, 0.3, -1.0).normalize();
        let img = sky_with_sun(1024, at, 1.5, Vec3::splat(20000.0));
        let lights = find(Grid::Projection(Projection::Equirect, 1024, 512), &[&img]);
        let s = lights.sun.expect("a sun");
        assert!(
            s.direction.angle_between(at).to_degrees() < 0.5,
            "{:?}",
            s.direction
        );
        assert!(lights.others.is_empty(), "{:?}", lights.others);
    }

    /// A sky without a compact light has no sun.
    #[test]
    fn an_overcast_sky_has_none() {
        let img = Image::from_fn(512, 256, |x, y| {
            Vec4::new(
                1.0 + (x % 7) as f32 * 0.1,
                1.0 + (y % 5) as f32 * 0.2,
                1.2,
                1.0,
            )
        });
        let lights = find(Grid::Projection(Projection::Equirect, 512, 256), &[&img]);
        assert!(lights.sun.is_none() && lights.others.is_empty());
    }
}
