//! Make-style depfiles (`target: dep dep ...`), as Make, Ninja (`deps = gcc`) and asset
//! cookers read them: the output a command was asked for, and every file it read.

use crate::error::Result;
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

/// Writes the depfile `path` for `target` (atomically, never over one of `reads`).
pub fn write(path: &Path, target: &Path, reads: &[PathBuf]) -> Result<()> {
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
