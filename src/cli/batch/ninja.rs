//! `batch --emit ninja`: a build.ninja whose edges are the manifest's jobs. Each edge runs
//! the job's command line with `--depfile`, so Ninja learns every file the job read (faces,
//! decals, recipes, materials) and reruns it when one changes; the cubeforge program is an
//! input of every edge, and the manifest of build.ninja itself (Ninja regenerates it first).

use super::manifest::{shell_quote, Planned};
use cubeforge::output::{self, Destination, Files};
use cubeforge::{Error, Result};
use std::path::{Path, PathBuf};

/// A path in a build line: `$`, space and `:` escaped as Ninja reads them.
fn path(p: &str) -> String {
    let mut out = String::new();
    for c in p.chars() {
        if matches!(c, '$' | ' ' | ':' | '\n') {
            out.push('$');
        }
        out.push(c);
    }
    out
}

/// A variable's value: only `$` is special.
fn value(v: &str) -> String {
    v.replace('$', "$$")
}

/// The text of build.ninja for `planned`, run by the program `exe`, from `manifest`.
pub fn text(manifest: &Path, exe: &Path, planned: &[Planned]) -> String {
    let m = manifest.display().to_string();
    let exe = exe.display().to_string();
    let mut s = format!(
        "# Written by `cubeforge batch {m} --emit ninja`: edit {m}, not this file (Ninja\n\
         # writes it again when the manifest changes; run the command again after adding\n\
         # inputs that its globs match).\n\
         ninja_required_version = 1.10\n\n\
         cubeforge = {}\n\n\
         rule cubeforge\n  command = $cubeforge -q $args --depfile $out.d\n  depfile = $out.d\n  \
         deps = gcc\n  description = cubeforge $args\n\n\
         rule manifest\n  command = $cubeforge -q batch $in --emit ninja\n  generator = 1\n  \
         description = build.ninja from $in\n\n\
         build build.ninja: manifest {}\n",
        value(&shell_quote(&exe)),
        path(&m)
    );
    for p in planned {
        let args: Vec<String> = p.argv.iter().map(|a| shell_quote(a)).collect();
        let input = p
            .input
            .as_ref()
            .map(|i| format!(" {}", path(&i.display().to_string())))
            .unwrap_or_default();
        s.push_str(&format!(
            "\n# {m}, line {}\nbuild {}: cubeforge{input} | {}\n  args = {}\n",
            p.line,
            path(&p.output),
            path(&exe),
            value(&args.join(" "))
        ));
    }
    s
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
        text(manifest, &exe, planned).into_bytes(),
    )]);
    output::deliver(&files, &Destination::Path(out.clone()), &inputs)?;
    Ok(out)
}
