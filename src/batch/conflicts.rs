//! A batch's jobs checked against each other before anything runs, so that no job's result
//! depends on which thread ran first and none destroys another's data: ids are unique, no
//! output is standard output (it would land in the batch's own), no two jobs write one file
//! however it is spelled (`out/x`, `out/../out/x`, a symlinked folder, a hard link), no
//! folder output holds another job's file, no job writes what another reads, and the state
//! file is none of these. With depfiles, each `OUTPUT.d` is an output too. Paths are
//! compared as places ([`crate::io::atomic::Place`]) in hash maps: 10,000 jobs cost no pairs.

use super::BatchJob;
use crate::error::{Error, Result};
use crate::io::atomic::{Place, Places, Resolver};
use crate::output::depfile;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// A file or folder a job writes: its output, or its depfile.
#[derive(Clone)]
struct Write {
    job: usize,
    path: PathBuf,
}

/// Refuses, with one line naming the jobs, a batch whose jobs would step on each other (see
/// the module). `state`: the state file, which the batch writes.
pub(super) fn check(jobs: &[BatchJob], depfiles: bool, state: Option<&Path>) -> Result<()> {
    let mut ids = HashSet::with_capacity(jobs.len());
    for j in jobs {
        if !ids.insert(j.id.as_str()) {
            return Err(Error::usage(format!("two jobs are one: {}", j.id)));
        }
        if j.output == Path::new("-") {
            return Err(Error::usage(format!(
                "{}: a batch job cannot write to standard output (-): it would go into the \
                 batch's own output and run every time; name a file",
                j.id
            )));
        }
    }
    let mut resolver = Resolver::default();
    let mut writes: Places<Write> = Places::default();
    let mut placed: Vec<(Place, Write)> = Vec::with_capacity(jobs.len() * 2);
    for (i, j) in jobs.iter().enumerate() {
        let dep = depfiles.then(|| depfile::beside(&j.output));
        for path in std::iter::once(&j.output).chain(dep.as_ref()) {
            let place = resolver.place(path);
            let w = Write {
                job: i,
                path: path.clone(),
            };
            if let Some(first) = writes.insert(&place, w.clone()) {
                return Err(Error::usage(format!(
                    "two jobs write {}: {} and {}",
                    first.path.display(),
                    jobs[first.job].id,
                    j.id
                )));
            }
            placed.push((place, w));
        }
    }
    // A folder output is replaced whole: nothing of another job's may be inside it.
    for (place, w) in &placed {
        if let Some((_, dir)) = writes.above(place).filter(|(_, d)| d.job != w.job) {
            return Err(Error::usage(format!(
                "{} writes the folder {}, which is replaced whole, and {} writes {} inside it",
                jobs[dir.job].id,
                dir.path.display(),
                jobs[w.job].id,
                w.path.display()
            )));
        }
    }
    // No job writes what another reads: which ran first would decide what it read.
    let state = state.map(|s| (s, resolver.place(s)));
    for (i, j) in jobs.iter().enumerate() {
        let Some(input) = &j.input else { continue };
        let place = resolver.place(input);
        if let Some((s, sp)) = &state {
            if same(&place, sp) {
                return Err(Error::usage(format!(
                    "the batch's state file {} is the input of {}: name another input",
                    s.display(),
                    j.id
                )));
            }
        }
        let hit = writes
            .get(&place)
            .or_else(|| writes.above(&place).map(|(_, w)| w))
            .filter(|w| w.job != i);
        if let Some(w) = hit {
            return Err(Error::usage(format!(
                "{} writes {}, and {} reads {}: one job must not write another's input (the \
                 order they ran in would decide what it read)",
                jobs[w.job].id,
                w.path.display(),
                j.id,
                input.display()
            )));
        }
    }
    if let Some((s, sp)) = &state {
        let hit = writes.get(sp).or_else(|| writes.above(sp).map(|(_, w)| w));
        if let Some(w) = hit {
            return Err(Error::usage(format!(
                "the batch's state file {} is written by {} ({}): name another output",
                s.display(),
                jobs[w.job].id,
                w.path.display()
            )));
        }
    }
    Ok(())
}

/// Whether two places are one file.
fn same(a: &Place, b: &Place) -> bool {
    a.path == b.path || (a.node.is_some() && a.node == b.node)
}
