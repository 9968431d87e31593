//! cubeforge: turn photographs into cube maps and check them.
//!
//! Data flows image -> cube map -> (mip chain) -> writer. Every layout is a mapping between
//! directions and image coordinates ([`layout`]); every conversion looks each output texel's
//! direction up in an [`cube::Environment`] ([`resample`]).

pub mod control;
pub mod convert;
pub mod cube;
pub mod error;
pub mod filter;
pub mod flux;
pub mod image;
pub mod info;
pub mod io;
pub mod layout;
pub mod preview;
pub mod resample;
pub mod synthetic;

pub use error::{Error, Result};
