//! `cubeforge batch`: a manifest of jobs over many inputs, each built from its command's own
//! flags exactly as that command line would be, run by the library's [`cubeforge::internals::batch`]
//! (inputs side by side, each decoded once, incremental through a state file, sharded), or
//! written out as a `build.ninja` for Ninja to run.

mod expand;
mod manifest;
mod ninja;
mod template;

use super::{Cli, Command};
use cubeforge::internals::batch::{Batch, BatchJob, Done, Outcome, Shard};
use cubeforge::{Error, Job, Result};
use manifest::Planned;
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// The manifest (TOML): `[[job]]` tables of `inputs` (paths or globs), `command`, `args`
    /// and `output` (with {stem}, {name} and {dir} of each input); paths relative to it.
    pub manifest: PathBuf,
    /// Print what would run and why (and what is up to date); run nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Run every job, up to date or not.
    #[arg(long)]
    pub force: bool,
    /// Run the I-th of N parts (from 0): each machine of a CI matrix or array job passes its
    /// index. Each input's jobs stay together; inputs go by cost (their jobs' planned bytes,
    /// from the headers), the greatest first onto the least-loaded part, the same on every
    /// machine; I/N:order deals them out in turn instead. --dry-run prints each part's cost.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Write a Make-style depfile beside each job's output (OUTPUT.d): the files it read.
    #[arg(long)]
    pub depfiles: bool,
    /// Write a build file for another runner instead of running: `ninja` writes build.ninja
    /// beside the manifest (an edge per job, with depfiles).
    #[arg(long, value_enum, value_name = "RUNNER")]
    pub emit: Option<Emit>,
    /// Memory the inputs running side by side may plan together, in bytes or with K, M, G
    /// (default: half the machine's memory): fewer run at once under a smaller budget. Each
    /// job's own budget is its --max-memory in the manifest's args.
    #[arg(long, value_parser = super::bytes)]
    pub max_memory: Option<u64>,
    /// A cache the team shares, in Bazel's HTTP remote-cache protocol (bazel-remote,
    /// BuildBuddy, nginx with WebDAV PUT; default: $CUBEFORGE_CACHE): a job that would run
    /// is fetched when the cache holds its outputs for the same build, command and input
    /// bytes, and uploaded when it ran. Credentials: $CUBEFORGE_CACHE_TOKEN (bearer), or
    /// $CUBEFORGE_CACHE_USER and $CUBEFORGE_CACHE_PASSWORD (basic).
    #[arg(long, value_name = "URL")]
    pub cache: Option<String>,
    /// Read the cache, never write to it (a CI job that may not change what others get).
    #[arg(long)]
    pub cache_read_only: bool,
}

/// Build files `--emit` writes.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Emit {
    /// build.ninja: `ninja -j N` runs the jobs, rebuilding what changed.
    Ninja,
}

const EXAMPLES: &str = "\
Examples (assets.toml: [[job]] tables of inputs, command, args, output; docs/pipelines.md):
  # run what changed since the last run (assets.state.json keeps what each job read)
  cubeforge batch assets.toml
  # what would run, and why
  cubeforge batch assets.toml --dry-run
  # this machine's third of the jobs (CI matrix, Slurm array, Kubernetes Indexed Job)
  cubeforge batch assets.toml --shard 2/3
  # a build.ninja beside the manifest, for ninja -j 8
  cubeforge batch assets.toml --emit ninja
  # fetch what a team's cache holds, build the rest and upload it
  cubeforge batch assets.toml --cache http://cache.studio:8080";

/// The state file of `manifest` (and of a shard, which keeps its own).
fn state_path(manifest: &Path, shard: Option<Shard>) -> PathBuf {
    let stem = manifest
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "batch".into());
    let name = match shard {
        Some(s) => format!("{stem}.shard-{}-of-{}.state.json", s.index, s.count),
        None => format!("{stem}.state.json"),
    };
    PathBuf::from(name)
}

