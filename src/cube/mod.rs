//! Cube maps: six square faces in the OpenGL face-selection convention, their mip levels,
//! direction <-> texel mapping (written once, here) and seamless sampling across face edges.

#![warn(missing_docs)]

// Face addressing (face), the stored map and its mips (map), what every layout is sampled
// through (environment), and the bordered sampler with its batched lookups (sampler). The
// public items are re-exported here: callers name `cube::X`.
mod environment;
mod face;
pub mod fixup;
mod map;
mod sampler;

pub use environment::{Dirs, Environment, Interp, BATCH};
pub(crate) use face::SKYBOX_WORDS;
pub use face::{
    dir_face, face_dir, face_of_stem, solid_angle_table, texel_dir, FaceNaming, FACE_LONG_NAMES,
    FACE_NAMES, FACE_NAMINGS,
};
pub(crate) use face::{texel_angle, texel_density, texel_footprint, texel_solid_angle};
pub use fixup::EdgeFixup;
pub(crate) use map::{box_reduce_face, faces_from_images, try_faces};
pub use map::{CubeMap, Faces};
pub use sampler::CubeSampler;
pub(crate) use sampler::{TapLevels, TapScratch};
