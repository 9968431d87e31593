//! The integration tests, one binary so the suite links once. `tests/hostile_inputs.rs`
//! stays apart: its allocator refuses any allocation over 1 GiB.

#[path = "../common/mod.rs"]
mod common;

mod astc;
mod atomic_writes;
mod batch;
mod batched;
mod careless;
mod chain_flux;
mod cli_errors;
mod cli_options;
mod command_reports;
mod containers;
mod control;
mod conversions;
mod doc_pictures;
mod edge_fixup;
mod engine_containers;
mod exr_envmap;
mod exr_openexr;
mod fault_campaign;
mod fault_outputs;
mod figures;
mod finite;
mod first_hour;
mod flux;
mod formats;
mod gpu_formats;
mod hdr8;
mod help_examples;
mod hostile_exr;
mod hostile_paths;
mod ibl;
mod info;
mod jobs;
mod ktx2_keys;
mod layers;
mod lut;
mod man_pages;
mod octahedral;
mod prefilter;
mod preview;
mod preview_pbr;
mod readme;
mod real_images;
mod rgbe;
mod sh_bands;
mod simd;
mod texel_truth;
mod uastc;
mod ultrahdr;
mod ultrahdr_readers;
mod view;