/// The job a command line describes, built by that command's own flags through `parser`,
/// the command line's parser built once for the batch (built again for each job, it was
/// most of the planning of a large manifest).
fn job_of(parser: &mut clap::Command, argv: &[String]) -> Result<Box<dyn Job + Send + Sync>> {
    let usage = |e: clap::Error| Error::usage(super::one_line(&e));
    let matches = parser
        .try_get_matches_from_mut(
            std::iter::once("cubeforge").chain(argv.iter().map(String::as_str)),
        )
        .map_err(usage)?;
    let cli = <Cli as clap::FromArgMatches>::from_arg_matches(&matches).map_err(usage)?;
    if cli.depfile.is_some() {
        return Err(Error::usage(
            "--depfile in a manifest's args: give batch --depfiles (one beside each output)",
        ));
    }
    Ok(match cli.command {
        Command::Convert(a) => Box::new(super::convert::job(a)?),
        Command::Prefilter(a) => Box::new(super::prefilter::job(a)?),
        Command::Irradiance(a) => Box::new(super::irradiance::job(a)?),
        Command::Ibl(a) => Box::new(super::ibl::job(a)?),
        Command::Lut(a) => Box::new(super::lut::job(a)?),
        Command::Control(a) => Box::new(super::control::job(a)?),
        Command::Preview(a) => Box::new(super::preview::job(a)?),
        Command::View(a) => Box::new(super::view::job(a)?),
        _ => return Err(Error::usage("not a job")),
    })
}

/// The job a command line (its words after `cubeforge`) describes, built as a manifest's
/// are: the Python package (python/, which compiles the command line in) runs the CLI's own
/// jobs from keyword arguments named as its flags.
#[allow(dead_code)]
pub fn job_of_words(argv: &[String]) -> Result<Box<dyn Job + Send + Sync>> {
    job_of(&mut <Cli as clap::CommandFactory>::command(), argv)
}

/// A `batch` command line (its words after `cubeforge`) parsed and planned as the command
/// does it, silently (`warn` hears the manifest's warnings): the Python package's `batch`.
#[allow(dead_code)]
pub fn prepare_words(argv: &[String], warn: &mut dyn FnMut(String)) -> Result<Prepared> {
    let words = std::iter::once("cubeforge").chain(argv.iter().map(String::as_str));
    let cli = <Cli as clap::Parser>::try_parse_from(words)
        .map_err(|e| Error::usage(super::one_line(&e)))?;
    match cli.command {
        Command::Batch(a) => prepare(&a, warn),
        _ => Err(Error::usage("not a batch command line")),
    }
}

/// A job that cannot even be built (a bad flag) fails alone, as a job that runs and fails.
struct Unbuilt(String, cubeforge::Limits);

impl Job for Unbuilt {
    fn validate(&self) -> Result<Vec<cubeforge::Warning>> {
        Err(Error::usage(self.0.clone()))
    }
    fn memory_estimate(&self) -> Result<u64> {
        Ok(0)
    }
    fn run(&self, _: &dyn cubeforge::Progress) -> Result<cubeforge::Report> {
        Err(Error::usage(self.0.clone()))
    }
    fn limits_mut(&mut self) -> &mut cubeforge::Limits {
        &mut self.1
    }
}

/// What a batch that ran did: the library's report and what its lines need.
pub struct Ran {
    pub report: cubeforge::internals::batch::BatchReport,
    pub dry_run: bool,
    /// A cache was asked.
    pub cached: bool,
    pub seconds: f64,
    /// The manifest line of each job's id.
    lines: std::collections::HashMap<String, usize>,
}

