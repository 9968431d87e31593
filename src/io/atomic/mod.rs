//! Writes that land whole or not at all. Every file is first written under a temporary name
//! beside its target (`.NAME.cubeforge-PID-N.tmp`, the name cut short where it would pass
//! the file system's 255 bytes), and a folder that does not exist yet is built whole under
//! such a name and renamed into place, so a new faces folder or prefilter chain appears
//! complete or not at all, and a failed command leaves no empty folders behind.
//!
//! A folder that is an output in its own right (six faces, a chain's `m0/ m1/ ...`: see
//! [`stage_replacing`]) is replaced whole: the new one is built beside it and exchanged with it in
//! one step, so the old contents never mix with the new (a stale `m4/` of a longer chain,
//! faces of another format), and of two writers one ends with its whole result in place. A
//! folder that holds anything cubeforge did not write is refused, never emptied
//! ([`folder`]). Files into existing folders are renamed under an advisory lock on each
//! folder, so two processes writing one folder never interleave their files.
//!
//! Targets are regular files only: one that is a FIFO, a device or a socket (links followed)
//! is refused before anything is staged, and looked at again before the renames, never
//! replaced by one ([`place`]); so are two targets that are one file however spelled.
//!
//! Temporaries are registered, and every step that makes or moves one happens under the
//! registry's lock, so a signal handler ([`remove_temporaries`]) that takes them back never
//! races a thread still making one: after it, nothing new appears.

#![warn(missing_docs)]

mod folder;
mod place;

use crate::error::{Error, Result};
pub use folder::check_folder;
pub(crate) use place::{
    check_regular, check_targets, open_regular, special_kind, Place, Places, Resolver,
};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Temporary files and folders that exist now, for [`remove_temporaries`]; `stopping` once
/// it ran (the process is ending on a signal: no temporary may be made after it).
struct Pending {
    paths: Vec<PathBuf>,
    stopping: bool,
}

static PENDING: Mutex<Pending> = Mutex::new(Pending {
    paths: Vec::new(),
    stopping: false,
});

fn pending() -> std::sync::MutexGuard<'static, Pending> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

fn interrupted() -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::Interrupted,
        "interrupted by a signal: the command is stopping",
    )
}

/// Runs `step` (which makes or moves temporaries) under the registry's lock, unless the
/// process is stopping; `track` says what the registry gains and loses when it succeeds.
fn guarded<T>(
    step: impl FnOnce() -> std::io::Result<T>,
    track: impl FnOnce(&mut Vec<PathBuf>),
) -> std::io::Result<T> {
    let mut p = pending();
    if p.stopping {
        return Err(interrupted());
    }
    let out = step()?;
    track(&mut p.paths);
    Ok(out)
}

fn forget(p: &Path) {
    pending().paths.retain(|q| q != p);
}

pub(super) fn remove_any(p: &Path) {
    if p.is_dir() && !p.is_symlink() {
        let _ = std::fs::remove_dir_all(p);
    } else {
        let _ = std::fs::remove_file(p);
    }
}

/// Outputs put in place whole by this process so far (each [`Staged::commit`] that ended).
static COMMITTED: AtomicU64 = AtomicU64::new(0);

/// Removes every temporary file and folder not yet in place: what a SIGINT, SIGTERM or
/// SIGHUP handler calls before the process ends. From then on every write of this process
/// fails (the registry's lock is held while they go, and no temporary is made after it).
/// Returns how many outputs were put in place whole before it, so the handler can say what
/// the stop kept (0: nothing was written).
pub fn remove_temporaries() -> u64 {
    let mut p = pending();
    p.stopping = true;
    for t in std::mem::take(&mut p.paths) {
        remove_any(&t);
    }
    COMMITTED.load(Ordering::SeqCst)
}

/// Files written under temporary names, not yet in place. Dropped without [`Staged::commit`],
/// it removes them.
#[derive(Debug)]
pub struct Staged {
    /// Folders built whole: (temporary, target, replaced whole when it exists).
    trees: Vec<(PathBuf, PathBuf, bool)>,
    /// Folders that are outputs in their own right (replaced whole), as given.
    folders: Vec<PathBuf>,
    /// Files in folders that exist: (temporary, target).
    files: Vec<(PathBuf, PathBuf)>,
    /// Files an earlier run may have left in the folder outputs, replaced with them.
    known: Vec<PathBuf>,
}

/// The longest file name the common file systems take (ext4, XFS, Btrfs, APFS, NTFS).
const NAME_MAX: usize = 255;

/// A temporary name beside `path`: hidden, unique in this process, and no longer than the
/// file system allows whatever the target's name (the name is cut short to fit).
pub(super) fn temp_name(path: &Path) -> PathBuf {
    static SERIAL: AtomicU64 = AtomicU64::new(0);
    let suffix = format!(
        ".cubeforge-{}-{}.tmp",
        std::process::id(),
        SERIAL.fetch_add(1, Ordering::Relaxed)
    );
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut keep = NAME_MAX - 1 - suffix.len();
    while keep < name.len() && !name.is_char_boundary(keep) {
        keep -= 1;
    }
    parent(path).join(format!(".{}{suffix}", &name[..keep.min(name.len())]))
}

