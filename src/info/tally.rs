//! Value statistics a row at a time: a whole image's rows in parallel, or a file's rows as
//! its bands are decoded, added in row order either way, so both give the same figures.

use super::{LevelBad, Stats};
use crate::image::luminance;
use crate::layout::Projection;
use glam::Vec4;

/// Partial statistics: over a row, then over the rows before it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tally {
    min: f64,
    max: f64,
    sum: f64,
    n: u64,
    bad: LevelBad,
}

impl Default for Tally {
    fn default() -> Self {
        Tally {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            sum: 0.0,
            n: 0,
            bad: LevelBad::default(),
        }
    }
}

impl Tally {
    /// Row `y` of an image of `(w, h)` laid out as `projection`: a ball's texels outside its
    /// disc are left out.
    pub(crate) fn of_row(
        projection: Option<Projection>,
        (w, h): (usize, usize),
        y: usize,
        row: &[Vec4],
    ) -> Tally {
        let mut t = Tally::default();
        match projection {
            Some(p @ (Projection::Sphere | Projection::Angular)) => {
                let v = (y as f32 + 0.5) / h as f32;
                for (x, &px) in row.iter().enumerate() {
                    if p.to_dir((x as f32 + 0.5) / w as f32, v).is_some() {
                        t.texel(px);
                    }
                }
            }
            _ => row.iter().for_each(|&px| t.texel(px)),
        }
        t
    }

    fn texel(&mut self, p: Vec4) {
        self.bad.count(p);
        let l = luminance(p) as f64;
        if l.is_finite() {
            self.min = self.min.min(l);
            self.max = self.max.max(l);
            self.sum += l;
            self.n += 1;
        }
    }

    /// Adds the next row's tally.
    pub(crate) fn add(&mut self, o: &Tally) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
        self.sum += o.sum;
        self.n += o.n;
        self.bad.nan += o.bad.nan;
        self.bad.inf += o.bad.inf;
        self.bad.negative += o.bad.negative;
    }

    pub(crate) fn stats(&self) -> Stats {
        let (min, max, mean) = match self.n {
            0 => (0.0, 0.0, 0.0),
            n => (self.min, self.max, self.sum / n as f64),
        };
        Stats {
            min_luminance: min,
            max_luminance: max,
            mean_luminance: mean,
            nan: self.bad.nan,
            inf: self.bad.inf,
            negative: self.bad.negative,
        }
    }
}
