//! `cubeforge batch`: a manifest of jobs over many inputs, each built from its command's own
//! flags exactly as that command line would be, run one after another; a failing job does not
//! stop the others. (First slice of the pipeline issue: no incremental state, depfiles, ninja
//! or shards yet; inputs are decoded by each job.)

use super::{Cli, Command};
use cubeforge::{Error, Job, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The manifest (TOML): `[[job]]` tables of `inputs` (paths or globs), `command`, `args`
    /// and `output` (with {stem}, {name} and {dir} of each input); paths relative to it.
    pub manifest: PathBuf,
    /// Print each job's command line and run nothing.
    #[arg(long)]
    pub dry_run: bool,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    job: Vec<Entry>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    inputs: toml::Spanned<Vec<String>>,
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
];

/// One job's command line, after `cubeforge`.
struct Planned {
    line: usize,
    argv: Vec<String>,
}

/// The line (from 1) of byte `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

fn plan(path: &Path, text: &str) -> Result<Vec<Planned>> {
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
        let at = line_of(text, entry.inputs.span().start);
        let mut inputs = Vec::new();
        for pattern in entry.inputs.get_ref() {
            let found = expand(pattern)
                .map_err(|msg| recipe_err(Some(at), format!("input {pattern:?}: {msg}")))?;
            inputs.extend(found);
        }
        if inputs.is_empty() && command != "lut" {
            return Err(recipe_err(Some(at), "no input matches".into()));
        }
        for input in inputs {
            let output = fill(&entry.output, &input);
            let mut argv = vec![command.clone()];
            if command != "lut" {
                argv.push(input.display().to_string());
            }
            argv.extend(["-o".to_owned(), output]);
            argv.extend(entry.args.iter().cloned());
            planned.push(Planned { line, argv });
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

/// The job a command line describes, built by that command's own flags.
fn job_of(argv: &[String]) -> Result<Box<dyn Job>> {
    let cli = <Cli as clap::Parser>::try_parse_from(
        std::iter::once("cubeforge".to_owned()).chain(argv.iter().cloned()),
    )
    .map_err(|e| Error::usage(super::one_line(&e)))?;
    Ok(match cli.command {
        Command::Convert(a) => Box::new(super::convert::job(a)?),
        Command::Prefilter(a) => Box::new(super::prefilter::job(a)?),
        Command::Irradiance(a) => Box::new(super::irradiance::job(a)?),
        Command::Ibl(a) => Box::new(super::ibl::job(a)?),
        Command::Lut(a) => Box::new(super::lut::job(a)?),
        Command::Control(a) => Box::new(super::control::job(a)?),
        Command::Preview(a) => Box::new(super::preview::job(a)?),
        _ => return Err(Error::usage("not a job")),
    })
}

pub fn run(a: Args, verbose: bool) -> Result<()> {
    let text = std::fs::read_to_string(&a.manifest).map_err(|e| Error::io(&a.manifest, e))?;
    // Paths in the manifest (its globs included) are relative to it.
    if let Some(dir) = a.manifest.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::env::set_current_dir(dir).map_err(|e| Error::io(dir, e))?;
    }
    let planned = plan(&a.manifest, &text)?;
    let mut failed = Vec::new();
    for p in &planned {
        let line = format!("cubeforge {}", p.argv.join(" "));
        if a.dry_run {
            super::say(&line)?;
            continue;
        }
        let result = job_of(&p.argv).and_then(|job| {
            let observer = super::Observer::new(verbose);
            let report = job.run(&observer)?;
            observer.report(&report)
        });
        if let Err(e) = result {
            failed.push(format!("line {}: {line}: {}", p.line, e.with_flags()));
        }
    }
    for f in &failed {
        super::tell(format_args!("cubeforge: batch: failed: {f}"));
    }
    let ran = planned.len() - failed.len();
    if !a.dry_run {
        super::report(format!("batch: {ran} ran, {} failed", failed.len()))?;
    }
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Error::usage(format!(
            "{} of {} jobs failed",
            failed.len(),
            planned.len()
        )))
    }
}
