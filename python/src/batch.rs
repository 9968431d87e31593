//! `cubeforge.batch`: a manifest planned and run as the command does it (its own code, from
//! src/cli/batch), silently, without the GIL; what it did comes back as a dict, as the other
//! jobs' reports do, with each job's outcome and the counts the command's summary gives.

use crate::cli::{self, Prepared};
use crate::run::{polled, Shared};
use cubeforge::internals::batch::{Done, Outcome};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::Path;
use std::sync::atomic::Ordering;

/// What a batch did, before it becomes a dict (built on the batch's thread, where the
/// working folder is the manifest's and its relative paths mean what they say).
#[derive(Default)]
struct Told {
    jobs: Vec<JobLine>,
    counts: Vec<(&'static str, usize)>,
    written: Vec<String>,
    warnings: Vec<String>,
    summary: Vec<String>,
    failures: Vec<String>,
}

/// One job's end: its id, its outcome as the command names it, why it ran (or would), its
/// seconds and its error.
struct JobLine(String, &'static str, Option<String>, f64, Option<String>);

/// `path` from the manifest's folder (the working folder while the batch runs), absolute.
fn shown(here: &Path, path: &Path) -> String {
    here.join(path).display().to_string()
}

/// The batch's report in words: each job, the counts, the files, warnings and lines.
fn told(ran: &cli::Ran, mut warnings: Vec<String>) -> Told {
    let here = std::env::current_dir().unwrap_or_default();
    let r = &ran.report;
    let mut t = Told {
        counts: vec![
            ("ran", r.ran()),
            ("up_to_date", r.up_to_date()),
            ("failed", r.failed()),
            ("from_cache", r.fetched()),
            ("would_run", r.would_run()),
            ("would_fetch", r.would_fetch()),
            ("other_shards", r.other_shards),
        ],
        summary: ran.summary(),
        failures: ran.failures(),
        ..Told::default()
    };
    warnings.extend(r.warnings.iter().map(|w| w.with_flags()));
    for d in &r.jobs {
        let (what, why, error) = outcome(d);
        match &d.outcome {
            Outcome::Ran(_, report) => {
                let files = report.written.iter().map(|p| shown(&here, p));
                t.written.extend(files);
                let said = report.warnings.iter();
                warnings.extend(said.map(|w| format!("{}: {}", d.id, w.with_flags())));
            }
            Outcome::Fetched(_, files) => t.written.extend(files.iter().map(|p| shown(&here, p))),
            _ => {}
        }
        t.jobs
            .push(JobLine(d.id.clone(), what, why, d.seconds, error));
    }
    t.warnings = warnings;
    t
}

/// A job's outcome as the command names it, why it ran (or would), and its error.
fn outcome(d: &Done) -> (&'static str, Option<String>, Option<String>) {
    match &d.outcome {
        Outcome::Ran(why, _) => ("ran", Some(why.to_string()), None),
        Outcome::Fetched(why, _) => ("from cache", Some(why.to_string()), None),
        Outcome::UpToDate => ("up to date", None, None),
        Outcome::WouldRun(why) => ("would run", Some(why.to_string()), None),
        Outcome::WouldFetch(why) => ("would fetch", Some(why.to_string()), None),
        Outcome::Failed(e) => ("failed", None, Some(e.with_flags())),
    }
}

/// Plans and runs the batch the words after `cubeforge` describe, silently; `shared` counts
/// the jobs ended of the jobs planned, its label the last one's id. What it did, and the
/// batch's error when a job failed.
type Outcomes = (Told, cubeforge::Result<()>);

fn run_words(argv: &[String], shared: &Shared) -> cubeforge::Result<Outcomes> {
    let mut warnings = Vec::new();
    match cli::prepare_words(argv, &mut |w| warnings.push(w))? {
        Prepared::Emitted(path, line) => {
            let here = std::env::current_dir().unwrap_or_default();
            let t = Told {
                written: vec![shown(&here, &path)],
                warnings,
                summary: vec![line],
                ..Told::default()
            };
            Ok((t, Ok(())))
        }
        Prepared::Ready(mut ready) => {
            ready.stop_when(shared.stop.clone());
            shared.total.store(ready.jobs() as u64, Ordering::Relaxed);
            let tell = |d: &Done| {
                shared.done.fetch_add(1, Ordering::Relaxed);
                if let Ok(mut l) = shared.label.lock() {
                    l.clone_from(&d.id);
                }
            };
            let ran = ready.run(&tell)?;
            Ok((told(&ran, warnings), ran.failed()))
        }
    }
}

/// `cubeforge batch MANIFEST ...` from its words; returns what it did as a dict, or raises
/// when a job failed (the dict as the exception's `report`).
#[pyfunction]
#[pyo3(signature = (argv, progress=None))]
pub fn batch(
    py: Python<'_>,
    argv: Vec<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyDict>> {
    let shared = Shared::default();
    let got = polled(py, &shared, &progress, || run_words(&argv, &shared))?;
    let (told, failed) = got.map_err(|e| crate::error(py, &e))?;
    let report = dict(py, &told)?;
    match failed {
        Ok(()) => Ok(report),
        Err(err) => {
            // "N of M jobs failed" and the first failure's line; every one in the report.
            let mut text = err.with_flags();
            if let Some(first) = told.failures.first() {
                text = format!("{text}: {first}");
            }
            let e = crate::raise_as(py, "ArgumentError", text);
            e.value(py).setattr("report", report)?;
            Err(e)
        }
    }
}

fn dict(py: Python<'_>, t: &Told) -> PyResult<Py<PyDict>> {
    let d = PyDict::new(py);
    let jobs = PyList::empty(py);
    for JobLine(id, what, why, seconds, error) in &t.jobs {
        let j = PyDict::new(py);
        j.set_item("id", id)?;
        j.set_item("outcome", what)?;
        j.set_item("why", why)?;
        j.set_item("seconds", seconds)?;
        j.set_item("error", error)?;
        jobs.append(j)?;
    }
    d.set_item("jobs", jobs)?;
    for (key, n) in &t.counts {
        d.set_item(key, n)?;
    }
    d.set_item("written", &t.written)?;
    d.set_item("warnings", &t.warnings)?;
    d.set_item("summary", &t.summary)?;
    d.set_item("failures", &t.failures)?;
    Ok(d.unbind())
}
