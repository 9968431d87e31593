//! cubeforge: turn photographs into cube maps and check them.
//!
//! Every command of the `cubeforge` tool is a job here: build one from plain data, run it,
//! read its [`Report`]. [`ConvertJob`] turns any layout or container into any other,
//! [`PrefilterJob`] makes mip chains for blurred and glossy reflections, [`IrradianceJob`] the
//! diffuse side, [`IblJob`] the files an engine loads, [`LutJob`] BRDF tables, [`ControlJob`]
//! control maps, and [`PreviewJob`] a sphere lit by the map. Each [`Job`] checks its options
//! ([`Job::validate`]), plans its memory from the inputs' headers ([`Job::memory_estimate`],
//! refused over [`Limits::max_memory`] before anything is decoded), and writes through
//! [`output::deliver`]: inputs are never overwritten, outputs land whole or not at all, and
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
//! Below the jobs, [`convert`] loads any input as a direction-addressed environment and
//! resamples it, [`cube`] holds cube maps and their sampler, [`image`] the one pixel type, and
//! [`output`] encodes a result ([`output::Target`]) and writes it. The other modules are the
//! jobs' plumbing, public for the command line and the tests but not documented as API.
//! ARCHITECTURE.md draws the layers.

#![warn(missing_docs)]

mod alloc;
pub mod batch;
#[doc(hidden)]
pub mod chain;
#[doc(hidden)]
pub mod control;
pub mod convert;
pub mod cube;
pub mod error;
#[doc(hidden)]
pub mod filter;
#[doc(hidden)]
pub mod flux;
#[doc(hidden)]
pub mod ibl;
pub mod image;
#[doc(hidden)]
pub mod info;
#[doc(hidden)]
pub mod io;
pub mod jobs;
#[doc(hidden)]
pub mod layout;
#[doc(hidden)]
pub mod lut;
pub mod output;
#[doc(hidden)]
pub mod preview;
mod progress;
#[doc(hidden)]
pub mod resample;
mod simd;
#[doc(hidden)]
pub mod synthetic;
#[doc(hidden)]
pub mod tonemap;
#[doc(hidden)]
pub mod view;

pub use control::Size;
pub use cube::{CubeMap, Interp};
pub use error::{Error, LimitKind, Result};
pub use filter::{ChainOptions, FilterKind, IrradianceMethod, LightingModel};
pub use ibl::{Engine, IblOptions};
pub use image::Image;
pub use io::{
    Container, ExrFloat, FileFormat, GpuFormat, Limits, MapKind, ReadOptions, Session, SessionGuard,
};
pub use jobs::{
    ControlJob, ConvertJob, IblJob, IrradianceJob, Job, LutJob, LutKind, PrefilterJob, PreviewJob,
    Progress, Quality, Report, ViewJob, Warning,
};
pub use layout::Kind as Layout;
pub use output::{Destination, Encoding};
pub use preview::{Background, Options as View, Parallax, ParallaxMode, Shading};
pub use resample::{Orientation, Resampler};
pub use tonemap::Tonemap;

/// The README's Rust example, compiled and run with the doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
