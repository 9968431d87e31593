//! Every conversion: for each output texel, its direction; look the direction up in the input.
//! Coarse outputs are antialiased by supersampling the texel's footprint on a pyramid level.

use crate::cube::{dir_face, face_dir, CubeMap, Dirs, Environment, Interp, BATCH};
use crate::image::Image;
use crate::layout::{equirect, Projection};
use glam::{Mat3, Vec3, Vec4};

/// A rotation of the environment (degrees) and an optional handedness flip.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Orientation {
    pub yaw: f32,
    pub pitch: f32,
    pub roll: f32,
    pub mirror: bool,
}

impl Orientation {
    /// The matrix taking an output direction to the input direction that lands there.
    /// The environment turns by yaw about +Y, then pitch about +X, then roll about +Z
    /// (counter-clockwise looking down each axis); mirror negates X of the input.
    pub fn lookup_matrix(&self) -> Mat3 {
        let r = Mat3::from_rotation_y(self.yaw.to_radians())
            * Mat3::from_rotation_x(self.pitch.to_radians())
            * Mat3::from_rotation_z(self.roll.to_radians());
        let m = r.transpose();
        if self.mirror {
            Mat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0)) * m
        } else {
            m
        }
    }

    pub fn is_identity(&self) -> bool {
        *self == Orientation::default()
    }
}

/// How to resample: interpolation, antialiasing, orientation.
#[derive(Clone, Copy, Debug)]
pub struct Resampler {
    pub interp: Interp,
    /// Supersample texels whose footprint covers more than a source texel or so.
    pub antialias: bool,
    pub orientation: Orientation,
}

impl Default for Resampler {
    fn default() -> Self {
        Resampler {
            interp: Interp::Bilinear,
            antialias: true,
            orientation: Orientation::default(),
        }
    }
}

/// Largest number of subsamples per axis of one output texel.
const MAX_SUB: usize = 4;

impl Resampler {
    /// A cube map of face edge `size` from any environment.
    pub fn to_cube(&self, env: &dyn Environment, size: usize) -> CubeMap {
        let inv = 1.0 / size as f32;
        let faces = std::array::from_fn(|face| {
            self.render(
                env,
                size,
                size,
                |x, y| Some(face_dir(face, x * inv, y * inv)),
                |x, y| {
                    // Angle of one texel at (sc, tc) on the face plane, the larger axis.
                    let sc = 2.0 * x * inv - 1.0;
                    let tc = 2.0 * y * inv - 1.0;
                    let q = 1.0 + sc * sc + tc * tc;
                    2.0 * inv * (1.0 + sc.abs().max(tc.abs()).powi(2)).sqrt() / q
                },
            )
        });
        CubeMap {
            levels: vec![faces],
        }
    }

    /// A panorama, mirror ball or angular map of `w` x `h` from any environment.
    pub fn to_projection(
        &self,
        env: &dyn Environment,
        proj: Projection,
        w: usize,
        h: usize,
    ) -> Image {
        let (iw, ih) = (1.0 / w as f32, 1.0 / h as f32);
        let at = move |p: Projection| move |x: f32, y: f32| p.to_dir(x * iw, y * ih);
        // The angle one texel spans, from each layout's formula (the larger of its radial and
        // tangential rates times the texel's size in disc radii, 2 / w). One render per
        // layout, so each inlines its own direction maths.
        match proj {
            Projection::Equirect => {
                let rows = std::f32::consts::PI * ih;
                let dir = move |x: f32, y: f32| Some(equirect::uv_to_dir(x * iw, y * ih));
                self.render(env, w, h, dir, move |_, _| rows)
            }
            // The angle from -Z is pi r: pi per unit radius, across and around.
            Projection::Angular => {
                let texel = std::f32::consts::TAU * iw;
                self.render(env, w, h, at(proj), move |_, _| texel)
            }
            // The angle from -Z is 2 asin r: 2 / sqrt(1 - r^2) across the rings, more than the
            // 2 sqrt(1 - r^2) around them. Outside the ball nothing is sampled.
            Projection::Sphere => self.render(env, w, h, at(proj), move |x, y| {
                let (sx, sy) = (2.0 * x * iw - 1.0, 2.0 * y * ih - 1.0);
                let rr = sx * sx + sy * sy;
                if rr >= 1.0 {
                    0.0
                } else {
                    4.0 * iw / (1.0 - rr).sqrt()
                }
            }),
        }
    }

