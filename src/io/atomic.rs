//! Writes that land whole or not at all. Every file is first written under a temporary name:
//! files whose folder exists go beside their target (`.NAME.cubeforge-PID.tmp`), and a folder
//! that does not exist yet is built whole as `.NAME.cubeforge-PID.tmp/` and renamed into place,
//! so a new faces folder or prefilter chain appears complete or not at all, and a failed
//! command leaves no empty folders behind. Renames into existing folders happen under an
//! advisory lock on each folder, so two processes writing one folder never interleave their
//! files: the last one to finish wins, whole. Temporaries are registered so that a signal
//! handler ([`remove_temporaries`]) can take them back.

#![warn(missing_docs)]

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Temporary files and folders that exist now, for [`remove_temporaries`].
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

fn register(p: &Path) {
    pending().push(p.to_path_buf());
}

fn forget(p: &Path) {
    pending().retain(|q| q != p);
}

fn remove_any(p: &Path) {
    if p.is_dir() && !p.is_symlink() {
        let _ = std::fs::remove_dir_all(p);
    } else {
        let _ = std::fs::remove_file(p);
    }
}

/// Removes every temporary file and folder not yet renamed into place: what a SIGINT or
/// SIGTERM handler calls before the process ends.
pub fn remove_temporaries() {
    let list = std::mem::take(&mut *pending());
    for p in &list {
        remove_any(p);
    }
}

/// Files written under temporary names, not yet in place. Dropped without [`Staged::commit`],
/// it removes them.
#[derive(Debug)]
pub struct Staged {
    /// Folders built whole: (temporary, target).
    trees: Vec<(PathBuf, PathBuf)>,
    /// Files in folders that exist: (temporary, target).
    files: Vec<(PathBuf, PathBuf)>,
}

fn temp_name(path: &Path) -> PathBuf {
    let dir = parent(path);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    dir.join(format!(".{name}.cubeforge-{}.tmp", std::process::id()))
}

fn parent(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// The highest folder above `path` that does not exist (None when its folder exists).
fn missing_top(path: &Path) -> Option<PathBuf> {
    let mut top = None;
    let mut dir = parent(path);
    while !dir.exists() {
        top = Some(dir.to_path_buf());
        match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => dir = p,
            _ => break,
        }
    }
    top
}

/// Writes every file under a temporary name; nothing is visible under the real names yet.
pub fn stage(files: &[(PathBuf, Vec<u8>)]) -> Result<Staged> {
    // A rename onto a folder fails: find that out before anything is written.
    if let Some((path, _)) = files.iter().find(|(p, _)| p.is_dir()) {
        return Err(Error::file(path, "a folder of that name is in the way"));
    }
    let mut staged = Staged {
        trees: Vec::new(),
        files: Vec::new(),
    };
    let mut tmps = Vec::with_capacity(files.len());
    for (path, _) in files {
        let tmp = match missing_top(path) {
            Some(top) => {
                let root = match staged.trees.iter().find(|(_, t)| *t == top) {
                    Some((root, _)) => root.clone(),
                    None => {
                        if let Some(p) = top.parent().filter(|p| !p.as_os_str().is_empty()) {
                            if !p.is_dir() {
                                return Err(Error::file(path, "its folder is not a folder"));
                            }
                        }
                        let root = temp_name(&top);
                        register(&root);
                        staged.trees.push((root.clone(), top.clone()));
                        std::fs::create_dir(&root).map_err(|e| Error::io(&top, e))?;
                        root
                    }
                };
                // Within the new tree, the file keeps its place relative to the top.
                let rel = path.strip_prefix(&top).unwrap_or(path);
                let tmp = root.join(rel);
                std::fs::create_dir_all(parent(&tmp)).map_err(|e| Error::io(path, e))?;
                tmp
            }
            None => {
                let tmp = temp_name(path);
                register(&tmp);
                staged.files.push((tmp.clone(), path.clone()));
                tmp
            }
        };
        tmps.push(tmp);
    }
    // The writes in parallel (six faces of 3 MB each, say); the first failure in file order
    // is the one reported.
    use rayon::prelude::*;
    let written: Vec<Result<()>> = files
        .par_iter()
        .zip(&tmps)
        .map(|((path, bytes), tmp)| write_file(tmp, bytes, path).map_err(|e| Error::io(path, e)))
        .collect();
    written.into_iter().collect::<Result<()>>()?;
    Ok(staged)
}

