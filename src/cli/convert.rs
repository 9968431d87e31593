//! `cubeforge convert`: any layout to any other.

use super::{warn, Stages};
use cubeforge::convert::{self, Output};
use cubeforge::cube::{CubeMap, Faces, Interp, FACE_NAMES};
use cubeforge::io::{self, FileFormat, GpuFormat, WriteOptions};
use cubeforge::layout::Kind;
use cubeforge::preview::tonemap;
use cubeforge::resample::{Orientation, Resampler};
use cubeforge::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// One image; six face images in px nx py ny pz nz order; or a folder of px/nx/... faces.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output file, folder for --to faces, or - for standard output (with --format).
    #[arg(short, long, allow_hyphen_values = true)]
    pub output: PathBuf,
    /// Output layout (default: from the output's extension; hcross for images, faces for a folder).
    #[arg(long, value_enum)]
    pub to: Option<Kind>,
    /// Cube face edge in texels (equirect output is 4N x 2N, sphere and angular 2N x 2N).
    #[arg(long)]
    pub size: Option<usize>,
    /// File type of face images (png, jpg, tga, hdr, exr; default exr for HDR input, png for
    /// LDR), or of the output written to standard output (-o -; also ktx2, dds).
    #[arg(long)]
    pub format: Option<String>,
    /// Interpolation between input texels.
    #[arg(long, value_enum, default_value_t = Interp::Bilinear)]
    pub interp: Interp,
    /// Turn off supersampling of coarse outputs (faster, aliases when shrinking).
    #[arg(long)]
    pub no_antialias: bool,
    /// Rotate the environment about +Y, degrees (90 brings the old centre +Z to +X).
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw: f32,
    /// Rotate the environment about +X, degrees.
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub pitch: f32,
    /// Rotate the environment about +Z, degrees.
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub roll: f32,
    /// Flip handedness (mirror X) for engines with the other convention.
    #[arg(long)]
    pub mirror: bool,
    /// Write 16-bit PNG instead of 8-bit.
    #[arg(long)]
    pub png16: bool,
    /// Texel format of KTX2 and DDS output (default rgba16f).
    #[arg(long, value_enum)]
    pub gpu_format: Option<GpuFormat>,
    /// Mip levels in KTX2 and DDS output (default: the full chain down to 1x1).
    #[arg(long)]
    pub levels: Option<usize>,
    /// Which level of a KTX2 or DDS mip chain (or which mN folder of a prefiltered chain) to
    /// read; 0 is the full size.
    #[arg(long, default_value_t = 0)]
    pub level: usize,
    #[command(flatten)]
    pub tone: super::ToneArgs,
    #[command(flatten)]
    pub input: super::InputArgs,
}

