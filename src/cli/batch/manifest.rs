//! The batch manifest: `[[job]]` tables of inputs (paths or globs), a command, its args and
//! an output template, read into command lines; errors name the manifest's line.

use cubeforge::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    job: Vec<Entry>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    inputs: Option<toml::Spanned<Vec<String>>>,
    command: toml::Spanned<String>,
    #[serde(default)]
    args: Vec<String>,
    output: String,
}

/// The commands a manifest may name: those that are jobs.
const COMMANDS: &[&str] = &[
    "convert",
    "prefilter",
    "irradiance",
    "ibl",
    "lut",
    "control",
    "preview",
    "view",
];

/// Commands whose first argument is not an input file: `lut` takes none, `control` a recipe.
fn takes_input(command: &str) -> bool {
    command != "lut"
}

/// One job's command line, after `cubeforge`.
pub struct Planned {
    /// The manifest line of its `command`.
    pub line: usize,
    /// The command line, after `cubeforge`.
    pub argv: Vec<String>,
    /// The input it was made for (None: `lut`, which reads none).
    pub input: Option<PathBuf>,
    /// Its output, as the template made it.
    pub output: String,
}

/// The line (from 1) of byte `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

pub fn plan(path: &Path, text: &str) -> Result<Vec<Planned>> {
    let recipe_err = |line: Option<usize>, msg: String| Error::Recipe {
        path: path.to_path_buf(),
        line,
        msg,
    };
    let manifest: Manifest = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start));
        recipe_err(line, e.message().to_owned())
    })?;
    let mut planned = Vec::new();
    for entry in manifest.job {
        let line = line_of(text, entry.command.span().start);
        let command = entry.command.get_ref();
        if !COMMANDS.contains(&command.as_str()) {
            return Err(recipe_err(
                Some(line),
                format!("command {command:?}: use one of {}", COMMANDS.join(", ")),
            ));
        }
        if entry
            .args
            .iter()
            .any(|a| a == "-o" || a.starts_with("--output"))
        {
            return Err(recipe_err(
                Some(line),
                "the output goes in `output` (a template with {stem}, {name}, {dir}), not in args"
                    .into(),
            ));
        }
        let at = entry
            .inputs
            .as_ref()
            .map_or(line, |i| line_of(text, i.span().start));
        let patterns = entry.inputs.as_ref().map_or(&[][..], |i| i.get_ref());
        if !takes_input(command) {
            if !patterns.is_empty() {
                return Err(recipe_err(
                    Some(at),
                    format!("{command} reads no input: leave `inputs` out"),
                ));
            }
            let mut argv = vec![command.clone(), "-o".into(), entry.output.clone()];
            argv.extend(entry.args.iter().cloned());
            planned.push(Planned {
                line,
                argv,
                input: None,
                output: entry.output.clone(),
            });
            continue;
        }
        let mut inputs = Vec::new();
        for pattern in patterns {
            let found = expand(pattern)
                .map_err(|msg| recipe_err(Some(at), format!("input {pattern:?}: {msg}")))?;
            inputs.extend(found);
        }
        if inputs.is_empty() {
            return Err(recipe_err(Some(at), "no input matches".into()));
        }
        for input in inputs {
            let output = fill(&entry.output, &input);
            let mut argv = vec![command.clone(), input.display().to_string()];
            argv.extend(["-o".to_owned(), output.clone()]);
            argv.extend(entry.args.iter().cloned());
            planned.push(Planned {
                line,
                argv,
                input: Some(input),
                output,
            });
        }
    }
    Ok(planned)
}

/// The files a pattern names: itself when it holds no wildcard (it need not exist yet: the
/// job says so), else the matches in name order.
fn expand(pattern: &str) -> std::result::Result<Vec<PathBuf>, String> {
    if !pattern.contains(['*', '?', '[']) {
        return Ok(vec![PathBuf::from(pattern)]);
    }
    let mut found: Vec<PathBuf> = glob::glob(pattern)
        .map_err(|e| e.to_string())?
        .filter_map(|p| p.ok())
        .collect();
    found.sort();
    Ok(found)
}

/// The output template with {stem}, {name} and {dir} of `input` filled in.
fn fill(template: &str, input: &Path) -> String {
    let part = |s: Option<&std::ffi::OsStr>| s.map(|s| s.to_string_lossy().into_owned());
    let dir = input
        .parent()
        .map(|d| d.display().to_string())
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| ".".into());
    template
        .replace("{stem}", &part(input.file_stem()).unwrap_or_default())
        .replace("{name}", &part(input.file_name()).unwrap_or_default())
        .replace("{dir}", &dir)
}

/// `s` as one word for a POSIX shell: as is when it holds only safe characters, else in
/// single quotes.
pub fn shell_quote(s: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}
