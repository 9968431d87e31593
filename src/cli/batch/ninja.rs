//! `batch --emit ninja`: a build.ninja whose edges are the manifest's jobs. Each edge runs
//! the job's command line with `--depfile`, so Ninja learns every file the job read (faces,
//! decals, recipes, materials) and reruns it when one changes; the cubeforge program is an
//! input of every edge, and the manifest of build.ninja itself (Ninja regenerates it first).
//! Every name goes through [`path`] or [`value`]: what Ninja's syntax cannot hold is refused.

use super::manifest::{shell_quote, Planned};
use cubeforge::internals::output::{self, Destination, Files};
use cubeforge::{Error, Result};
use std::path::{Path, PathBuf};

/// Why Ninja cannot hold `s`: a line break ends a line of build.ninja and Ninja has no escape
/// for one; other control characters (but tab) would reach the terminal in Ninja's status
/// line.
fn unholdable(s: &str) -> Option<String> {
    let c = s.chars().find(|&c| c.is_control() && c != '\t')?;
    let shown = cubeforge::internals::error::escape_text(&c.to_string()).into_owned();
    Some(if c == '\n' || c == '\r' {
        format!("build.ninja cannot hold a line break ({shown})")
    } else {
        format!("build.ninja cannot hold the control character {shown}")
    })
}

/// A path on a build line, as Ninja's lexer reads it: `$`, space and `:` escaped with `$`,
/// and `|` (which has no escape) through the variable `$pipe` that [`text`] defines.
pub(super) fn path(p: &str) -> Result<String> {
    if let Some(why) = unholdable(p) {
        return Err(Error::file(p, format!("{why} in a name: rename it")));
    }
    let mut out = String::with_capacity(p.len() + 8);
    for c in p.chars() {
        match c {
            '$' | ' ' | ':' => {
                out.push('$');
                out.push(c);
            }
            '|' => out.push_str("${pipe}"),
            c => out.push(c),
        }
    }
    Ok(out)
}

/// One word of a variable's value (`args = ...`), shell-quoted for the rule's command and
/// with `$` doubled for Ninja. A raw line break would end the value and start a line of
/// build.ninja's own (`p⏎cubeforge = touch PWNED #.exr` would rebind `$cubeforge`): refused.
fn value(word: &str) -> Result<String> {
    match unholdable(word) {
        Some(why) => Err(Error::file(word, format!("{why} in a command's word"))),
        None => Ok(shell_quote(word).replace('$', "$$")),
    }
}

/// A command line as a variable's value: each word through [`value`].
fn words(argv: &[String]) -> Result<String> {
    Ok(argv
        .iter()
        .map(|a| value(a))
        .collect::<Result<Vec<_>>>()?
        .join(" "))
}

/// The text of build.ninja for `planned`, run by the program `exe`, from `manifest`; an
/// error names a file whose name build.ninja cannot hold.
pub fn text(manifest: &Path, exe: &Path, planned: &[Planned]) -> Result<String> {
    let m = manifest.display().to_string();
    let m_path = path(&m)?;
    let exe = exe.display().to_string();
    // `./$in`: the manifest is in this folder, and a name starting with `-` is no option;
    // `--depfile=$out.d` for an output starting with `-` (Ninja drops a leading `./`).
    let mut s = format!(
        "# Written by `cubeforge batch {m} --emit ninja`: edit {m}, not this file (Ninja\n\
         # writes it again when the manifest changes; run the command again after adding\n\
         # inputs that its globs match).\n\
         ninja_required_version = 1.10\n\n\
         # `|` in a path (Ninja has no escape for it).\n\
         pipe = |\n\
         cubeforge = {}\n\n\
         rule cubeforge\n  command = $cubeforge -q $args --depfile=$out.d\n  depfile = $out.d\n  \
         deps = gcc\n  description = cubeforge $args\n\n\
         rule manifest\n  command = $cubeforge -q batch ./$in --emit ninja\n  generator = 1\n  \
         description = build.ninja from $in\n\n\
         build build.ninja: manifest {m_path}\n",
        value(&exe)?
    );
    let exe_path = path(&exe)?;
    for p in planned {
        let edge = || -> Result<String> {
            let input = match &p.input {
                Some(i) => format!(" {}", path(&i.display().to_string())?),
                None => String::new(),
            };
            Ok(format!(
                "\n# {m}, line {}\nbuild {}: cubeforge{input} | {exe_path}\n  args = {}\n",
                p.line,
                path(&p.output)?,
                words(&p.argv)?
            ))
        };
        s.push_str(&edge().map_err(|e| Error::recipe(manifest, Some(p.line), e.to_string()))?);
    }
    Ok(s)
}

/// Writes build.ninja beside the manifest (the current folder), through the output module.
pub fn write(manifest: &Path, planned: &[Planned]) -> Result<PathBuf> {
    let exe = std::env::current_exe().map_err(|e| Error::io(Path::new("cubeforge"), e))?;
    let out = PathBuf::from("build.ninja");
    let inputs: Vec<PathBuf> = std::iter::once(manifest.to_path_buf())
        .chain(planned.iter().filter_map(|p| p.input.clone()))
        .collect();
    let files = Files::new(vec![(
        out.clone(),
        text(manifest, &exe, planned)?.into_bytes(),
    )]);
    output::deliver(&files, &Destination::Path(out.clone()), &inputs)?;
    Ok(out)
}
