//! stub
use super::{Decoded, Limits, Meta};
use crate::error::Result;
use crate::image::Image;
use std::path::Path;
pub fn decode(_b: &[u8], _p: &Path, _l: &Limits) -> Result<(Decoded, Meta)> { todo!() }
pub fn encode(_i: &Image) -> std::result::Result<Vec<u8>, String> { todo!() }
