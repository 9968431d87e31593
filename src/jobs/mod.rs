//! Commands as library jobs. Each job is plain data (the options a front end gathered, with
//! no flag in sight), checked by [`Job::validate`] before any file is read, planned by
//! [`Job::memory_estimate`] from the inputs' headers, and run by [`Job::run`], which checks
//! the plan against the limits, does the work, writes through [`crate::output::deliver`] and
//! returns a [`Report`]. The command line, a batch manifest, the viewer and the tests build
//! the same jobs.

use crate::io::GpuFormat;
use crate::Result;
use std::path::PathBuf;

mod control;
mod convert;
mod ibl;
mod irradiance;
mod lut;
mod prefilter;
mod preview;
mod view;

pub use control::ControlJob;
pub use convert::ConvertJob;
pub use ibl::IblJob;
pub use irradiance::IrradianceJob;
pub use lut::{LutJob, LutKind};
pub use prefilter::PrefilterJob;
pub use preview::PreviewJob;
pub use view::ViewJob;

pub use crate::progress::Progress;

/// Something the user should know that did not stop the work: an option that does not apply,
/// values clamped or replaced, a result that differs from what was asked.
pub type Warning = crate::error::Text;

/// A lossy container format's quality: level 0 read back against the map before encoding.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    /// The texel format.
    pub format: GpuFormat,
    /// Peak signal-to-noise ratio in dB (peak 1; float formats compare v/(1+v)).
    pub psnr_db: f64,
}

/// What a job did.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// The files written (`-.EXT` for standard output), in order.
    pub written: Vec<PathBuf>,
    /// The warnings, in the order they were given to [`Progress::warning`].
    pub warnings: Vec<Warning>,
    /// Lines that describe the result (a chain's levels, a table's size), for a front end
    /// to print.
    pub summary: Vec<crate::error::Text>,
    /// A lossy container format's quality, when one was written.
    pub quality: Option<Quality>,
}

/// One command's work.
pub trait Job {
    /// Checks the options and the output's name, before any file is read. Returns the
    /// warnings about options that do not apply.
    fn validate(&self) -> Result<Vec<Warning>>;
    /// The bytes the job plans to hold at its peak, from the inputs' headers (the inputs are
    /// not decoded). [`Job::run`] refuses a plan over the limits.
    fn memory_estimate(&self) -> Result<u64>;
    /// Does the work and writes the result.
    fn run(&self, progress: &dyn Progress) -> Result<Report>;
    /// The limits every read of the job obeys: a front end sets their budget, or their
    /// [`crate::io::Session`] to learn what the job read and share decoded inputs.
    fn limits_mut(&mut self) -> &mut crate::io::Limits;
}

/// Collects warnings for the report and tells them to the observer at once.
pub(crate) struct Warnings<'a> {
    progress: &'a dyn Progress,
    list: Vec<Warning>,
}

impl<'a> Warnings<'a> {
    pub(crate) fn new(progress: &'a dyn Progress) -> Self {
        Warnings {
            progress,
            list: Vec::new(),
        }
    }

    pub(crate) fn push(&mut self, text: impl std::fmt::Display) {
        let w = Warning::new(text.to_string());
        self.progress.warning(&w);
        self.list.push(w);
    }

    pub(crate) fn extend(&mut self, ws: Vec<Warning>) {
        for w in ws {
            self.progress.warning(&w);
            self.list.push(w);
        }
    }

    pub(crate) fn into_vec(self) -> Vec<Warning> {
        self.list
    }
}

pub(crate) use crate::error::Text;

/// Summary lines as texts.
pub(crate) fn texts(lines: Vec<String>) -> Vec<Text> {
    lines.into_iter().map(Text::new).collect()
}

/// The warning for decoded values that were not radiance.
/// The warning for lighting computed from an 8- or 16-bit image: display-referred colour, whose
/// brightest light is white, makes lighting dim and flat (a sun is 1e4 times brighter than
/// the sky around it in a photograph's radiance, not 1 time).
pub(crate) fn display_referred(loaded: &crate::convert::Loaded) -> Option<String> {
    (!loaded.hdr).then(|| {
        format!(
            "{}: an {} image holds display colours, not radiance: the lighting it makes is dim \
             and flat (nothing in it is brighter than white); give an HDR panorama (.hdr, \
             .exr; Poly Haven's are free), or lift it with {}",
            loaded
                .files
                .first()
                .map(|f| f.display().to_string())
                .unwrap_or_default(),
            loaded.meta.pixel_format,
            crate::error::param("exposure")
        )
    })
}

/// What a command wrote, as a summary line: each file with its size, a folder output (faces,
/// a chain) as one entry with its count. None on standard output, whose data is the output.
pub(crate) fn wrote(
    files: &crate::output::Files,
    dest: &crate::output::Destination,
) -> Option<String> {
    if dest.is_stdout() || files.files.is_empty() {
        return None;
    }
    let mut parts = Vec::new();
    for dir in &files.folders {
        let inside: Vec<&Vec<u8>> = files
            .files
            .iter()
            .filter(|(p, _)| p.starts_with(dir))
            .map(|(_, b)| b)
            .collect();
        let bytes: usize = inside.iter().map(|b| b.len()).sum();
        parts.push(format!(
            "{}/ ({} files, {bytes} bytes)",
            dir.display(),
            inside.len()
        ));
    }
    for (p, b) in &files.files {
        if !files.folders.iter().any(|d| p.starts_with(d)) {
            parts.push(format!("{} ({} bytes)", p.display(), b.len()));
        }
    }
    Some(format!("wrote {}", parts.join(", ")))
}
