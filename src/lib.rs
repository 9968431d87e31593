//! cubeforge: turn photographs into cube maps and check them.
//!
//! Data flows image -> cube map -> (mip chain) -> writer. Every layout is a mapping between
//! directions and image coordinates ([`layout`]); every conversion looks each output texel's
//! direction up in an [`cube::Environment`] ([`resample`]).
//!
//! A panorama to a KTX2 cube map with its mip chain, without the command line:
//!
//! ```
//! use cubeforge::{convert, io::ReadOptions, output::Target, resample::Resampler};
//!
//! # fn main() -> cubeforge::Result<()> {
//! let input = convert::load(&["fixtures/sky.exr".into()], None, &ReadOptions::default())?;
//! let cube = convert::to_cube(&input, 64, &Resampler::default());
//! let out = std::env::temp_dir().join("cubeforge-doc-sky.ktx2");
//! let target = Target::new(&out, None, input.hdr)?; // layout and format from the name
//! target.encode(convert::Output::Cube(cube), &input.files)?.write()?; // all or nothing
//! # std::fs::remove_file(&out).ok();
//! # Ok(())
//! # }
//! ```

#![warn(missing_docs)]

mod alloc;
pub mod chain;
pub mod control;
pub mod convert;
pub mod cube;
pub mod error;
pub mod filter;
pub mod flux;
pub mod ibl;
pub mod image;
pub mod info;
pub mod io;
pub mod jobs;
pub mod layout;
pub mod lut;
pub mod output;
pub mod preview;
pub mod resample;
mod simd;
pub mod synthetic;
pub mod tonemap;

pub use error::{Error, LimitKind, Result};
pub use jobs::{ConvertJob, Job, Progress, Quality, Report, Warning};
pub use output::Destination;
