//! KTX2 cube maps (stub, being written).
use super::{Decoded, GpuFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use std::path::Path;

pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

pub fn encode(_cube: &CubeMap, _format: GpuFormat) -> Vec<u8> {
    unimplemented!()
}

pub fn decode(_bytes: &[u8], path: &Path, _limits: &Limits) -> Result<(Decoded, Meta)> {
    Err(Error::file(path, "KTX2 reading is not written yet"))
}
