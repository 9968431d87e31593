//! Prefiltered chains on disk. A chain folder holds `m0/`, `m1/`, ... (each a folder of six
//! faces, each level half the size of the one before) and `levels.json`; a KTX2 or DDS chain
//! keeps the same description beside it in `NAME.ktx2.levels.json` or `NAME.dds.levels.json`
//! (a KTX2 with `--cubeforge-keys` under [`crate::io::ktx2::LEVELS_KEY`] instead, which
//! `ktx validate -e` rejects). One schema, [`LevelsFile`], for all of them.

#![warn(missing_docs)]

use crate::convert::{self, Source};
use crate::cube::{CubeMap, Faces};
use crate::error::{Error, Result};
use crate::filter::{ChainOptions, FilterKind, LevelInfo, LightingModel};
use crate::io::{self, FileFormat, Meta, ReadOptions, WriteOptions};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The name of a chain folder's description.
pub(crate) const LEVELS_JSON: &str = "levels.json";

/// What a prefiltered chain holds, level by level: how `cubeforge prefilter` made it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelsFile {
    /// The filter every level was made with.
    pub filter: FilterKind,
    /// Edge of level 0's faces, texels.
    pub face_size: usize,
    /// Levels in the chain (`levels.len()`).
    pub level_count: usize,
    /// `--min-size`: the chain was stopped at the level whose faces are at least this large
    /// (its roughness mapping spans the shortened chain).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub min_size: Option<usize>,
    /// Cosine chains only: the lighting model applied to each level's power.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub lighting: Option<LightingModel>,
    /// Cosine chains only: `--gloss-scale` of the level-to-power mapping.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub gloss_scale: Option<f32>,
    /// Cosine chains only: `--gloss-bias` of the level-to-power mapping.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub gloss_bias: Option<f32>,
    /// One entry per level, level 0 first.
    pub levels: Vec<LevelInfo>,
}

impl LevelsFile {
    /// The description of a chain made with `opts` from a base of `face_size`.
    pub fn new(opts: &ChainOptions, face_size: usize, levels: Vec<LevelInfo>) -> LevelsFile {
        let cosine = opts.filter == FilterKind::Cosine;
        LevelsFile {
            filter: opts.filter,
            face_size,
            level_count: levels.len(),
            min_size: opts.min_size,
            lighting: cosine.then_some(opts.lighting),
            gloss_scale: cosine.then_some(opts.gloss_scale),
            gloss_bias: cosine.then_some(opts.gloss_bias),
            levels,
        }
    }

    pub(crate) fn to_json(&self) -> Vec<u8> {
        // Plain numbers, strings and lists: serialising cannot fail.
        serde_json::to_vec_pretty(self).unwrap_or_default()
    }

    /// Parses a description; `path` names it in errors.
    pub(crate) fn from_json(bytes: &[u8], path: &Path) -> Result<LevelsFile> {
        serde_json::from_slice(bytes)
            .map_err(|e| Error::file(path, format!("not a levels description: {e}")))
    }
}

/// Whether `dir` is a chain folder (it holds `m0/`).
pub fn is_chain_dir(dir: &Path) -> bool {
    dir.join("m0").is_dir()
}

/// The folder of level `k`.
pub fn level_dir(dir: &Path, k: usize) -> PathBuf {
    dir.join(format!("m{k}"))
}

/// Where a container chain's description goes: `NAME.dds.levels.json`, `NAME.ktx2.levels.json`.
pub(crate) fn levels_sidecar(file: &Path) -> PathBuf {
    let mut s = file.as_os_str().to_owned();
    s.push(".levels.json");
    PathBuf::from(s)
}

/// The description stored with a KTX2 or DDS chain, if it has one that parses.
pub(crate) fn container_levels(
    path: &Path,
    format: FileFormat,
    session: io::Session,
) -> Option<LevelsFile> {
    let key = match format {
        FileFormat::Ktx2 => io::ktx2::metadata_from_file(path)
            .into_iter()
            .find(|(k, _)| k == io::ktx2::LEVELS_KEY)
            .map(|(_, v)| v),
        FileFormat::Dds => None,
        _ => return None,
    };
    let bytes = match key {
        Some(bytes) => bytes,
        None => {
            let side = levels_sidecar(path);
            let bytes = io::read_file(&side).ok()?;
            session.note(&side);
            bytes
        }
    };
    LevelsFile::from_json(&bytes, path).ok()
}

