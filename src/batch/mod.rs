//! Many jobs as one build step: the jobs of one input run one after another and share its
//! decode; inputs run side by side within the memory budget; a job whose record in the state
//! file says it read the same bytes with the same build, and whose outputs are all there, is
//! skipped; a failing job does not stop the others; a shard runs a fixed part of the jobs.
//! Jobs that would write one file, or each other's files or inputs, are refused before any
//! runs.
//! `cubeforge batch` builds the jobs from a manifest; a tool that embeds cubeforge builds
//! them itself:
//!
//! ```
//! use cubeforge::{Batch, BatchJob, Destination, Outcome, PrefilterJob};
//! use std::path::PathBuf;
//!
//! # fn main() -> cubeforge::Result<()> {
//! let dir = std::env::temp_dir().join(format!("cubeforge-doc-batch-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).ok();
//! let input = PathBuf::from("fixtures/sky.exr");
//! // Two chains of one panorama (decoded once), and what was run kept in a state file.
//! let batch = || {
//!     let jobs = [16, 32].map(|size| {
//!         let out = dir.join(format!("sky{size}.ktx2"));
//!         let job = PrefilterJob {
//!             size: Some(size),
//!             ..PrefilterJob::new(vec![input.clone()], Destination::Path(out.clone()))
//!         };
//!         BatchJob::new(format!("sky at {size} px"), Some(input.clone()), out, job)
//!     });
//!     Batch { state: Some(dir.join("state.json")), ..Batch::new(jobs.into()) }
//! };
//! let report = batch().run(&|done| {
//!     if let Outcome::Failed(e) = &done.outcome {
//!         eprintln!("{}: {e}", done.id);
//!     }
//! })?;
//! assert_eq!(report.ran(), 2);
//! // Nothing changed: nothing runs.
//! assert_eq!(batch().run(&|_| {})?.up_to_date(), 2);
//! # std::fs::remove_dir_all(&dir).ok();
//! # Ok(())
//! # }
//! ```

mod cache;
mod conflicts;
#[cfg(feature = "http-cache")]
mod http;
mod reapi;
mod shard;
mod state;

pub use cache::{Cache, Store};
#[cfg(feature = "http-cache")]
pub use http::HttpStore;
pub use state::Why;

use crate::error::{Error, Result};
use crate::io::{Limits, Session};
use crate::jobs::{Job, Report};
use crate::output::{self, Destination, Files};
use state::State;
use std::path::PathBuf;

/// One job of a batch.
pub struct BatchJob {
    /// Names the job in the state file and in reports: its command line, say. It must tell
    /// the job's options apart: a job whose id changed has no record and runs.
    pub id: String,
    /// The input the job belongs to: the jobs of one input run together and decode it once
    /// (None: a group of its own).
    pub input: Option<PathBuf>,
    /// The output as the job names it (a file or a folder, never `-`): a depfile's target,
    /// and what the batch checks against the other jobs' outputs and inputs.
    pub output: PathBuf,
    /// The work.
    pub job: Box<dyn Job + Send + Sync>,
}

impl BatchJob {
    /// A job named `id` of `input`'s group, writing `output`.
    pub fn new(
        id: impl Into<String>,
        input: Option<PathBuf>,
        output: PathBuf,
        job: impl Job + Send + Sync + 'static,
    ) -> BatchJob {
        BatchJob {
            id: id.into(),
            input,
            output,
            job: Box::new(job),
        }
    }
}

/// The `I`-th of `N` parts of a batch (from 0). Each input's jobs stay together; the inputs
/// are given out by [`ShardBy`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This part, from 0.
    pub index: usize,
    /// How many parts.
    pub count: usize,
    /// How inputs are given out.
    pub by: ShardBy,
}

/// How a sharded batch gives out its inputs: the same on every machine from the same manifest
/// and inputs, so independent tasks agree without a coordinator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShardBy {
    /// By cost (`I/N`): each input's jobs' planned bytes (from the headers) as its cost,
    /// greatest first onto the least-loaded shard (the lowest on a tie): one 16K panorama
    /// among 2K ones gets a shard to itself instead of a quarter of the others beside it.
    #[default]
    Cost,
    /// In turn (`I/N:order`): input k to shard k mod N, as before costs were weighed.
    Order,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let bad = || {
            format!(
                "{s:?}: give I/N, the I-th of N shards counted from 0 (0/4 .. 3/4), or I/N:order \
                 to deal the inputs out in turn"
            )
        };
        let (s_part, by) = match s.strip_suffix(":order") {
            Some(rest) => (rest, ShardBy::Order),
            None => (s, ShardBy::Cost),
        };
        let (i, n) = s_part.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            i.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count, by })
    }
}

