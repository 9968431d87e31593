//! Faces given as six files or a folder: which file is which face (the naming found), the
//! note that says how they were read, and the six loaded as one cube map.

use super::{envmap, read, Loaded, Source};
use crate::cube::{
    face_of_stem, faces_from_images, CubeMap, FaceNaming, FACE_LONG_NAMES, FACE_NAMES,
    FACE_NAMINGS, SKYBOX_WORDS,
};
use crate::error::{Error, Result};
use crate::io::{Decoded, FileFormat, Meta, ReadOptions};
use crate::layout::Kind;
use std::path::{Path, PathBuf};

/// How six face files given one by one are named: OpenEXR's where all six carry its
/// suffixes in its order, else the OpenGL table the argument order gives.
pub(super) fn naming_of(files: &[PathBuf]) -> FaceNaming {
    let openexr = files.iter().enumerate().all(|(i, f)| {
        f.file_stem()
            .and_then(|s| face_of_stem(&s.to_string_lossy()))
            .is_some_and(|(face, naming)| face == i && naming == FaceNaming::OpenExr)
    });
    if openexr {
        FaceNaming::OpenExr
    } else {
        FaceNaming::Axes
    }
}

/// Finds a folder's six faces (any supported extension) by the first naming that names one:
/// the axes (px/nx/..., posx/negx/..., Unity's PositiveX/...), OpenEXR's exrenvmap
/// (NAME+X/NAME-X/...), a skybox pack's words (right left top bottom front back, or NAME_rt
/// NAME_lf ...); and says which.
pub(crate) fn find_faces(dir: &Path) -> Result<(Vec<PathBuf>, FaceNaming)> {
    let entries: Vec<(PathBuf, usize, FaceNaming)> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| FileFormat::from_extension(p).is_some())
        .filter_map(|p| {
            let (face, naming) = face_of_stem(&p.file_stem()?.to_string_lossy())?;
            Some((p, face, naming))
        })
        .collect();
    // Axis names win over OpenEXR's, and both over skybox words, when a folder holds several.
    let naming = [FaceNaming::Axes, FaceNaming::OpenExr]
        .into_iter()
        .find(|n| entries.iter().any(|e| e.2 == *n))
        .unwrap_or(FaceNaming::Skybox);
    let mut found = Vec::new();
    for i in 0..6 {
        let mut hits: Vec<&PathBuf> = entries
            .iter()
            .filter(|e| e.1 == i && e.2 == naming)
            .map(|e| &e.0)
            .collect();
        hits.sort();
        match hits.as_slice() {
            [] if entries.is_empty() => {
                return Err(Error::file(
                    dir,
                    format!("holds no face images; faces are named {FACE_NAMINGS}"),
                ));
            }
            [] if naming == FaceNaming::Skybox => {
                let word = SKYBOX_WORDS[i];
                return Err(Error::file(
                    dir,
                    format!(
                        "face {} ({}) of a skybox pack is missing (expected {}.EXT or \
                         NAME_{}.EXT)",
                        word[0],
                        FACE_NAMES[i],
                        word[0],
                        word[word.len() - 1]
                    ),
                ));
            }
            [] if naming == FaceNaming::OpenExr => {
                return Err(Error::file(
                    dir,
                    format!(
                        "face {} of OpenEXR's split faces is missing (expected NAME{}.EXT)",
                        OPENEXR_FACES[i], OPENEXR_FACES[i]
                    ),
                ))
            }
            [] => {
                return Err(Error::file(
                    dir,
                    format!(
                        "face {} is missing (expected {}.EXT, {}.EXT or NAME_{}.EXT)",
                        FACE_NAMES[i], FACE_NAMES[i], FACE_LONG_NAMES[i], FACE_NAMES[i]
                    ),
                ))
            }
            [one] => found.push((*one).clone()),
            many => {
                return Err(Error::file(
                    dir,
                    format!(
                        "face {} is ambiguous: {}",
                        FACE_NAMES[i],
                        many.iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ))
            }
        }
    }
    Ok((found, naming))
}

/// OpenEXR's face suffixes, as messages write them.
const OPENEXR_FACES: [&str; 6] = ["+X", "-X", "+Y", "-Y", "+Z", "-Z"];

/// The warning that says how a folder's skybox names, or OpenEXR's split faces, were read
/// (None for any other input).
pub(crate) fn skybox_note(inputs: &[PathBuf]) -> Option<String> {
    let [dir] = inputs else { return None };
    match find_faces(dir) {
        Ok((_, FaceNaming::OpenExr)) if dir.is_dir() => Some(format!(
            "{}: OpenEXR's split faces (exrenvmap's NAME+X ... NAME-Z), read by OpenEXR's face \
             orientation; if they came from a cubeforge panorama through `exrenvmap -li`, they \
             are its mirror image (OpenEXR's latlong runs the other way: write the panorama \
             with --mirror first)",
            dir.display()
        )),
        Ok((files, FaceNaming::Skybox)) if dir.is_dir() => {
            let names: Vec<String> = files
                .iter()
                .filter_map(|f| Some(f.file_name()?.to_string_lossy().into_owned()))
                .collect();
            Some(format!(
                "{}: faces named as a skybox pack, read as +X -X +Y -Y +Z -Z in OpenGL's order \
                 (as LearnOpenGL loads them): {}; if the sky comes out turned or mirrored, name \
                 them px nx py ny pz nz",
                dir.display(),
                names.join(" ")
            ))
        }
        _ => None,
    }
}

pub(super) fn load_faces(
    files: &[PathBuf],
    naming: FaceNaming,
    opts: &ReadOptions,
) -> Result<Loaded> {
    let mut images = Vec::with_capacity(6);
    let mut meta: Option<Meta> = None;
    let mut replaced = 0;
    let mut formats: Vec<String> = Vec::new();
    for f in files {
        let (decoded, m) = read(f, opts)?;
        replaced += m.replaced_values;
        if !formats.contains(&m.pixel_format) {
            formats.push(m.pixel_format.clone());
        }
        match decoded {
            Decoded::Image(img) => images.push(img),
            Decoded::Cube(_) => {
                return Err(Error::file(
                    f,
                    "a face must be a single image, not a cube map",
                ))
            }
        }
        meta.get_or_insert(m);
    }
    let Some(mut meta) = meta else {
        return Err(Error::usage("no face images given"));
    };
    meta.replaced_values = replaced;
    if formats.len() > 1 {
        meta.pixel_format = format!("mixed: {}", formats.join(", "));
    }
    let cube = if naming == FaceNaming::OpenExr {
        let faces = envmap::split_cube(&images).map_err(|e| Error::file(&files[0], e))?;
        CubeMap::from_faces(faces)?
    } else {
        faces_from_images(images, files)?
    };
    Ok(Loaded {
        source: Source::Cube(cube),
        kind: Kind::Faces.into(),
        hdr: meta.hdr,
        meta,
        files: files.to_vec(),
    })
}
