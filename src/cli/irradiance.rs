//! `cubeforge irradiance`: the diffuse side: an irradiance cube map and 9 SH coefficients.

use super::Stages;
use cubeforge::convert::{self, Loaded, Output};
use cubeforge::filter::{self, sh, IrradianceMethod};
use cubeforge::io::{GpuFormat, WriteOptions};
use cubeforge::layout::Kind;
use cubeforge::output::{self, Target};
use cubeforge::resample::Resampler;
use cubeforge::{Error, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Anything `convert` reads: one image, six faces, or a folder of faces.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// As for convert: a folder receives px.exr ... (replacing what it held whole); a file gets
    /// a layout or container; - is standard output (with --format).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output layout (default: from the output's name, as for convert).
    #[arg(long, value_enum)]
    pub to: Option<Kind>,
    /// Face edge of the irradiance map (it holds no detail: 32 is plenty).
    #[arg(long, default_value_t = 32)]
    pub size: usize,
    /// Also write the 9 SH coefficients (radiance, irradiance, irradiance / pi) as JSON.
    #[arg(long)]
    pub sh: Option<PathBuf>,
    /// brute: exact integral (default; right next to HDR suns); sh: from the 9 coefficients.
    #[arg(long, value_enum, default_value_t = IrradianceMethod::Brute)]
    pub method: IrradianceMethod,
    /// File type of face images (default exr).
    #[arg(long, default_value = "exr")]
    pub format: String,
    /// Texel format of KTX2 and DDS output.
    #[arg(long, value_enum, default_value_t = GpuFormat::Rgba16f)]
    pub gpu_format: GpuFormat,
    /// Supercompress KTX2 output with Zstandard at LEVEL (1 to 22; 19 when no level is given,
    /// as in --zstd=19). Readers inflate it on load (three.js, Bevy, KTX-Software); DDS has none.
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true, default_missing_value = "19", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd: Option<i32>,
    #[command(flatten)]
    pub tone: super::ToneArgs,
    #[command(flatten)]
    pub input: super::InputArgs,
}

pub fn run(mut a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    let (output, to_stdout) = super::output_name(&a.output, Some(&a.format))?;
    a.output = output;
    if to_stdout && a.sh.is_some() {
        return Err(Error::usage(
            "-o - (standard output) takes one file: write the --sh coefficients with -o FILE",
        ));
    }
    let mut target = Target::new(&a.output, a.to, true)?;
    if target.kind == Kind::Faces {
        // Replaced whole: refuse a folder that is not cubeforge's before the work.
        output::check_folder_output(&a.output, &a.inputs, a.sh.as_slice())?;
    }
    if !to_stdout {
        target.face_format = output::face_format(&a.format)?;
    }
    target.write = WriteOptions {
        linear: a.input.linear,
        gpu_format: a.gpu_format,
        zstd: a.zstd,
        ..WriteOptions::default()
    };
    match target.kind {
        Kind::Ktx2 => {}
        Kind::Dds if a.zstd.is_some() => return Err(cubeforge::io::zstd_needs_ktx2(&a.output)),
        _ if a.zstd.is_some() => super::warn("--zstd applies to KTX2 outputs: ignored"),
        _ => {}
    }
    target.levels = Some(1);
    target.tone = a.tone.for_target(&target);
    if a.size == 0 || a.size > 4096 {
        return Err(Error::usage(format!("--size {}: use 1 to 4096", a.size)));
    }
    let read = a.input.read_options();
    // The whole plan against the budget before any file is decoded: the input, the base
    // faces it is resampled to (256 at most), the map (faces, encoding, a sampler copy).
    let plan = cubeforge::chain::plan(&a.inputs, a.input.from, &read)?;
    let base = plan.face_size.unwrap_or(256).min(256) as u64;
    let face = |n: u64| 6 * 16 * n * n;
    a.input.limits().check_memory(
        format_args!("--size {}", a.size),
        (2 * face(base) + 3 * face(a.size as u64)).saturating_add(plan.working_bytes()),
    )?;
    let loaded = convert::load_planned(&a.inputs, a.input.from, &read)?;
    stages.done("decode");
    // 256 faces hold everything the integral and the SH can see.
    let base_size = loaded.face_size().min(256);
    let base = convert::to_cube(&loaded, base_size, &Resampler::default());
    stages.done("resample");
    let bar = super::progress(6 * a.size as u64, format!("irradiance {}", a.size));
    let (irr, coeffs) = filter::irradiance_with_progress(&base, a.size, a.method, &|n| {
        if let Some(b) = &bar {
            b.inc(n);
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    stages.done("filter");

    let out = match target.kind {
        k if k == Kind::Faces || k.is_container() => Output::Cube(irr),
        to => Output::Image(convert::to_image(
            &Loaded::from_cube(irr),
            to,
            a.size,
            &Resampler::default(),
        )),
    };
    let encoded = target.encode(out, &loaded.files)?;
    if let Some(w) = &encoded.clamped {
        super::warn(w);
    }
    stages.quality(a.gpu_format, encoded.psnr);
    let encoded_folders = encoded.folders;
    let mut files = encoded.files;
    if let Some(p) = &a.sh {
        let json = serde_json::to_vec_pretty(&sh::ShFile::new(&coeffs))
            .map_err(|e| Error::usage(e.to_string()))?;
        output::refuse_inputs(std::slice::from_ref(p), &loaded.files)?;
        files.push((p.clone(), json));
    }
    stages.done("encode");
    super::deliver(&files, &encoded_folders, to_stdout)?;
    stages.done("write");
    let dc = coeffs[0].map(|v| v * sh::BASIS[0].3);
    super::report(format_args!(
        "irradiance {} px ({:?}); mean radiance {:.4} {:.4} {:.4}",
        a.size, a.method, dc[0], dc[1], dc[2]
    ))?;
    stages.total();
    Ok(())
}
