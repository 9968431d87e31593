//! An `ibl` output folder read back: the file of it that holds the specular chain (or, for the
//! engines that filter a panorama themselves, that panorama) and the engine it was made for,
//! so that every reading command takes the folder `ibl` wrote.

use super::engines::{GENERIC_SH, SPECULAR_FILES};
use super::Engine;
use std::path::{Path, PathBuf};

/// The specular file of an `ibl` output folder and its engine (None: not such a folder): what
/// `view`, `preview` and `info` read when given the folder.
pub fn specular_of(dir: &Path) -> Option<(PathBuf, Option<Engine>)> {
    if !dir.is_dir() || crate::chain::is_chain_dir(dir) {
        return None;
    }
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    names.sort();
    let ends = |p: &PathBuf, suffix: &str| p.to_string_lossy().ends_with(suffix);
    for (suffix, engine) in SPECULAR_FILES {
        if let Some(p) = names.iter().find(|p| ends(p, suffix)) {
            let stem = p.to_string_lossy();
            let stem = &stem[..stem.len() - suffix.len()];
            let generic =
                engine == Engine::Bevy && PathBuf::from(format!("{stem}{GENERIC_SH}")).is_file();
            return Some((
                p.clone(),
                Some(if generic { Engine::Generic } else { engine }),
            ));
        }
    }
    // Godot's, Unity's and Unreal's folders hold the panorama the engine filters itself.
    let images: Vec<&PathBuf> = names
        .iter()
        .filter(|p| crate::io::FileFormat::from_extension(p).is_some())
        .collect();
    // three.js's folder: NAME.jpg (UltraHDR) and its NAME.hdr fallback; the JPEG is shown.
    let stem = |p: &PathBuf| p.with_extension("");
    match images.as_slice() {
        [one] => Some(((*one).clone(), None)),
        [a, b] if stem(a) == stem(b) => {
            let jpg = |p: &PathBuf| {
                crate::io::FileFormat::from_extension(p) == Some(crate::io::FileFormat::Jpeg)
            };
            [a, b]
                .into_iter()
                .find(|p| jpg(p))
                .map(|p| ((*p).clone(), None))
        }
        _ => None,
    }
}

/// Every file some target writes into an `ibl` folder under the name stem `name`: what an
/// earlier run for another target may have left there, which a new run replaces with the
/// folder (an output folder is one target's). Anything else there stops the run.
pub(crate) fn written_by_targets(dir: &Path, name: &str) -> Vec<PathBuf> {
    const SUFFIXES: [&str; 15] = [
        "_specular.ktx2",
        "_diffuse.ktx2",
        "_ggx.ktx2",
        "_lambertian.ktx2",
        "_charlie.ktx2",
        "_ibl.ktx",
        "_irradiance.ktx",
        "_skybox.ktx",
        "_sh.json",
        "_dfg.png",
        ".env",
        ".exr",
        ".hdr",
        ".jpg",
        ".ktx2",
    ];
    const FIXED: [&str; 4] = ["lut_ggx.png", "lut_charlie.png", "sh.txt", "sun.json"];
    SUFFIXES
        .iter()
        .map(|s| dir.join(format!("{name}{s}")))
        .chain(FIXED.iter().map(|f| dir.join(f)))
        .collect()
}
