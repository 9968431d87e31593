//! Make-style depfiles (`target: dep dep ...`), as Make, Ninja (`deps = gcc`) and asset
//! cookers read them: the output a command was asked for, and every file it read.

use crate::error::{Error, Result};
use crate::io::atomic::{Place, Places};
use crate::output::{self, Destination, Files};
use std::path::{Path, PathBuf};

/// A path as Make and Ninja read it: spaces and `#` escaped with a backslash, `$` doubled.
fn escape(path: &Path) -> String {
    let mut out = String::new();
    for c in path.to_string_lossy().chars() {
        match c {
            ' ' | '#' => {
                out.push('\\');
                out.push(c);
            }
            '$' => out.push_str("$$"),
            _ => out.push(c),
        }
    }
    out
}

/// The depfile's text: `target` depends on each of `reads`, one per line.
pub fn text(target: &Path, reads: &[PathBuf]) -> String {
    let mut s = format!("{}:", escape(target));
    for r in reads {
        s.push_str(" \\\n  ");
        s.push_str(&escape(r));
    }
    s.push('\n');
    s
}

/// Refuses, before the command runs, a depfile `path` that would land on its output
/// `target` or inside it (a folder output: faces, a chain, an engine's files), or where no
/// regular file can be (a FIFO, a device). Spellings are compared as places.
pub fn check(path: &Path, target: &Path) -> Result<()> {
    crate::io::atomic::check_regular(path)?;
    let (at, out) = (Place::of(path), Place::of(target));
    let mut places = Places::default();
    places.insert(&out, ());
    if places.get(&at).is_some() {
        return Err(Error::file(
            path,
            "is the command's output: the depfile would overwrite it; name another file",
        ));
    }
    if places.above(&at).is_some() {
        return Err(Error::file(
            path,
            format!(
                "is inside the output folder {}: the depfile would overwrite or join what the \
                 command writes there; name a file outside it",
                target.display()
            ),
        ));
    }
    Ok(())
}

/// Writes the depfile `path` for `target` (atomically), never over one of `reads` nor over a
/// file the command wrote (`written`: the output, a face, an `--sh` file).
pub fn write(path: &Path, target: &Path, reads: &[PathBuf], written: &[PathBuf]) -> Result<()> {
    let at = Place::of(path);
    let mut outs = Places::default();
    for w in written {
        outs.insert(&Place::of(w), ());
    }
    if outs.get(&at).is_some() {
        return Err(Error::file(
            path,
            "is a file the command wrote: the depfile would overwrite it; name another file",
        ));
    }
    let files = Files::new(vec![(path.to_path_buf(), text(target, reads).into_bytes())]);
    output::deliver(&files, &Destination::Path(path.to_path_buf()), reads)
}

/// The depfile a batch writes beside an output: `OUTPUT.d`.
pub fn beside(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".d");
    PathBuf::from(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_as_make_reads() {
        let t = text(
            Path::new("out dir/sky.ktx2"),
            &["a b.exr".into(), "c#1$.png".into()],
        );
        assert_eq!(t, "out\\ dir/sky.ktx2: \\\n  a\\ b.exr \\\n  c\\#1$$.png\n");
        assert_eq!(text(Path::new("lut.png"), &[]), "lut.png:\n");
    }
}