/// [`convert::plan_input`], where a chain folder counts all its levels: what loading `inputs`
/// will take, checked against the memory budget before any file is decoded (jobs plan
/// through [`crate::input::Input`]).
pub(crate) fn plan(
    inputs: &[PathBuf],
    from: Option<crate::layout::Kind>,
    opts: &ReadOptions,
) -> Result<convert::InputPlan> {
    match inputs {
        [dir] if is_chain_dir(dir) => {
            let mut files = Vec::new();
            for k in 0.. {
                let sub = level_dir(dir, k);
                if !sub.is_dir() {
                    break;
                }
                files.extend(convert::find_faces(&sub)?.0);
            }
            convert::plan_files(&files, from, opts)
        }
        _ => convert::plan_input(inputs, from, opts),
    }
}

/// A chain folder as read.
pub(crate) struct ChainDir {
    pub cube: CubeMap,
    /// Every face file read.
    pub files: Vec<PathBuf>,
    /// Level 0's description; `hdr` if any level holds values above 1, `replaced_values`
    /// summed over the levels.
    pub meta: Meta,
    pub levels: Option<LevelsFile>,
}

/// Reads a chain folder: every `mK/` while they last, each half the size of the one before,
/// and `levels.json` if present (it must list as many levels).
pub(crate) fn read_dir(dir: &Path, opts: &ReadOptions) -> Result<ChainDir> {
    // Every level's faces within the budget together, before any is decoded.
    plan(std::slice::from_ref(&dir.to_path_buf()), None, opts)?;
    let mut levels: Vec<Faces> = Vec::new();
    let mut files = Vec::new();
    let mut meta: Option<Meta> = None;
    for k in 0.. {
        let sub = level_dir(dir, k);
        if !sub.is_dir() {
            break;
        }
        let loaded = convert::load_planned(std::slice::from_ref(&sub), None, opts)?;
        let Source::Cube(mut c) = loaded.source else {
            return Err(Error::file(
                &sub,
                "a chain level must be a folder of six faces",
            ));
        };
        if let Some(prev) = levels.last() {
            let want = (prev[0].width / 2).max(1);
            if c.size() != want {
                return Err(Error::file(
                    &sub,
                    format!(
                        "faces are {0}x{0}, but level m{k} of a chain must be {1}x{1} (half of m{2})",
                        c.size(),
                        want,
                        k - 1
                    ),
                ));
            }
        }
        match &mut meta {
            None => meta = Some(loaded.meta),
            Some(m) => {
                m.hdr |= loaded.meta.hdr;
                m.replaced_values += loaded.meta.replaced_values;
            }
        }
        files.extend(loaded.files);
        levels.push(c.levels.swap_remove(0));
    }
    let Some(meta) = meta else {
        return Err(Error::file(dir, "not a chain folder: it holds no m0/"));
    };
    let json = dir.join(LEVELS_JSON);
    let description = if json.exists() {
        // A hand-made description may hold less than cubeforge writes: any JSON is taken,
        // and a `levels` list must match the folders.
        opts.limits.session.note(&json);
        let bytes = io::read_file(&json)?;
        let value: serde_json::Value = serde_json::from_slice(&bytes)
            .map_err(|e| Error::file(&json, format!("not valid JSON: {e}")))?;
        if let Some(listed) = value.get("levels").and_then(|l| l.as_array()) {
            if listed.len() != levels.len() {
                return Err(Error::file(
                    &json,
                    format!(
                        "lists {} levels but the folder holds {} (m0 to m{})",
                        listed.len(),
                        levels.len(),
                        levels.len() - 1
                    ),
                ));
            }
        }
        serde_json::from_value(value).ok()
    } else {
        None
    };
    Ok(ChainDir {
        cube: CubeMap { levels },
        files,
        meta,
        levels: description,
    })
}

