//! stub
use super::{Decoded, FileFormat, Meta, ReadOptions, WriteOptions};
use crate::error::Result;
use crate::image::Image;
use std::path::Path;
pub fn decode(_b: &[u8], _f: FileFormat, _p: &Path, _o: &ReadOptions) -> Result<(Decoded, Meta)> { todo!() }
pub fn encode(_i: &Image, _f: FileFormat, _o: &WriteOptions) -> std::result::Result<Vec<u8>, String> { todo!() }
