//! Folder outputs (six faces, a prefiltered chain) replaced whole. cubeforge only replaces a
//! folder it could have written: faces, `mN/` levels of faces, `levels.json`, the names the
//! command writes now, and its own leftover temporaries. Anything else (a photo, a notes
//! file) makes it refuse: emptying a folder of someone's files is never the right guess.

use super::{exchange_folders, guarded, move_registered, temp_name};
use crate::cube::{FACE_LONG_NAMES, FACE_NAMES};
use crate::error::{Error, Result};
use crate::io::FileFormat;
use std::path::{Path, PathBuf};

/// Files the desktop leaves in any folder it shows: never a reason to refuse one.
const DESKTOP_LITTER: [&str; 3] = [".DS_Store", "Thumbs.db", "desktop.ini"];

/// Whether `dir` may be replaced whole by a folder output that writes `writing` (paths under
/// it): it does not exist, or it is a folder of what cubeforge writes there. Refuses a file in
/// the way, the current folder (or one above it), and a folder holding anything else.
pub fn check_folder(dir: &Path, writing: &[PathBuf]) -> Result<()> {
    let meta = match std::fs::symlink_metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(Error::io(dir, e)),
    };
    let real = if meta.file_type().is_symlink() {
        std::fs::canonicalize(dir).map_err(|e| Error::io(dir, e))?
    } else {
        dir.to_path_buf()
    };
    if !real.is_dir() {
        return Err(Error::file(
            dir,
            "a file of that name is in the way of the output folder",
        ));
    }
    if let (Ok(cwd), Ok(c)) = (std::env::current_dir(), std::fs::canonicalize(&real)) {
        if cwd.starts_with(&c) {
            return Err(Error::file(
                dir,
                "is the current folder (or holds it): cubeforge replaces an output folder whole, so name a folder inside it",
            ));
        }
    }
    let written: Vec<PathBuf> = writing
        .iter()
        .filter_map(|p| p.strip_prefix(dir).ok().map(Path::to_path_buf))
        .collect();
    if let Some(stranger) = foreign_entry(&real, Path::new(""), &written)? {
        return Err(Error::file(
            dir,
            format!(
                "holds {}, which cubeforge did not write: an output folder (faces, a chain, an ibl target's files) is replaced whole, so name a new or empty folder (or move that out)",
                stranger.display()
            ),
        ));
    }
    Ok(())
}

/// The first entry of `dir` (at `rel` below the output folder) that cubeforge would not
/// have written there, if any.
fn foreign_entry(dir: &Path, rel: &Path, written: &[PathBuf]) -> Result<Option<PathBuf>> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        // Gone while it was read: another writer replaced the output folder whole (its
        // level folders with it), so nothing foreign is left there; the move looks again.
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(Error::io(dir, e)),
    };
    let mut names: Vec<_> = entries.filter_map(|e| e.ok()).collect();
    names.sort_by_key(|e| e.file_name());
    for e in names {
        let name = e.file_name().to_string_lossy().into_owned();
        let here = rel.join(&name);
        let is_dir = e.file_type().map(|t| t.is_dir()).unwrap_or(false);
        // A FIFO, a device or a socket is never cubeforge's, whatever its name.
        let special = e
            .file_type()
            .is_ok_and(|t| !t.is_dir() && !t.is_file() && !t.is_symlink());
        if special {
            return Ok(Some(here));
        }
        let ours = written.contains(&here)
            || DESKTOP_LITTER.contains(&name.as_str())
            || (name.starts_with('.') && name.contains(".cubeforge-") && name.ends_with(".tmp"))
            || (!is_dir && is_face_file(&name))
            || (!is_dir && rel.as_os_str().is_empty() && name == "levels.json");
        if ours {
            continue;
        }
        // A chain's level folder: `m` and digits, right below the output folder.
        let level = rel.as_os_str().is_empty()
            && name.len() > 1
            && name.starts_with('m')
            && name[1..].bytes().all(|b| b.is_ascii_digit());
        if is_dir && level {
            if let Some(inner) = foreign_entry(&e.path(), &here, written)? {
                return Ok(Some(inner));
            }
            continue;
        }
        return Ok(Some(here));
    }
    Ok(None)
}

/// A face image's name: px.EXT ... or posx.EXT ..., EXT an image type cubeforge writes.
fn is_face_file(name: &str) -> bool {
    let Some((stem, _)) = name.rsplit_once('.') else {
        return false;
    };
    let stem = stem.to_ascii_lowercase();
    (FACE_NAMES.contains(&stem.as_str()) || FACE_LONG_NAMES.contains(&stem.as_str()))
        && FileFormat::from_extension(Path::new(name)).is_some_and(|f| !f.is_container())
}

/// Puts the staged folder `tmp` in place as `dir`, replacing whatever folder is there whole
/// (checked again: another process may have written it since; `known`: files an earlier
/// run left there, which go with it). The folder it replaced, now
/// under a registered temporary name, comes back to be removed.
pub(super) fn put(tmp: &Path, dir: &Path, known: &[PathBuf]) -> Result<Option<PathBuf>> {
    // Another writer may put its folder there between the look and the move: look again.
    for _ in 0..16 {
        match std::fs::symlink_metadata(dir) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => match move_registered(tmp, dir) {
                Ok(()) => return Ok(None),
                Err(_) if std::fs::symlink_metadata(dir).is_ok() => continue,
                Err(e) => return Err(Error::io(dir, e)),
            },
            Err(e) => return Err(Error::io(dir, e)),
            Ok(m) if m.is_dir() => {
                let mut staged = Vec::new();
                super::collect_files(tmp, tmp, dir, &mut staged);
                let writing: Vec<PathBuf> = staged
                    .into_iter()
                    .map(|(_, p)| p)
                    .chain(known.iter().cloned())
                    .collect();
                check_folder(dir, &writing)?;
                // One step where the system has it: `dir` always names a whole folder.
                if guarded(|| exchange_folders(tmp, dir), |_| {}).is_ok() {
                    return Ok(Some(tmp.to_path_buf()));
                }
                // Elsewhere the old folder steps aside first.
                let aside = temp_name(dir);
                guarded(|| std::fs::rename(dir, &aside), |p| p.push(aside.clone()))
                    .map_err(|e| Error::io(dir, e))?;
                return match move_registered(tmp, dir) {
                    Ok(()) => Ok(Some(aside)),
                    Err(e) => {
                        let _ = std::fs::rename(&aside, dir);
                        Err(Error::io(dir, e))
                    }
                };
            }
            Ok(_) => {
                return Err(Error::file(
                    dir,
                    "a file of that name is in the way of the output folder",
                ))
            }
        }
    }
    Err(Error::file(
        dir,
        "other writers keep replacing this folder: try again",
    ))
}