/// A batch planned: its jobs ready to run, or its build file written instead (the path, for
/// the Python package's report, and the line that says so).
pub enum Prepared {
    Ready(Box<Ready>),
    Emitted(#[allow(dead_code)] PathBuf, String),
}

/// The jobs of a manifest, built and ready to run.
pub struct Ready {
    batch: Batch,
    cached: bool,
    lines: std::collections::HashMap<String, usize>,
}

pub fn run(a: Args, verbose: bool) -> Result<()> {
    let shown = verbose || a.dry_run;
    match prepare(&a, &mut |w| super::warn(w))? {
        Prepared::Emitted(_, line) => super::report(line),
        Prepared::Ready(ready) => {
            let ran = ready.run(&|d: &Done| show(d, shown))?;
            if ran.cached && verbose && !ran.dry_run {
                super::report(format!(
                    "cache: {} blobs uploaded, {} already there (not sent again)",
                    ran.report.blobs_uploaded, ran.report.blobs_present
                ))?;
            }
            summarize(&ran)
        }
    }
}

/// Plans the batch `a` describes (`warn` hears the manifest's warnings), from the manifest's
/// folder (the working folder changes to it), or writes its build file.
pub fn prepare(a: &Args, warn: &mut dyn FnMut(String)) -> Result<Prepared> {
    let text = std::fs::read_to_string(&a.manifest).map_err(|e| Error::io(&a.manifest, e))?;
    let name = PathBuf::from(a.manifest.file_name().unwrap_or(a.manifest.as_os_str()));
    // Paths in the manifest (its globs included) are relative to it.
    if let Some(dir) = a.manifest.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::env::set_current_dir(dir).map_err(|e| Error::io(dir, e))?;
    }
    // Depfiles and build.ninja name every file: only then do names they cannot hold matter.
    let build_files = a.depfiles || a.emit.is_some();
    let planned = manifest::plan(&a.manifest, &text, build_files, warn)?;
    if let Some(Emit::Ninja) = a.emit {
        let out = ninja::write(&name, &planned)?;
        let line = format!(
            "batch: wrote {} ({} jobs): run ninja -C {}",
            out.display(),
            planned.len(),
            a.manifest
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .map_or(".".into(), |d| manifest::shell_quote(
                    &d.display().to_string()
                ))
        );
        let line = cubeforge::internals::error::escape_text(&line).into_owned();
        return Ok(Prepared::Emitted(out, line));
    }
    let jobs = jobs_of(&planned);
    let lines = planned.iter().map(|p| (p.line_text(), p.line)).collect();
    let cache = cache_of(a)?;
    let cached = cache.is_some();
    let batch = Batch {
        cache,
        state: Some(state_path(&name, a.shard)),
        force: a.force,
        dry_run: a.dry_run,
        shard: a.shard,
        depfiles: a.depfiles,
        max_memory: a
            .max_memory
            .unwrap_or(cubeforge::Limits::default().max_memory),
        ..Batch::new(jobs)
    };
    Ok(Prepared::Ready(Box::new(Ready {
        batch,
        cached,
        lines,
    })))
}

impl Ready {
    /// The jobs of the manifest (a shard runs a part of them).
    #[allow(dead_code)]
    pub fn jobs(&self) -> usize {
        self.batch.jobs.len()
    }

    /// Stops the batch between jobs once `flag` is set (a Python caller's Ctrl-C).
    #[allow(dead_code)]
    pub fn stop_when(&mut self, flag: std::sync::Arc<std::sync::atomic::AtomicBool>) {
        self.batch.stop = Some(flag);
    }

    /// Runs the jobs, telling `tell` of each one's end (from any thread); prints nothing.
    pub fn run(self, tell: &(dyn Fn(&Done) + Sync)) -> Result<Ran> {
        let dry_run = self.batch.dry_run;
        let start = std::time::Instant::now();
        let report = self.batch.run(tell)?;
        Ok(Ran {
            report,
            dry_run,
            cached: self.cached,
            seconds: start.elapsed().as_secs_f64(),
            lines: self.lines,
        })
    }
}

/// The batch's jobs, one per planned command line (one that cannot be built fails alone).
fn jobs_of(planned: &[Planned]) -> Vec<BatchJob> {
    let mut parser = <Cli as clap::CommandFactory>::command();
    planned
        .iter()
        .map(|p| {
            let job: Box<dyn Job + Send + Sync> = match job_of(&mut parser, &p.argv) {
                Ok(j) => j,
                Err(e) => Box::new(Unbuilt(e.with_flags(), cubeforge::Limits::default())),
            };
            BatchJob {
                id: p.line_text(),
                input: p.input.clone(),
                output: PathBuf::from(&p.output),
                job,
            }
        })
        .collect()
}

/// The cache `--cache` or `$CUBEFORGE_CACHE` names (an empty one: none).
fn cache_of(a: &Args) -> Result<Option<cubeforge::internals::batch::Cache>> {
    use cubeforge::internals::batch::{Cache, HttpStore};
    let url = a
        .cache
        .clone()
        .or_else(|| std::env::var("CUBEFORGE_CACHE").ok())
        .filter(|u| !u.is_empty());
    match url {
        None if a.cache_read_only => Err(Error::usage(
            "--cache-read-only needs a cache: --cache URL or $CUBEFORGE_CACHE",
        )),
        None => Ok(None),
        Some(u) => {
            let store =
                HttpStore::from_env(&u).map_err(|e| Error::usage(format!("--cache: {e}")))?;
            Ok(Some(Cache::new(store, a.cache_read_only)))
        }
    }
}

