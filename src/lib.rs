//! cubeforge: turn photographs into cube maps and check them.
//!
//! Every command of the `cubeforge` tool is a job here: build one from plain data, run it,
//! read its [`Report`]. [`ConvertJob`] turns any layout or container into any other,
//! [`PrefilterJob`] makes mip chains for blurred and glossy reflections, [`IrradianceJob`] the
//! diffuse side, [`IblJob`] the files an engine loads, [`LutJob`] BRDF tables, [`ControlJob`]
//! control maps, and [`PreviewJob`] a sphere lit by the map. Each [`Job`] checks its options
//! ([`Job::validate`]), plans its memory from the inputs' headers ([`Job::memory_estimate`],
//! refused over [`Limits::max_memory`] before anything is decoded), and writes through one
//! path (`output::deliver`): inputs are never overwritten, outputs land whole or not at all, and
//! [`Destination::Stdout`] is standard output. [`Progress`] hears stages, progress and warnings
//! while a job runs; `&()` hears nothing. A map is laid out as a [`Layout`] (a panorama, a
//! ball, a cross, six faces, ...) or stored in a [`Container`] (KTX2, DDS, KTX, .env); a
//! [`MapKind`] is either, as a job's `to` and `info`'s report name it.
//!
//! A panorama to a KTX2 cube map with its mip chain:
//!
//! ```
//! use cubeforge::{ConvertJob, Destination, Job};
//!
//! # fn main() -> cubeforge::Result<()> {
//! let out = std::env::temp_dir().join("cubeforge-doc-root.ktx2");
//! let job = ConvertJob {
//!     size: Some(64),
//!     ..ConvertJob::new(vec!["fixtures/sky.exr".into()], Destination::Path(out.clone()))
//! };
//! let report = job.run(&())?;
//! assert_eq!(report.written, [out.clone()]);
//! # std::fs::remove_file(&out).ok();
//! # Ok(())
//! # }
//! ```
//!
//! A split-sum GGX chain, its levels listed in the report:
//!
//! ```
//! use cubeforge::{ChainOptions, Destination, FilterKind, Job, PrefilterJob};
//!
//! # fn main() -> cubeforge::Result<()> {
//! let out = std::env::temp_dir().join("cubeforge-doc-root-ggx.ktx2");
//! let job = PrefilterJob {
//!     size: Some(32),
//!     chain: ChainOptions { filter: FilterKind::Ggx, samples: 8, ..ChainOptions::default() },
//!     ..PrefilterJob::new(vec!["fixtures/sky.exr".into()], Destination::Path(out.clone()))
//! };
//! for line in job.run(&())?.summary {
//!     println!("{line}"); // level  0     32 px  roughness 0.000 (alpha 0.0000), ...
//! }
//! # std::fs::remove_file(&out).ok();
//! # Ok(())
//! # }
//! ```
//!
//! Bevy's two KTX2 files (specular chain and diffuse map) and the code that loads them:
//!
//! ```
//! use cubeforge::{Engine, IblJob, IblOptions, Job};
//!
//! # fn main() -> cubeforge::Result<()> {
//! let dir = std::env::temp_dir().join(format!("cubeforge-doc-root-{}", std::process::id()));
//! let job = IblJob {
//!     options: IblOptions { specular_size: Some(32), samples: Some(4), ..IblOptions::default() },
//!     ..IblJob::new(vec!["fixtures/sky.exr".into()], dir.clone(), Engine::Bevy)
//! };
//! let report = job.run(&())?;
//! assert_eq!(report.written.len(), 2);
//! println!("{}", report.summary.last().unwrap()); // the Bevy snippet
//! # std::fs::remove_dir_all(&dir).ok();
//! # Ok(())
//! # }
//! ```
//!
//! A [`Batch`] runs many jobs as one build step (grouped by input over one decode, skipped
//! when up to date), and [`write_depfile`] names what one job read for Make or Ninja.
//!
//! The modules themselves are private: what a library user needs is re-exported here, and
//! a test (`tests/it/surface.rs`) fails when this surface grows past 200 items. The command
//! line, the tests and the benches reach the plumbing through `internals`, which is not API.
//! ARCHITECTURE.md draws the layers.

#![warn(missing_docs)]

// Plumbing modules, documented for the crate's readers, not as API: `missing_docs` is
// held for the modules the facade draws on most (batch, convert, cube, error, image, jobs,
// output) as before they were made private.
mod alloc;
mod batch;
#[allow(missing_docs)]
mod chain;
#[allow(missing_docs)]
mod control;
mod convert;
mod cube;
mod error;
#[allow(missing_docs)]
mod filter;
#[allow(missing_docs)]
mod flux;
#[allow(missing_docs)]
mod ibl;
mod image;
#[allow(missing_docs)]
mod info;
mod input;
#[allow(missing_docs)]
mod io;
mod jobs;
#[allow(missing_docs)]
mod layout;
#[allow(missing_docs)]
mod lut;
mod output;
#[allow(missing_docs)]
mod preview;
mod progress;
#[allow(missing_docs)]
mod resample;
mod simd;
#[allow(missing_docs)]
mod synthetic;
#[allow(missing_docs)]
mod tonemap;
#[allow(missing_docs)]
mod view;

pub use batch::{Batch, BatchJob, BatchReport, Done, Outcome, Shard, ShardBy, Why};
pub use control::Size;
pub use convert::MapKind;
pub use cube::{CubeMap, EdgeFixup, Interp};
pub use error::{Error, LimitKind, Result};
pub use filter::sh_bands::ShWindow;
pub use filter::{ChainOptions, FilterKind, IrradianceMethod, LightingModel, RoughnessMapping};
pub use ibl::{Engine, IblOptions};
pub use image::Image;
pub use io::{
    Container, ExrFloat, FileFormat, GpuFormat, HdrEncoding, Limits, ReadOptions, Session,
    SessionGuard,
};
pub use jobs::{
    ControlJob, ConvertJob, IblJob, IrradianceJob, Job, LutJob, LutKind, PrefilterJob, PreviewJob,
    Progress, Quality, Report, ViewJob, Warning,
};
pub use layout::Kind as Layout;
pub use output::depfile::write as write_depfile;
pub use output::{Destination, Encoding};
pub use preview::{Background, Options as View, Parallax, ParallaxMode, Refraction, Shading};
pub use resample::{Orientation, Resampler};
pub use tonemap::Tonemap;

/// The plumbing below the facade, each module whole, for the command line (a crate of its
/// own), the tests and the benches. Not API: nothing here is promised to stay.
#[doc(hidden)]
#[allow(missing_docs)]
pub mod internals {
    macro_rules! whole {
        ($($m:ident),*) => { $(pub mod $m { pub use crate::$m::*; })* };
    }
    whole!(
        batch, chain, control, convert, cube, error, filter, flux, ibl, image, info, input, io,
        jobs, layout, lut, output, preview, resample, synthetic, tonemap, view
    );
}

/// The README's Rust example, compiled and run with the doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
