//! One input: the paths a job reads, opened from their headers into one value that knows what
//! they are, what loading them takes (planned against the memory budget before any file is
//! decoded) and how they load: whole, one level of a chain, a chain folder's every level, or a
//! large OpenEXR or .hdr panorama reduced as it is decoded. Every job reads through it, so planning
//! and loading are never paired by hand and a load's warnings are gathered in one place.

#![warn(missing_docs)]

use crate::chain::{self, ChainDir};
use crate::convert::{self, stream, InputPlan, Loaded};
use crate::error::{Error, Result};
use crate::io::{self, ReadOptions};
use crate::layout::Kind;
use std::path::{Path, PathBuf};

/// What the paths name, as found when they were opened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// One file (or standard input), any layout or container.
    File,
    /// Six face files, or a folder of six faces.
    Faces,
    /// A prefiltered chain's folder (`m0/`, `m1/`, ...).
    Chain,
}

/// How the input will be loaded: decided when it is opened, so its plan is the load's.
#[derive(Clone, Copy, Debug)]
enum Load {
    /// Everything the paths hold (a chain folder planned with all its levels).
    Whole,
    /// Level `n` of a chain folder, container or mip-mapped OpenEXR file, alone.
    Level(usize),
    /// An OpenEXR or .hdr panorama box-reduced band by band as it is decoded ([`stream`]).
    Reduced(stream::Plan),
}

/// An input opened: its paths, how they are read, and the plan of their load.
#[derive(Clone, Debug)]
pub struct Input {
    paths: Vec<PathBuf>,
    from: Option<Kind>,
    read: ReadOptions,
    kind: InputKind,
    load: Load,
    face_size: Option<usize>,
    bytes: u64,
}

impl Input {
    /// Opens `paths` whole from their headers (a chain folder with every level), checking
    /// the decode's peak against the memory budget before anything is decoded.
    pub fn open(paths: &[PathBuf], from: Option<Kind>, read: &ReadOptions) -> Result<Input> {
        let plan = chain::plan(paths, from, read)?;
        Ok(Input::planned(paths, from, read, Load::Whole, plan))
    }

    /// Opens level `level` of `paths`: a chain folder's `mN/` alone; a container's or
    /// mip-mapped OpenEXR file's level as its decoder picks it.
    pub fn open_level(
        paths: &[PathBuf],
        from: Option<Kind>,
        read: &ReadOptions,
        level: usize,
    ) -> Result<Input> {
        let plan = match paths {
            [dir] if chain::is_chain_dir(dir) && chain::level_dir(dir, level).is_dir() => {
                convert::plan_input(&[chain::level_dir(dir, level)], from, read)?
            }
            _ => chain::plan(paths, from, read)?,
        };
        Ok(Input::planned(paths, from, read, Load::Level(level), plan))
    }

    /// Opens one OpenEXR or .hdr panorama to be reduced as it is decoded, for outputs whose finest
    /// texel spans `min_footprint(face size)` radians; anything else is opened whole.
    pub fn open_reduced(
        paths: &[PathBuf],
        from: Option<Kind>,
        read: &ReadOptions,
        min_footprint: impl FnOnce(usize) -> f32,
    ) -> Result<Input> {
        let plan = match paths {
            [one] => stream::plan(one, read, min_footprint)?,
            _ => None,
        };
        let Some(p) = plan else {
            return Input::open(paths, from, read);
        };
        let planned = InputPlan {
            face_size: Some(p.face_size()),
            held_bytes: 0,
            peak_bytes: p.working_bytes(),
        };
        Ok(Input::planned(paths, from, read, Load::Reduced(p), planned))
    }

    fn planned(
        paths: &[PathBuf],
        from: Option<Kind>,
        read: &ReadOptions,
        load: Load,
        plan: InputPlan,
    ) -> Input {
        let kind = match paths {
            [dir] if chain::is_chain_dir(dir) => InputKind::Chain,
            [dir] if dir.is_dir() => InputKind::Faces,
            [_] => InputKind::File,
            _ => InputKind::Faces,
        };
        Input {
            paths: paths.to_vec(),
            from,
            read: *read,
            kind,
            load,
            face_size: plan.face_size,
            bytes: plan.working_bytes(),
        }
    }

    /// What the paths name.
    pub fn kind(&self) -> InputKind {
        self.kind
    }