/// The files of a chain folder: `mK/px.EXT` ... for every level, and `levels.json`.
pub(crate) fn encode_dir(
    dir: &Path,
    chain: &CubeMap,
    description: &LevelsFile,
    face_format: FileFormat,
    write: (&WriteOptions, Option<crate::tonemap::Tonemap>),
    inputs: &[PathBuf],
) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    crate::output::refuse_folder(dir, inputs)?;
    let mut files = Vec::new();
    for (k, faces) in chain.levels.iter().enumerate() {
        files.extend(crate::output::encode_faces(
            &level_dir(dir, k),
            faces,
            face_format,
            write,
            inputs,
        )?);
    }
    files.push((dir.join(LEVELS_JSON), description.to_json()));
    Ok(files)
}

/// The files a chain becomes at `target` (as [`crate::output::Encoding::resolve`] decided
/// it): a KTX2 or DDS and its sidecar (a KTX2 with `cubeforge_keys` holds the description
/// in its metadata instead), a KTX or .env, or
/// a chain folder of faces, with the count of texels every level had clamped to the format's
/// range and a lossy format's quality, as [`crate::output::Target::encode`] reports them.
/// Refuses to overwrite any of `inputs`.
pub fn encode(
    target: &crate::output::Target,
    chain: &CubeMap,
    description: &LevelsFile,
    inputs: &[PathBuf],
) -> Result<crate::output::Encoded> {
    let path = target.path.as_path();
    let refuse = |p: &[PathBuf]| crate::output::refuse_inputs(p, inputs);
    let format = target.format().ok_or_else(|| io::unknown_ext(path))?;
    let container = format.is_container().then_some(format);
    let opts = target.write;
    let moved;
    let chain = match opts.edge_fixup {
        crate::cube::EdgeFixup::None => chain,
        mode => {
            moved = crate::cube::fixup::apply_cube(chain.clone(), mode);
            &moved
        }
    };
    let clamped = io::clamp_warning_with(path, format, &opts, chain.levels.iter().flatten());
    let files = match container {
        Some(FileFormat::Ktx2) if opts.cubeforge_keys => {
            refuse(&[path.to_path_buf()])?;
            let json = description.to_json();
            let bytes = crate::output::encode_cube_as(
                format,
                path,
                chain,
                &opts,
                &[(io::ktx2::LEVELS_KEY, &json)],
            )?;
            vec![(path.to_path_buf(), bytes)]
        }
        Some(FileFormat::Ktx2 | FileFormat::Dds) => {
            // DDS has no room for metadata, and KTX2's keys are the specification's: a
            // sidecar that `info` and `preview` read.
            let side = levels_sidecar(path);
            refuse(&[path.to_path_buf(), side.clone()])?;
            let bytes = crate::output::encode_cube_as(format, path, chain, &opts, &[])?;
            vec![(path.to_path_buf(), bytes), (side, description.to_json())]
        }
        Some(_) => {
            // KTX 1 and .env: the engines' own containers, read by their own level mappings.
            refuse(&[path.to_path_buf()])?;
            vec![(
                path.to_path_buf(),
                crate::output::encode_cube_as(format, path, chain, &opts, &[])?,
            )]
        }
        None => encode_dir(
            path,
            chain,
            description,
            format,
            (&opts, target.gain_map),
            inputs,
        )?,
    };
    let psnr = match &files[..] {
        [(_, bytes), ..] if container.is_some() && opts.gpu_format.is_lossy() => {
            let faces: Vec<&crate::image::Image> = chain.levels[0].iter().collect();
            io::container_psnr(bytes, opts.gpu_format, &faces)
        }
        _ => None,
    };
    Ok(crate::output::Encoded {
        files,
        clamped,
        psnr,
        folders: if container.is_none() {
            vec![path.to_path_buf()]
        } else {
            Vec::new()
        },
        gain_map: None,
    })
}
