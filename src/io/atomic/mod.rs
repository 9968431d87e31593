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
        .map(|((path, bytes), tmp)| write_file(tmp, bytes).map_err(|e| Error::io(path, e)))
        .collect();
    written.into_iter().collect::<Result<()>>()?;
    Ok(staged)
}

/// Writes `bytes` to `tmp`, to be put in place later. Its blocks are left for the kernel to
/// write out when it likes: the exchange that puts it in place (`replace`) waits for none.
fn write_file(tmp: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::fs::File::create(tmp)?;
    f.write_all(bytes)
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
        // Temporary names that hold a replaced file after its exchange, removed at the end.
        let mut old: Vec<PathBuf> = Vec::new();
        for (i, (tmp, path)) in files.iter().enumerate() {
            match replace(tmp, path) {
                Ok(true) => old.push(tmp.clone()),
                Ok(false) => forget(tmp),
                Err(e) => {
                    self.files = files[i..].to_vec();
                    let made = files[..i].iter().zip(&existed).filter(|(_, &x)| !x);
                    created.extend(made.map(|((_, p), _)| p.clone()));
                    drop(locks);
                    rollback(&created);
                    remove_all(&old);
                    return Err(Error::io(path, e));
                }
            }
        }
        drop(locks);
        remove_all(&old);
        Ok(())
    }
}

/// Puts `tmp` in place as `path`; true when the file it replaced is now named `tmp`.
///
/// A regular file is exchanged with its replacement (Linux's `renameat2(RENAME_EXCHANGE)`):
/// `path` always names one whole file, and the old one is freed afterwards, with the others,
/// outside the folder's lock. A plain rename over a file costs more on ext4, one file after
/// another: it first writes out the new file's blocks (`auto_da_alloc`), then frees the old
/// one's (device, six 3 MB faces: 18-20 ms of renames; exchanges 0.1 ms, then the removals
/// 6-7 ms). Elsewhere, or where the file system cannot exchange, a plain rename.
fn replace(tmp: &Path, path: &Path) -> std::io::Result<bool> {
    // Where there is no exchange (a file system without it, a kernel or sandbox without the
    // call) or the file went away, nothing moved: a rename, which reports any real error.
    #[cfg(target_os = "linux")]
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file()) && exchange(tmp, path).is_ok() {
        // A folder put there meanwhile goes back where it was.
        if std::fs::symlink_metadata(tmp).is_ok_and(|m| m.is_dir()) {
            exchange(tmp, path)?;
            return Err(std::io::Error::other("a folder of that name is in the way"));
        }
        return Ok(true);
    }
    std::fs::rename(tmp, path).map(|()| false)
}

/// Swaps the names of two existing files, atomically.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use std::os::unix::ffi::OsStrExt;
    let c = |p: &Path| std::ffi::CString::new(p.as_os_str().as_bytes());
    let (a, b) = (c(a)?, c(b)?);
    // SAFETY: two NUL-terminated paths that outlive the call, which only reads them. The
    // system call directly: glibc wraps it only from 2.28 on.
    let r = unsafe {
        libc::syscall(
            libc::SYS_renameat2,
            libc::AT_FDCWD,
            a.as_ptr(),
            libc::AT_FDCWD,
            b.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Removes the replaced files (under their temporary names), in parallel.
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