    /// The shared loop: `dir(x, y)` gives the direction at continuous pixel coordinates
    /// (None where the layout shows nothing), `footprint` the angle one texel spans there.
    /// Texels are worked in short runs of a row: every tap of a run (one per texel, or up to
    /// MAX_SUB x MAX_SUB for coarse texels) is queued and looked up in batches.
    pub fn render(
        &self,
        env: &dyn Environment,
        w: usize,
        h: usize,
        dir: impl Fn(f32, f32) -> Option<Vec3> + Sync,
        footprint: impl Fn(f32, f32) -> f32 + Sync,
    ) -> Image {
        let turn = (!self.orientation.is_identity()).then(|| self.orientation.lookup_matrix());
        let src_angle = env.texel_angle();
        let levels = env.levels();
        Image::from_rows(w, h, |y, row| {
            let mut taps = Taps {
                env,
                interp: self.interp,
                turn,
                level: 0,
                dirs: Dirs::default(),
                slot: [0; BATCH],
            };
            for (run, out) in row.chunks_mut(RUN).enumerate() {
                let mut acc = [Vec4::ZERO; RUN];
                let mut count = [0u32; RUN];
                for (i, n_taps) in count.iter_mut().enumerate().take(out.len()) {
                    let x = run * RUN + i;
                    let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
                    let ratio = if self.antialias {
                        footprint(cx, cy) / src_angle
                    } else {
                        0.0
                    };
                    if ratio <= 1.5 {
                        if let Some(d) = dir(cx, cy) {
                            taps.push(d, 0, i, &mut acc);
                            *n_taps = 1;
                        }
                        continue;
                    }
                    // A pyramid level where the footprint spans at most ~4 texels, then up to
                    // MAX_SUB x MAX_SUB bilinear taps spread over the texel.
                    let level = ((ratio / 4.0).log2().ceil().max(0.0) as usize).min(levels - 1);
                    let rest = ratio / (1u32 << level) as f32;
                    let n = ((rest / 1.5).ceil() as usize).clamp(1, MAX_SUB);
                    let step = 1.0 / n as f32;
                    for j in 0..n {
                        for k in 0..n {
                            let sx = x as f32 + (k as f32 + 0.5) * step;
                            let sy = y as f32 + (j as f32 + 0.5) * step;
                            if let Some(d) = dir(sx, sy) {
                                taps.push(d, level, i, &mut acc);
                                *n_taps += 1;
                            }
                        }
                    }
                }
                taps.flush(&mut acc);
                for ((o, a), &c) in out.iter_mut().zip(acc).zip(&count) {
                    *o = match c {
                        0 => Vec4::ZERO,
                        1 => a,
                        _ => a / c as f32,
                    };
                }
            }
        })
    }
}

/// Output texels per run: their sums live on the stack while the run's taps are looked up.
const RUN: usize = 64;

/// Queued lookups of one level, each adding into the sum of the texel (slot) it belongs to.
/// Flushing keeps each slot's order of additions, so results do not depend on batch edges.
struct Taps<'a> {
    env: &'a dyn Environment,
    interp: Interp,
    turn: Option<Mat3>,
    level: usize,
    dirs: Dirs,
    slot: [u8; BATCH],
}

impl Taps<'_> {
    #[inline]
    fn push(&mut self, d: Vec3, level: usize, slot: usize, acc: &mut [Vec4; RUN]) {
        if self.dirs.is_full() || (level != self.level && self.dirs.len > 0) {
            self.flush(acc);
        }
        self.level = level;
        self.slot[self.dirs.len] = slot as u8;
        self.dirs.push(d);
    }

    fn flush(&mut self, acc: &mut [Vec4; RUN]) {
        let n = self.dirs.len;
        if n == 0 {
            return;
        }
        if let Some(m) = &self.turn {
            self.dirs.transform(m);
        }
        self.dirs.normalize();
        let mut out = [Vec4::ZERO; BATCH];
        self.env
            .sample_many(&self.dirs, self.level, self.interp, &mut out[..n]);
        for (&s, v) in self.slot[..n].iter().zip(&out[..n]) {
            acc[s as usize] += *v;
        }
        self.dirs.len = 0;
    }
}

/// An environment given by a function of direction: exact ground truth for tests and fixtures.
pub struct FnEnv<F: Fn(Vec3) -> Vec4 + Sync>(pub F);

impl<F: Fn(Vec3) -> Vec4 + Sync> Environment for FnEnv<F> {
    fn sample(&self, d: Vec3, _level: usize, _interp: Interp) -> Vec4 {
        (self.0)(d)
    }
    fn texel_angle(&self) -> f32 {
        1e-6
    }
    fn levels(&self) -> usize {
        1
    }
}

/// Which face and texel a direction falls on, for tests and tools that need the exact cell.
pub fn dir_texel(d: Vec3, size: usize) -> (usize, usize, usize) {
    let (f, s, t) = dir_face(d);
    let x = ((s * size as f32) as usize).min(size - 1);
    let y = ((t * size as f32) as usize).min(size - 1);
    (f, x, y)
}
