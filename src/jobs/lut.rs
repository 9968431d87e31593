//! `lut` as a job: the BRDF lookup tables a split-sum shader samples beside the chain.

use super::{Job, Progress, Report, Text, Warning, Warnings};
use crate::error::{param, Error, Result};
use crate::io::{self, ktx2, FileFormat, GpuFormat, Limits};
use crate::lut::{self, LutOptions};
use crate::output::{self, Destination, Encoding, Files};
use std::path::{Path, PathBuf};

/// The files a table (or a control map) is written as: 8- or 16-bit PNG, half-float EXR,
/// or a one-level KTX2.
pub(crate) const TABLE_FORMATS: &str = ".png, .exr or .ktx2";

/// Which table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LutKind {
    /// GGX DFG: R = scale, G = bias.
    #[default]
    Dfg,
    /// Filament's multiscatter DFG: R = DFG1, G = DFG2.
    Multiscatter,
    /// Charlie sheen albedo in R, G and B.
    Charlie,
}

/// A BRDF lookup table as .png, .exr or .ktx2.
#[derive(Clone, Debug)]
pub struct LutJob {
    /// The file written.
    pub output: PathBuf,
    /// Which table.
    pub kind: LutKind,
    /// Table edge, texels (n.v across, roughness down).
    pub size: usize,
    /// Hammersley samples per texel.
    pub samples: u32,
    /// How the table is stored: 16-bit PNG, the EXR sample type.
    pub encoding: Encoding,
    /// The memory budget (only `max_memory` applies).
    pub limits: Limits,
}

impl LutJob {
    /// The GGX DFG table at `output`, at the default size and samples.
    pub fn new(output: PathBuf) -> LutJob {
        LutJob {
            output,
            kind: LutKind::Dfg,
            size: lut::DEFAULT_SIZE,
            samples: lut::DEFAULT_SAMPLES,
            encoding: Encoding::default(),
            limits: Limits::default(),
        }
    }

    fn format(&self) -> Result<FileFormat> {
        table_format(&self.output, "a lookup table", self.encoding.png16)
    }
}

/// The file type of a table or a control map at `output` ([`TABLE_FORMATS`]); `png16` is
/// refused for any other than PNG. `what` names the output in the message.
pub(crate) fn table_format(output: &Path, what: &str, png16: bool) -> Result<FileFormat> {
    let format = match FileFormat::from_extension(output) {
        Some(f @ (FileFormat::Png | FileFormat::Exr | FileFormat::Ktx2)) => f,
        _ => {
            return Err(Error::file(
                output,
                format!("{what} is written as {TABLE_FORMATS}"),
            ))
        }
    };
    if png16 && format != FileFormat::Png {
        return Err(Error::usage(format!(
            "{} applies to PNG output only",
            param("png16")
        )));
    }
    Ok(format)
}

impl Job for LutJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        self.format()?;
        if !(2..=4096).contains(&self.size) || self.samples == 0 {
            return Err(Error::usage(format!(
                "{} {} with {} {}: use a size of 2 to 4096 and at least 1 sample",
                param("size"),
                self.size,
                param("samples"),
                self.samples
            )));
        }
        Ok(Vec::new())
    }

    /// The table (RGBA f32), its encoding and a KTX2's mip chain.
    fn memory_estimate(&self) -> Result<u64> {
        Ok((self.size as u64).pow(2) * 16 * 3)
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        let format = self.format()?;
        let size = self.size;
        self.limits.check_memory(
            format_args!("{} {size}", param("size")),
            self.memory_estimate()?,
        )?;
        let opts = LutOptions {
            multiscatter: self.kind == LutKind::Multiscatter,
            samples: self.samples,
        };
        let (table, what) = match self.kind {
            LutKind::Charlie => (
                lut::charlie(size, &opts),
                "Charlie sheen table (E in R, G, B)",
            ),
            LutKind::Multiscatter => (
                lut::dfg(size, &opts),
                "multiscatter DFG table (R = DFG1, G = DFG2)",
            ),
            LutKind::Dfg => (lut::dfg(size, &opts), "DFG table (R = scale, G = bias)"),
        };
        progress.stage("integrate");

        // Data, not colour: no sRGB encode.
        let write = self.encoding.write_options(true);
        let (bytes, encoding) = match format {
            FileFormat::Ktx2 => (
                ktx2::encode_2d(std::slice::from_ref(&table), GpuFormat::Rgba16f),
                "KTX2 RGBA16F".to_string(),
            ),
            FileFormat::Exr => (
                crate::output::encode_image_as(format, &self.output, &table, &write)?,
                "half-float EXR".to_string(),
            ),
            _ => {
                let above = io::count_out_of_range([&table], 1.0);
                if above > 0 {
                    warnings.push(format_args!(
                        "{}: {above} values above 1 written as 1 (PNG holds 0 to 1); .exr or .ktx2 keep them",
                        self.output.display()
                    ));
                }
                let bits = if self.encoding.png16 { 16 } else { 8 };
                (
                    crate::output::encode_image_as(format, &self.output, &table, &write)?,
                    format!("{bits}-bit PNG, linear"),
                )
            }
        };
        if format != FileFormat::Png {
            if let Some(w) = io::clamp_warning(&self.output, format, GpuFormat::Rgba16f, [&table]) {
                warnings.push(w);
            }
        }
        progress.stage("encode");
        let files = Files::new(vec![(self.output.clone(), bytes)]);
        output::deliver(&files, &Destination::Path(self.output.clone()), &[])?;
        progress.stage("write");
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: vec![Text::new(format!(
                "{}: {size}x{size} {what}, {} samples a texel, {encoding}; x = n.v, y = roughness, roughness 0 in the top row",
                self.output.display(),
                self.samples
            ))],
            quality: None,
        })
    }

    fn limits_mut(&mut self) -> &mut crate::io::Limits {
        &mut self.limits
    }
}