/// A batch of jobs and how to run them.
pub struct Batch {
    /// The jobs, in order.
    pub jobs: Vec<BatchJob>,
    /// The state file that makes reruns incremental (None: every job runs; nothing is kept).
    pub state: Option<PathBuf>,
    /// Runs every job, up to date or not.
    pub force: bool,
    /// Says what would run, and why, and runs nothing.
    pub dry_run: bool,
    /// Runs only this part of the jobs.
    pub shard: Option<Shard>,
    /// Writes `OUTPUT.d`, a Make-style depfile, beside each job's output.
    pub depfiles: bool,
    /// The budget of the jobs that run at once (each job still checks its own plan).
    pub max_memory: u64,
    /// A cache shared with other machines: a job that would run is fetched from it when it
    /// holds the job's outputs for these inputs, and a job that ran is uploaded to it.
    pub cache: Option<Cache>,
    /// Set from another thread (a Python caller's Ctrl-C), the jobs not yet started fail as
    /// stopped, the running ones end, and the state keeps what finished.
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl Batch {
    /// Runs `jobs`, every one, with this machine's memory budget.
    pub fn new(jobs: Vec<BatchJob>) -> Batch {
        Batch {
            jobs,
            state: None,
            force: false,
            dry_run: false,
            shard: None,
            depfiles: false,
            max_memory: Limits::default().max_memory,
            cache: None,
            stop: None,
        }
    }
}

/// What became of one job.
#[derive(Debug)]
pub enum Outcome {
    /// It ran, for this reason.
    Ran(Why, Report),
    /// It would have run, for this reason, and its outputs came from the cache instead
    /// (the files written).
    Fetched(Why, Vec<PathBuf>),
    /// Its outputs are up to date: it did not run.
    UpToDate,
    /// A dry run: it would run, for this reason.
    WouldRun(Why),
    /// A dry run: it would run, and the cache would serve it.
    WouldFetch(Why),
    /// It failed; its outputs are as they were.
    Failed(Error),
}

/// One job's end.
#[derive(Debug)]
pub struct Done {
    /// The job's id.
    pub id: String,
    /// What became of it.
    pub outcome: Outcome,
    /// Seconds it took.
    pub seconds: f64,
    /// The cache was asked for it and had nothing (or nothing that could be used).
    pub cache_miss: bool,
}

/// What a batch did.
#[derive(Debug, Default)]
pub struct BatchReport {
    /// Each job of this shard, in the batch's order.
    pub jobs: Vec<Done>,
    /// Jobs left to the other shards.
    pub other_shards: usize,
    /// With a shard: each shard's estimated cost (its inputs' planned bytes) and jobs, in
    /// shard order.
    pub shard_costs: Vec<(u64, usize)>,
    /// With a cache: the blobs this batch uploaded, and those it did not send because the
    /// cache had them already.
    pub blobs_uploaded: usize,
    /// See `blobs_uploaded`.
    pub blobs_present: usize,
    /// Things to know: a state file that could not be read, say.
    pub warnings: Vec<crate::jobs::Warning>,
}

impl BatchReport {
    fn count(&self, f: impl Fn(&Outcome) -> bool) -> usize {
        self.jobs.iter().filter(|d| f(&d.outcome)).count()
    }
    /// Jobs that ran.
    pub fn ran(&self) -> usize {
        self.count(|o| matches!(o, Outcome::Ran(..)))
    }
    /// Jobs skipped as up to date.
    pub fn up_to_date(&self) -> usize {
        self.count(|o| matches!(o, Outcome::UpToDate))
    }
    /// Jobs whose outputs came from the cache.
    pub fn fetched(&self) -> usize {
        self.count(|o| matches!(o, Outcome::Fetched(..)))
    }
    /// Jobs that a dry run would run.
    pub fn would_run(&self) -> usize {
        self.count(|o| matches!(o, Outcome::WouldRun(_)))
    }
    /// Jobs that a dry run would fetch from the cache.
    pub fn would_fetch(&self) -> usize {
        self.count(|o| matches!(o, Outcome::WouldFetch(_)))
    }
    /// Jobs that failed.
    pub fn failed(&self) -> usize {
        self.count(|o| matches!(o, Outcome::Failed(_)))
    }
}

mod run;

impl Batch {
    /// Runs the batch, telling `on_done` of each job as it ends (from any thread), and
    /// returns what became of every job. An error is the batch's own, before any job runs
    /// (jobs that write one file, another's input or standard output; a state file that is a
    /// FIFO or a device) or after (its state file could not be written); the jobs' errors are
    /// in the report.
    pub fn run(self, on_done: &(dyn Fn(&Done) + Sync)) -> Result<BatchReport> {
        run::run(self, on_done)
    }
}

/// Writes the state file (through the output module: atomically).
fn save(path: &std::path::Path, state: &State) -> Result<()> {
    let files = Files::new(vec![(path.to_path_buf(), state.to_bytes()?)]);
    output::deliver(&files, &Destination::Path(path.to_path_buf()), &[])
}

/// The session that records a job's reads and shares its group's decodes.
fn share(job: &mut dyn Job, session: Session) {
    job.limits_mut().session = session;
}