pub fn run(mut a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    let (output, to_stdout) = super::output_name(&a.output, a.format.as_deref())?;
    a.output = output;
    let limits = a.input.limits();
    let read = a.input.read_options();
    let to = output_kind(&a)?;
    // Say which options this output ignores, and refuse the impossible, before the decode.
    let container = matches!(to, Kind::Ktx2 | Kind::Dds);
    if !container {
        if a.levels.is_some() {
            warn("--levels applies to KTX2 and DDS outputs: ignored");
        }
        if a.gpu_format.is_some() {
            warn("--gpu-format applies to KTX2 and DDS outputs: ignored");
        }
    }
    if a.levels == Some(0) {
        return Err(Error::usage("--levels 0: a map has at least 1 level"));
    }
    if to == Kind::Faces && a.to.is_none() && a.output.extension().is_none() && !a.output.exists() {
        warn(format!(
            "{}: no file extension, so six faces go into this new folder (--to faces)",
            a.output.display()
        ));
    }
    // Check the options before the (possibly slow) decode.
    let face_format = match to {
        Kind::Faces => face_format(&a)?,
        _ => None,
    };
    let loaded = load_level(&a.inputs, a.input.from, &read, a.level)?;
    stages.done("decode");
    if loaded.meta.replaced_values > 0 {
        warn(format!(
            "{}: replaced {} NaN, infinite or negative values by 0 (and values above 1e28 by 1e28)",
            loaded.files[0].display(),
            loaded.meta.replaced_values
        ));
    }
    let size = a.size.unwrap_or_else(|| loaded.face_size());
    if size == 0 {
        return Err(Error::usage("--size must be at least 1"));
    }
    if let (Some(n), true) = (a.levels, container) {
        let most = CubeMap::full_chain_len(size);
        if n > most {
            return Err(Error::usage(format!(
                "--levels {n}: a cube map of {size} px has 1 to {most} levels"
            )));
        }
    }
    let (w, h) = to.image_size(size);
    if w as u64 * h as u64 > limits.max_pixels || w.max(h) > limits.max_dimension as usize {
        return Err(Error::usage(format!(
            "--size {size} makes a {w}x{h} output, over the size limit (--max-pixels)"
        )));
    }
    // The output (RGBA f32, twice over for mips and encoding) and the input's pyramid.
    let texels = if to.projection().is_some() || to.is_cells() {
        w as u64 * h as u64
    } else {
        6 * size as u64 * size as u64
    };
    let input: u64 = loaded.images().iter().map(|i| i.pixels.len() as u64).sum();
    limits.check_memory(
        format_args!("--size {size} ({w}x{h} output)"),
        (texels * 2 + input / 2) * 16,
    )?;
    let hdr_out = loaded.hdr;
    let face_format = face_format.unwrap_or(if hdr_out {
        FileFormat::Exr
    } else {
        FileFormat::Png
    });

    let resampler = Resampler {
        interp: a.interp,
        antialias: !a.no_antialias,
        orientation: Orientation {
            yaw: a.yaw,
            pitch: a.pitch,
            roll: a.roll,
            mirror: a.mirror,
        },
    };
    let out = convert::convert(&loaded, to, size, &resampler);
    stages.done("resample");

    let write = WriteOptions {
        linear: a.input.linear,
        png16: a.png16,
        gpu_format: a.gpu_format.unwrap_or_default(),
    };
    let files = encode_output(
        &a.output,
        to,
        out,
        face_format,
        &write,
        a.levels,
        &a.tone,
        &loaded.files,
    )?;
    stages.done("encode");
    super::deliver(&files, to_stdout)?;
    stages.done("write");
    stages.total();
    Ok(())
}

/// Loads the inputs, then keeps only level `level` of a mip chain. A prefiltered chain's
/// folder (m0, m1, ...) gives its `mN` folder.
pub(super) fn load_level(
    inputs: &[PathBuf],
    from: Option<Kind>,
    read: &io::ReadOptions,
    level: usize,
) -> Result<convert::Loaded> {
    if let [dir] = inputs {
        let sub = dir.join(format!("m{level}"));
        if dir.is_dir() && dir.join("m0").is_dir() {
            if !sub.is_dir() {
                return Err(Error::file(
                    dir,
                    format!("--level {level}: no m{level} folder"),
                ));
            }
            return convert::load(&[sub], from, read);
        }
    }
    let mut loaded = convert::load(inputs, from, read)?;
    loaded.keep_level(level)?;
    Ok(loaded)
}

/// Encodes a conversion's result as the files it becomes: six faces in a folder, a container
/// with `levels` box mips (None: the full chain), or one image. 8-bit outputs get the
/// exposure and tone curve. Refuses to overwrite inputs.
#[allow(clippy::too_many_arguments)]
pub(super) fn encode_output(
    output: &Path,
    to: Kind,
    mut out: Output,
    face_format: FileFormat,
    write: &WriteOptions,
    levels: Option<usize>,
    tone: &super::ToneArgs,
    inputs: &[PathBuf],
) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let format = match to {
        Kind::Faces => Some(face_format),
        _ => FileFormat::from_extension(output),
    };
    let mut images: Vec<&mut cubeforge::image::Image> = match &mut out {
        Output::Cube(c) => c.levels[0].iter_mut().collect(),
        Output::Image(img) => vec![img],
    };
    if let Some(f) = format {
        if tone.applies(output, f, write.gpu_format) {
            for img in &mut images {
                tonemap::apply(img, tone.tonemap, tone.exposure);
            }
        }
    }
    let images = images.into_iter().map(|i| &*i);
    if let Some(f) = format {
        // Box mips are means of level 0: they fit where it fits.
        if let Some(w) = io::clamp_warning(output, f, write.gpu_format, images) {
            super::warn(w);
        }
    }
    match (to, out) {
        (Kind::Faces, Output::Cube(cube)) => {
            encode_faces(output, &cube.levels[0], face_format, write, inputs)
        }
        (Kind::Ktx2 | Kind::Dds, Output::Cube(cube)) => {
            refuse_inputs(&[output.to_path_buf()], inputs)?;
            let cube: CubeMap = cube.with_box_mips(levels);
            Ok(vec![(
                output.to_path_buf(),
                io::encode_cube(output, &cube, write.gpu_format)?,
            )])
        }
        (_, Output::Image(img)) => {
            refuse_inputs(&[output.to_path_buf()], inputs)?;
            Ok(vec![(
                output.to_path_buf(),
                io::encode_image(output, &img, write)?,
            )])
        }
        (_, Output::Cube(_)) => unreachable!("only faces and containers produce cube output"),
    }
}