pub(super) fn parent(path: &Path) -> &Path {
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

/// A folder output behind a symbolic link is replaced where the link points: the folder and
/// the paths under it (the files to write and the run's `known` ones) follow the link.
fn follow_folder_links(
    folders: &mut [PathBuf],
    paths: &mut [PathBuf],
    known: &mut [PathBuf],
) -> Result<()> {
    for f in folders {
        if std::fs::symlink_metadata(&*f).is_ok_and(|m| m.file_type().is_symlink()) {
            let real = std::fs::canonicalize(&*f).map_err(|e| Error::io(&*f, e))?;
            for p in paths.iter_mut().chain(known.iter_mut()) {
                if let Ok(rel) = p.strip_prefix(&*f) {
                    *p = real.join(rel);
                }
            }
            *f = real;
        }
    }
    Ok(())
}

/// Writes every file under a temporary name (nothing is visible under the real names yet),
/// where each of `folders` is an output in its own right (a faces folder, a chain folder):
/// every file under it is staged in a new folder that replaces it whole on
/// [`Staged::commit`]. Refuses a folder that holds what cubeforge did not write
/// ([`check_folder`]) other than the `known` files (what an earlier run of another kind wrote
/// there, such as another `ibl` target's files), which go with the folder. Crate-only:
/// `output::deliver` calls it after the output check, which a caller here would skip.
pub(crate) fn stage_replacing(
    files: &[(PathBuf, Vec<u8>)],
    folders: &[PathBuf],
    known: &[PathBuf],
) -> Result<Staged> {
    // `-` names standard output: a command that cannot write there must not make a file or
    // a folder of that name.
    let dash = |p: &Path| p.components().any(|c| c.as_os_str() == "-");
    if let Some((path, _)) = files.iter().find(|(p, _)| dash(p)) {
        return Err(Error::file(
            path,
            "`-` stands for standard output, which this output cannot go to: name a file or folder",
        ));
    }
    let mut folders = folders.to_vec();
    let mut paths: Vec<PathBuf> = files.iter().map(|(p, _)| p.clone()).collect();
    let mut known = known.to_vec();
    follow_folder_links(&mut folders, &mut paths, &mut known)?;
    // Regular files only, each once: before anything is written.
    check_targets(&paths)?;
    // A rename onto a folder fails: find that out before anything is written.
    if let Some(path) = paths.iter().find(|p| p.is_dir()) {
        return Err(Error::file(path, "a folder of that name is in the way"));
    }
    let ours: Vec<PathBuf> = paths.iter().chain(&known).cloned().collect();
    for f in &folders {
        check_folder(f, &ours)?;
    }
    let mut staged = Staged {
        trees: Vec::new(),
        folders: folders.clone(),
        files: Vec::new(),
        known,
    };
    let mut tmps = Vec::with_capacity(files.len());
    for path in &paths {
        let whole = folders.iter().find(|f| path.starts_with(f));
        // The folder built whole for this file: a folder output, or the highest missing one.
        let top = match whole {
            Some(f) if parent(f).exists() => Some((f.clone(), true)),
            _ => missing_top(path).map(|t| (t, false)),
        };
        let tmp = match top {
            Some((top, replace)) => {
                let root = match staged.trees.iter().find(|(_, t, _)| *t == top) {
                    Some((root, _, _)) => root.clone(),
                    None => {
                        if !parent(&top).is_dir() {
                            return Err(Error::file(path, "its folder is not a folder"));
                        }
                        let root = temp_name(&top);
                        guarded(|| std::fs::create_dir(&root), |p| p.push(root.clone()))
                            .map_err(|e| Error::io(&top, e))?;
                        staged.trees.push((root.clone(), top.clone(), replace));
                        root
                    }
                };
                // Within the new tree, the file keeps its place relative to the top.
                let rel = path.strip_prefix(&top).unwrap_or(path);
                let tmp = root.join(rel);
                make_dirs(&root, parent(&tmp)).map_err(|e| Error::io(path, e))?;
                tmp
            }
            None => {
                let tmp = temp_name(path);
                staged.files.push((tmp.clone(), path.clone()));
                tmp
            }
        };
        tmps.push(tmp);
    }
    // The writes in parallel (six faces of 3 MB each, say); the first failure in file order
    // is the one reported.
    use rayon::prelude::*;
    let in_trees: Vec<bool> = tmps
        .iter()
        .map(|t| staged.trees.iter().any(|(r, _, _)| t.starts_with(r)))
        .collect();
    let written: Vec<Result<()>> = files
        .par_iter()
        .zip(&tmps)
        .zip(&in_trees)
        .map(|(((path, bytes), tmp), &in_tree)| {
            write_file(tmp, bytes, !in_tree).map_err(|e| Error::io(path, e))
        })
        .collect();
    written.into_iter().collect::<Result<()>>()?;
    Ok(staged)
}

/// Makes the folders from `root` (a registered temporary) down to `dir`, one at a time and
/// each under the registry's lock: a tree the signal handler removed is never made again.
fn make_dirs(root: &Path, dir: &Path) -> std::io::Result<()> {
    let Ok(rel) = dir.strip_prefix(root) else {
        return Ok(());
    };
    let mut at = root.to_path_buf();
    for part in rel.components() {
        at.push(part);
        let here = at.clone();
        guarded(
            || match std::fs::create_dir(&here) {
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && here.is_dir() => Ok(()),
                r => r,
            },
            |_| {},
        )?;
    }
    Ok(())
}

/// Writes `bytes` to `tmp`, to be put in place later (registered when `register`: a file
/// outside a registered tree). Its blocks are left for the kernel to write out when it
/// likes: the exchange that puts it in place (`replace`) waits for none.
fn write_file(tmp: &Path, bytes: &[u8], register: bool) -> std::io::Result<()> {
    use std::io::Write;
    // Made under the lock (a handler that ran first makes this fail, one that runs after
    // finds the name registered); written outside it.
    let mut f = guarded(
        || {
            std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(tmp)
        },
        |p| {
            if register {
                p.push(tmp.to_path_buf())
            }
        },
    )?;
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

/// Moves `from` to `to` under the registry's lock, `from` forgotten once it has moved.
fn move_registered(from: &Path, to: &Path) -> std::io::Result<()> {
    guarded(|| std::fs::rename(from, to), |p| p.retain(|q| q != from))
}

impl Staged {
    /// Puts every file in place. Files are renamed, never copied; if a rename fails, the
    /// files and folders this call created are taken back (files it replaced stay replaced).
    pub fn commit(mut self) -> Result<()> {
        // Whatever is still staged when this returns is removed by `drop`.
        self.put_in_place()?;
        COMMITTED.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }

    fn put_in_place(&mut self) -> Result<()> {
        // A FIFO or a device put there since the files were staged: refused, nothing moved.
        for (_, p) in &self.files {
            check_regular(p)?;
        }
        let mut created: Vec<PathBuf> = Vec::new();
        // Temporary names that hold what was replaced, removed at the end.
        let mut old: Vec<PathBuf> = Vec::new();
        let rollback = |created: &[PathBuf]| created.iter().for_each(|p| remove_any(p));
        let trees = std::mem::take(&mut self.trees);
        for (i, (root, top, replace)) in trees.iter().enumerate() {
            let placed: Result<()> = if *replace {
                folder::put(root, top, &self.known).map(|replaced| old.extend(replaced))
            } else {
                // A new folder goes in with one rename. If another process made it
                // meanwhile, its files join the others, moved one by one under the lock
                // (folder outputs within it replace theirs whole).
                match move_registered(root, top) {
                    Ok(()) => {
                        created.push(top.clone());
                        Ok(())
                    }
                    Err(_) if top.is_dir() => self.join_existing(root, top, &mut old),
                    Err(e) => Err(Error::io(top, e)),
                }
            };
            if let Err(e) = placed {
                self.trees.extend(trees[i..].iter().cloned());
                rollback(&created);
                remove_all(&old);
                return Err(e);
            }
        }
        for (_, p) in &self.files {
            if let Err(e) = std::fs::create_dir_all(parent(p)) {
                rollback(&created);
                remove_all(&old);
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

    /// A staged tree whose target another process made meanwhile: its folder outputs
    /// replace theirs whole, its other files are moved in one by one (after this, the
    /// tree's temporary holds nothing of value and is removed).
    fn join_existing(&mut self, root: &Path, top: &Path, old: &mut Vec<PathBuf>) -> Result<()> {
        for f in self.folders.clone() {
            let Ok(rel) = f.strip_prefix(top) else {
                continue;
            };
            let sub = root.join(rel);
            if !sub.is_dir() {
                continue;
            }
            std::fs::create_dir_all(parent(&f)).map_err(|e| Error::io(&f, e))?;
            let moved = temp_name(&f);
            guarded(|| std::fs::rename(&sub, &moved), |p| p.push(moved.clone()))
                .map_err(|e| Error::io(&f, e))?;
            old.extend(folder::put(&moved, &f, &self.known)?);
        }
        collect_files(root, root, top, &mut self.files);
        self.trees
            .push((root.to_path_buf(), top.to_path_buf(), false));
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

/// Swaps two folders, atomically, where the system can.
fn exchange_folders(a: &Path, b: &Path) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    return exchange(a, b);
    #[cfg(not(target_os = "linux"))]
    Err(std::io::Error::from(std::io::ErrorKind::Unsupported))
}

/// Swaps the names of two existing files or folders, atomically.
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

/// Removes what was replaced (under temporary names), in parallel.
fn remove_all(names: &[PathBuf]) {
    use rayon::prelude::*;
    names.par_iter().for_each(|p| {
        remove_any(p);
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
        for tmp in self
            .trees
            .iter()
            .map(|(t, _, _)| t)
            .chain(self.files.iter().map(|(t, _)| t))
        {
            remove_any(tmp);
            forget(tmp);
        }
    }
}

#[cfg(test)]
mod tests;