    /// The paths as given.
    pub fn paths(&self) -> &[PathBuf] {
        &self.paths
    }

    /// How the files are read.
    pub fn read_options(&self) -> &ReadOptions {
        &self.read
    }

    /// The face edge that keeps the input's resolution, where the headers tell it.
    pub fn face_size(&self) -> Option<usize> {
        self.face_size
    }

    /// The input's bytes while a job works from it (its texels and their lookup pyramid, or
    /// the decode's peak): a job's memory plan is this, its work and its encoding's.
    pub fn plan_bytes(&self) -> u64 {
        self.bytes
    }

    /// Loads the input as it was opened, with the warnings of the load (how a folder's
    /// skybox names were read, which part of a multi-part OpenEXR file, values replaced).
    pub fn load(&self) -> Result<(Loaded, Vec<String>)> {
        let (paths, from, read) = (self.paths.as_slice(), self.from, &self.read);
        let loaded = match self.load {
            Load::Whole => convert::load_planned(paths, from, read)?,
            Load::Level(n) => load_level(paths, from, read, n)?,
            Load::Reduced(p) => match stream::load_planned(&paths[0], read, &p)? {
                Some(loaded) => loaded,
                // Changed since it was planned: planned again, whole.
                None => convert::load(paths, from, read)?,
            },
        };
        let warnings = warnings(&loaded, paths, read);
        Ok((loaded, warnings))
    }

    /// Loads a chain folder's every level as one cube map (the preview's and `info`'s
    /// reading), with the warning for values replaced across them.
    pub(crate) fn load_chain(&self) -> Result<(ChainDir, Vec<String>)> {
        let [dir] = self.paths.as_slice() else {
            return Err(Error::usage("a prefiltered chain is one folder"));
        };
        let c = chain::read_dir(dir, &self.read)?;
        let warnings = replaced_note(dir, c.meta.replaced_values as u64)
            .into_iter()
            .collect();
        Ok((c, warnings))
    }
}

/// Level `level` of the inputs: a chain folder's `mN/`, a mip-mapped OpenEXR file's level as
/// its decoder picks it, else the whole input with only that level kept.
fn load_level(
    inputs: &[PathBuf],
    from: Option<Kind>,
    read: &ReadOptions,
    level: usize,
) -> Result<Loaded> {
    if let [dir] = inputs {
        let sub = chain::level_dir(dir, level);
        if chain::is_chain_dir(dir) {
            if !sub.is_dir() {
                return Err(Error::file(
                    dir,
                    format!("no level {level}: no m{level} folder"),
                ));
            }
            return convert::load_planned(&[sub], from, read);
        }
    }
    if let [file] = inputs {
        if level > 0 && io::is_exr(file) {
            let read = ReadOptions {
                exr_level: level,
                ..*read
            };
            return convert::load_planned(inputs, from, &read);
        }
    }
    let mut loaded = convert::load_planned(inputs, from, read)?;
    loaded.keep_level(level)?;
    Ok(loaded)
}

/// The warnings of a load, gathered in one place for every job: how a folder's skybox names
/// or OpenEXR's split faces were read, which part of a multi-part OpenEXR file was, and how
/// many values were replaced.
fn warnings(loaded: &Loaded, inputs: &[PathBuf], read: &ReadOptions) -> Vec<String> {
    let replaced = loaded
        .files
        .first()
        .and_then(|f| replaced_note(f, loaded.meta.replaced_values as u64));
    [
        convert::skybox_note(inputs),
        part_note(loaded, read),
        replaced,
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The warning for `n` values of `file` replaced as it was read (None for none); the Python
/// package's `write` gives it for an array's.
pub fn replaced_note(file: &Path, n: u64) -> Option<String> {
    (n > 0).then(|| {
        format!(
            "{}: replaced {n} NaN, infinite or negative values by 0 (and values above 1e28 by 1e28)",
            file.display()
        )
    })
}

/// The warning for a multi-part OpenEXR input read without a part chosen: which was read.
fn part_note(loaded: &Loaded, read: &ReadOptions) -> Option<String> {
    let part = loaded
        .meta
        .part
        .as_deref()
        .filter(|_| read.exr_part.is_none())?;
    Some(format!(
        "{}: a multi-part OpenEXR file: read {part}",
        loaded.files.first()?.display()
    ))
}
