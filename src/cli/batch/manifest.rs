//! The batch manifest: `[[job]]` tables of inputs (paths or globs), a command, its args and
//! an output template, read into command lines; errors name the manifest's line.

use super::expand::{expand, is_glob};
use super::ninja;
use super::template::{Template, Unfilled};
use cubeforge::internals::output::depfile;
use cubeforge::{Error, Result};
use std::collections::{HashMap, HashSet};
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
    output: toml::Spanned<String>,
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

/// The line (from 1) of each byte offset, by a search over the lines' starts (a count of the
/// line breaks before each table made 10,000 tables quadratic).
struct Lines(Vec<usize>);

impl Lines {
    fn new(text: &str) -> Lines {
        let breaks = text.match_indices('\n').map(|(i, _)| i + 1);
        Lines(std::iter::once(0).chain(breaks).collect())
    }
    fn of(&self, at: usize) -> usize {
        self.0.partition_point(|&start| start <= at)
    }
}

/// A relative path that starts with `-` as `./-...`, so that no command reads a file named
/// `-o.exr` or `--help.exr` as an option (`-` alone, standard input or output, stays).
fn as_arg(p: &str) -> String {
    if p.starts_with('-') && p != "-" {
        format!("./{p}")
    } else {
        p.to_owned()
    }
}

/// Why no build file can name `input` or the `output` made of it, in Ninja's and Make's
/// syntax (build.ninja's, a depfile's): the message names the file. A batch plans the jobs
/// that `--emit ninja` and `--depfiles` would, so that the three runners build the same.
fn unnameable(input: Option<&str>, output: &str) -> Option<String> {
    let depfile = |p: &str, target| depfile::escape(Path::new(p), target).err();
    if let Some(i) = input {
        if let Some(e) = ninja::path(i).err().or_else(|| depfile(i, false)) {
            return Some(e.to_string());
        }
    }
    let e = ninja::path(output)
        .err()
        .or_else(|| depfile(output, true))?;
    Some(match input {
        Some(i) => format!("{i}: its output {e}"),
        None => e.to_string(),
    })
}

/// Why a path makes no job.
enum NoJob {
    /// Its name: a glob's match is left out, a path named as it is an error.
    Input(String),
    /// The template leads out of its folder: an error, whatever the input.
    Template(String),
}

/// The input as the command line names it, and its output; or why it makes no job (each
/// message starts with the input's name).
fn job_paths(
    template: &Template,
    input: &Path,
    build_files: bool,
) -> std::result::Result<(String, String), NoJob> {
    let Some(i) = input.to_str() else {
        return Err(NoJob::Input(format!(
            "{}: its name is not UTF-8, which a manifest's command line cannot hold",
            input.display()
        )));
    };
    let i = as_arg(i);
    let output = match template.fill(Path::new(&i)) {
        Ok(o) => as_arg(&o),
        Err(Unfilled::Input(msg)) => return Err(NoJob::Input(format!("{i}: {msg}"))),
        Err(Unfilled::Template(msg)) => return Err(NoJob::Template(msg)),
    };
    match unnameable(Some(&i), &output).filter(|_| build_files) {
        Some(why) => Err(NoJob::Input(why)),
        None => Ok((i, output)),
    }
}

/// The manifest's jobs. A glob's match that makes no job (a stem of `..`; with `build_files`,
/// for depfiles or build.ninja, a name that Make or Ninja cannot hold) is left out and told
/// through `warn`, with the manifest's line; the same path named without wildcards is an
/// error. Without build files every name the file system holds makes its job.
pub fn plan(
    path: &Path,
    text: &str,
    build_files: bool,
    warn: &mut dyn FnMut(String),
) -> Result<Vec<Planned>> {
    let recipe_err = |line: Option<usize>, msg: String| Error::Recipe {
        path: path.to_path_buf(),
        line,
        msg,
    };
    let lines = Lines::new(text);
    let manifest: Manifest = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| lines.of(s.start));
        recipe_err(line, e.message().to_owned())
    })?;
    let mut planned = Vec::new();
    // Each pattern's matches, read once however many tables name it.
    let mut found: HashMap<String, Vec<PathBuf>> = HashMap::new();
    let mut told = HashSet::new();
    for entry in manifest.job {
        let line = lines.of(entry.command.span().start);
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
        let out_line = lines.of(entry.output.span().start);
        let template = Template::parse(entry.output.get_ref())
            .map_err(|msg| recipe_err(Some(out_line), msg))?;
        let at = entry
            .inputs
            .as_ref()
            .map_or(line, |i| lines.of(i.span().start));
        let patterns = entry.inputs.as_ref().map_or(&[][..], |i| i.get_ref());
        if !takes_input(command) {
            if !patterns.is_empty() {
                return Err(recipe_err(
                    Some(at),
                    format!("{command} reads no input: leave `inputs` out"),
                ));
            }
            if template.has_placeholders() {
                return Err(recipe_err(
                    Some(out_line),
                    format!(
                        "{command} reads no input: its output has no {{stem}}, {{name}} or {{dir}}"
                    ),
                ));
            }
            let output = as_arg(entry.output.get_ref());
            if let Some(why) = unnameable(None, &output).filter(|_| build_files) {
                return Err(recipe_err(Some(out_line), why));
            }
            let mut argv = vec![command.clone(), "-o".into(), output.clone()];
            argv.extend(entry.args.iter().cloned());
            planned.push(Planned {
                line,
                argv,
                input: None,
                output,
            });
            continue;
        }
        let before = planned.len();
        let mut left_out = 0;
        for pattern in patterns {
            if !found.contains_key(pattern) {
                let paths = expand(pattern)
                    .map_err(|msg| recipe_err(Some(at), format!("input {pattern:?}: {msg}")))?;
                found.insert(pattern.clone(), paths);
            }
            for input in &found[pattern] {
                match job_paths(&template, input, build_files) {
                    Ok((input, output)) => {
                        let mut argv = vec![command.clone(), input.clone(), "-o".into()];
                        argv.push(output.clone());
                        argv.extend(entry.args.iter().cloned());
                        planned.push(Planned {
                            line,
                            argv,
                            input: Some(PathBuf::from(input)),
                            output,
                        });
                    }
                    Err(NoJob::Input(msg)) if is_glob(pattern) => {
                        left_out += 1;
                        if told.insert(msg.clone()) {
                            warn(format!("{}: line {at}: left out {msg}", path.display()));
                        }
                    }
                    Err(NoJob::Input(msg)) => return Err(recipe_err(Some(at), msg)),
                    Err(NoJob::Template(msg)) => return Err(recipe_err(Some(out_line), msg)),
                }
            }
        }
        if planned.len() == before {
            return Err(recipe_err(
                Some(at),
                match left_out {
                    0 => "no input matches".into(),
                    n => format!("each of the {n} files its inputs match is left out (above)"),
                },
            ));
        }
    }
    Ok(planned)
}

/// `s` as one word for a POSIX shell: as is when it holds only safe characters, else in
/// single quotes, in which every byte but `'` (written `'\''`) is itself: sound for any
/// text (a command line's words are UTF-8 and hold no NUL).
pub fn shell_quote(s: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c);
    if !s.is_empty() && s.chars().all(safe) {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}
