//! DDS cube maps (stub, being written).
use super::{Decoded, GpuFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use std::path::Path;

pub fn encode(_cube: &CubeMap, _format: GpuFormat) -> std::result::Result<Vec<u8>, String> {
    Err("DDS writing is not written yet".into())
}

pub fn decode(_bytes: &[u8], path: &Path, _limits: &Limits) -> Result<(Decoded, Meta)> {
    Err(Error::file(path, "DDS reading is not written yet"))
}