/// Writes `bytes` to `tmp`, to be renamed onto `target` later. When that rename replaces a
/// file, ext4 (`auto_da_alloc`) first allocates and flushes the new file's blocks, serially,
/// inside the rename: 3 ms per 3 MB face, 18 ms for six, more than the whole write. Starting
/// that writeback here, on the parallel writers, leaves the renames nothing to wait for.
fn write_file(tmp: &Path, bytes: &[u8], target: &Path) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::fs::File::create(tmp)?;
    f.write_all(bytes)?;
    #[cfg(target_os = "linux")]
    if target.is_file() {
        use std::os::fd::AsRawFd;
        // SAFETY: a plain system call on this open file; it reads no memory of ours. A
        // failure only means the rename flushes as before.
        unsafe {
            libc::sync_file_range(f.as_raw_fd(), 0, 0, libc::SYNC_FILE_RANGE_WRITE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = target;
    Ok(())
}

/// An advisory lock on a folder, held while files are renamed into it.
fn lock_dirs(dirs: &mut Vec<PathBuf>) -> Vec<std::fs::File> {
    // One order for every process: no deadlock between two writers.
    dirs.sort();
    dirs.dedup();
    dirs.iter()
        .filter_map(|d| {
            let f = std::fs::File::open(d).ok()?;
            // A file system without locks still gets the renames, unlocked.
            f.lock().ok()?;
            Some(f)
        })
        .collect()
}

impl Staged {
    /// Puts every file in place. Files are renamed, never copied; if a rename fails, the
    /// files and folders this call created are taken back (files it replaced stay replaced).
    pub fn commit(mut self) -> Result<()> {
        // Whatever is still staged when this returns is removed by `drop`.
        self.put_in_place()
    }

    fn put_in_place(&mut self) -> Result<()> {
        let mut created: Vec<PathBuf> = Vec::new();
        let rollback = |created: &[PathBuf]| created.iter().for_each(|p| remove_any(p));
        // A new folder goes in with one rename. If another process made it meanwhile, its
        // files join the others, moved one by one under the lock.
        let trees = std::mem::take(&mut self.trees);
        for (i, (root, top)) in trees.iter().enumerate() {
            match std::fs::rename(root, top) {
                Ok(()) => {
                    forget(root);
                    created.push(top.clone());
                }
                Err(_) if top.is_dir() => {
                    collect_files(root, root, top, &mut self.files);
                    self.trees.push((root.clone(), top.clone()));
                }
                Err(e) => {
                    self.trees.extend(trees[i..].iter().cloned());
                    rollback(&created);
                    return Err(Error::io(top, e));
                }
            }
        }
        for (_, p) in &self.files {
            if let Err(e) = std::fs::create_dir_all(parent(p)) {
                rollback(&created);
                return Err(Error::io(p, e));
            }
        }
        let mut dirs: Vec<PathBuf> = self
            .files
            .iter()
            .map(|(_, p)| parent(p).to_path_buf())
            .collect();
        let locks = lock_dirs(&mut dirs);
        let files = std::mem::take(&mut self.files);
        let existed: Vec<bool> = files.iter().map(|(_, p)| p.exists()).collect();
        let old = keep_replaced(&files);
        for (i, (tmp, path)) in files.iter().enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                self.files = files[i..].to_vec();
                let made = files[..i].iter().zip(&existed).filter(|(_, &x)| !x);
                created.extend(made.map(|((_, p), _)| p.clone()));
                drop(locks);
                rollback(&created);
                remove_all(&old);
                return Err(Error::io(path, e));
            }
            forget(tmp);
        }
        drop(locks);
        remove_all(&old);
        Ok(())
    }
}

/// A second name for each regular file the renames will replace, so that no rename drops a
/// file's last name: freeing a replaced file's pages and blocks happened inside its rename,
/// one file after another under the folder's lock (VM, ext4, six 3 MB faces: 1.1-1.7 ms per
/// rename; 0.04 ms now, the removals 1.2 ms each on the pool's threads). Where a file system
/// has no hard links, the renames free the files as before. (A file replaced while the
/// kernel still writes it to disk, as in back-to-back benchmark runs, waits for that write
/// either way.)
fn keep_replaced(files: &[(PathBuf, PathBuf)]) -> Vec<PathBuf> {
    files
        .iter()
        .filter(|(_, p)| std::fs::symlink_metadata(p).is_ok_and(|m| m.is_file()))
        .filter_map(|(_, p)| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            let old = parent(p).join(format!(".{name}.cubeforge-{}.old", std::process::id()));
            register(&old);
            match std::fs::hard_link(p, &old) {
                Ok(()) => Some(old),
                Err(_) => {
                    forget(&old);
                    None
                }
            }
        })
        .collect()
}

/// Removes the replaced files' second names, in parallel.
fn remove_all(names: &[PathBuf]) {
    use rayon::prelude::*;
    names.par_iter().for_each(|p| {
        let _ = std::fs::remove_file(p);
        forget(p);
    });
}

/// The files under a staged tree, paired with their targets under `top`.
fn collect_files(dir: &Path, root: &Path, top: &Path, out: &mut Vec<(PathBuf, PathBuf)>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            collect_files(&p, root, top, out);
        } else if let Ok(rel) = p.strip_prefix(root) {
            out.push((p.clone(), top.join(rel)));
        }
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        for (tmp, _) in self.trees.iter().chain(&self.files) {
            remove_any(tmp);
            forget(tmp);
        }
    }
}

/// Writes several files so that either all of them land or none does (see the module).
pub fn write_all_atomic(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    stage(files)?.commit()
}