/// The warnings, the summary lines, then each failure in one line with its manifest line;
/// an error when any job failed.
fn summarize(ran: &Ran) -> Result<()> {
    for w in &ran.report.warnings {
        super::warn(w.with_flags());
    }
    for line in ran.summary() {
        super::report(line)?;
    }
    for line in ran.failures() {
        super::tell(format_args!("cubeforge: {line}"));
    }
    ran.failed()
}

impl Ran {
    /// The summary as the command prints it: with --dry-run each shard's cost, then the line
    /// of counts.
    pub fn summary(&self) -> Vec<String> {
        let (report, dry_run) = (&self.report, self.dry_run);
        let mut out = Vec::new();
        if dry_run {
            let n = report.shard_costs.len();
            for (i, (cost, jobs)) in report.shard_costs.iter().enumerate() {
                out.push(format!(
                    "shard {i}/{n}: {jobs} jobs, estimated {:.1} MiB",
                    *cost as f64 / (1u64 << 20) as f64
                ));
            }
        }
        let shards = if report.other_shards > 0 {
            format!(", {} left to other shards", report.other_shards)
        } else {
            String::new()
        };
        let n = report.jobs.len();
        out.push(if dry_run {
            let fetch = self
                .cached
                .then(|| format!(", {} from the cache", report.would_fetch()));
            format!(
                "batch: {n} jobs: {} would run{}, {} up to date{shards}",
                report.would_run(),
                fetch.unwrap_or_default(),
                report.up_to_date()
            )
        } else {
            let fetched = self
                .cached
                .then(|| format!(", {} from the cache", report.fetched()));
            format!(
                "batch: {n} jobs: {} ran{}, {} up to date, {} failed{shards} ({:.2} s)",
                report.ran(),
                fetched.unwrap_or_default(),
                report.up_to_date(),
                report.failed(),
                self.seconds
            )
        });
        out
    }

    /// Each failed job in one line (control characters written out): its manifest line, its
    /// command line and its error.
    pub fn failures(&self) -> Vec<String> {
        let failed = self.report.jobs.iter().filter_map(|d| match &d.outcome {
            Outcome::Failed(e) => Some((d, e)),
            _ => None,
        });
        failed
            .map(|(d, e)| {
                let line = format!(
                    "batch: failed: line {}: cubeforge {}: {}",
                    self.lines.get(&d.id).copied().unwrap_or(0),
                    d.id,
                    e.with_flags()
                );
                cubeforge::internals::error::escape_text(&line).into_owned()
            })
            .collect()
    }

    /// The batch's error when a job failed (as the command's exit status says).
    pub fn failed(&self) -> Result<()> {
        match self.report.failed() {
            0 => Ok(()),
            failed => Err(Error::usage(format!(
                "{failed} of {} jobs failed",
                self.report.jobs.len()
            ))),
        }
    }
}

/// One job's end, in one line (and its warnings) on standard output; up-to-date jobs only with
/// -v; failures are listed under the summary. Ids and reasons name files: every line is
/// written through `escape_text`, so an ESC or BEL in a file's name never reaches the terminal.
fn show(d: &Done, verbose: bool) {
    let id = &d.id;
    let say = |line: String| {
        let _ = super::report(cubeforge::internals::error::escape_text(&line));
    };
    match &d.outcome {
        Outcome::Ran(_, report) => {
            for w in &report.warnings {
                super::warn(format_args!("{id}: {}", w.with_flags()));
            }
            if d.cache_miss && verbose {
                say(format!("cache miss  cubeforge {id}"));
            }
            say(format!("ran         cubeforge {id} ({:.2} s)", d.seconds));
        }
        Outcome::Fetched(..) => say(format!("from cache  cubeforge {id} ({:.2} s)", d.seconds)),
        Outcome::WouldFetch(why) => say(format!(
            "would fetch cubeforge {id} ({why}): the cache has it"
        )),
        Outcome::UpToDate if verbose => say(format!("up to date  cubeforge {id}")),
        Outcome::UpToDate => {}
        Outcome::WouldRun(why) if d.cache_miss => say(format!(
            "would run   cubeforge {id} ({why}; not in the cache)"
        )),
        Outcome::WouldRun(why) => say(format!("would run   cubeforge {id} ({why})")),
        Outcome::Failed(_) => {}
    }
}

impl Planned {
    /// The job's command line after `cubeforge`, quoted for a shell: its id.
    fn line_text(&self) -> String {
        self.argv
            .iter()
            .map(|a| manifest::shell_quote(a))
            .collect::<Vec<_>>()
            .join(" ")
    }
}