/// Six face images `dir/px.EXT` ... encoded in parallel; the folder is created.
pub(super) fn encode_faces(
    dir: &Path,
    faces: &Faces,
    format: FileFormat,
    write: &WriteOptions,
    inputs: &[PathBuf],
) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let ext = match format {
        FileFormat::Jpeg => "jpg",
        FileFormat::Png => "png",
        FileFormat::Tga => "tga",
        FileFormat::Hdr => "hdr",
        _ => "exr",
    };
    let paths: Vec<PathBuf> = FACE_NAMES
        .iter()
        .map(|n| dir.join(format!("{n}.{ext}")))
        .collect();
    refuse_inputs(&paths, inputs)?;
    let encoded: Vec<Result<Vec<u8>>> = {
        use rayon::prelude::*;
        paths
            .par_iter()
            .zip(faces.par_iter())
            .map(|(p, f)| io::encode_image(p, f, write))
            .collect()
    };
    paths
        .into_iter()
        .zip(encoded)
        .map(|(p, e)| e.map(|b| (p, b)))
        .collect()
}

/// The output layout: --to, or what the output's name implies.
fn output_kind(a: &Args) -> Result<Kind> {
    output_kind_for(&a.output, a.to)
}

pub(super) fn output_kind_for(output: &Path, to: Option<Kind>) -> Result<Kind> {
    let by_name = FileFormat::from_extension(output);
    match (to, by_name) {
        (Some(Kind::Ktx2), Some(FileFormat::Ktx2)) | (Some(Kind::Dds), Some(FileFormat::Dds)) => {
            Ok(to.unwrap())
        }
        (Some(k @ (Kind::Ktx2 | Kind::Dds)), _) => Err(Error::file(
            output,
            format!("--to {} needs an output named .{}", k.name(), k.name()),
        )),
        (Some(Kind::Faces), Some(_)) => Err(Error::file(
            output,
            "--to faces writes a folder: give a folder name without an image extension",
        )),
        (Some(Kind::Faces), None) => Ok(Kind::Faces),
        (Some(k), Some(f)) if f.is_container() => Err(Error::file(
            output,
            format!(
                "{} holds cube maps, not a {} image: use --to {}",
                f.name(),
                k.name(),
                if f == FileFormat::Dds { "dds" } else { "ktx2" }
            ),
        )),
        (Some(k), Some(_)) => Ok(k),
        (Some(k), None) => Err(Error::file(
            output,
            format!(
                "a {} image needs a file name ending in .png .jpg .tga .hdr or .exr",
                k.name()
            ),
        )),
        (None, Some(FileFormat::Ktx2)) => Ok(Kind::Ktx2),
        (None, Some(FileFormat::Dds)) => Ok(Kind::Dds),
        (None, Some(_)) => Ok(Kind::Hcross),
        (None, None) if output.extension().is_some() && !output.is_dir() => {
            Err(io::unknown_ext(output))
        }
        (None, None) => Ok(Kind::Faces),
    }
}

fn face_format(a: &Args) -> Result<Option<FileFormat>> {
    match &a.format {
        None => Ok(None),
        Some(f) => match FileFormat::from_ext_str(f) {
            Some(ff) if !ff.is_container() => Ok(Some(ff)),
            _ => Err(Error::usage(format!(
                "--format {f}: face images are png, jpg, tga, hdr or exr"
            ))),
        },
    }
}

/// Refuses to write over any input file.
pub(super) fn refuse_inputs(outputs: &[PathBuf], inputs: &[PathBuf]) -> Result<()> {
    let canon = |p: &Path| std::fs::canonicalize(p).ok();
    let ins: Vec<PathBuf> = inputs.iter().filter_map(|p| canon(p)).collect();
    for o in outputs {
        if let Some(c) = canon(o) {
            if ins.contains(&c) {
                return Err(Error::file(o, "refusing to overwrite an input file"));
            }
        }
    }
    Ok(())
}
