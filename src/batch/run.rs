//! Running a batch: which jobs run and why, inputs side by side within the budget, the jobs
//! of one input in turn over its one decode, and the state file brought up to date.

use super::state::{self, Hashes, Record, State, Why};
use super::{conflicts, depfile, save, share, Batch, BatchJob, BatchReport, Done, Outcome};
use crate::error::{Error, Result};
use crate::io::Session;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// The state file is written again, while jobs run, at most this often: an interrupted batch
/// (a signal, a killed CI step) keeps what it finished up to this long before, and a batch of
/// many small jobs does not spend its time rewriting the file.
const SAVE_EVERY: Duration = Duration::from_secs(1);

/// The jobs of one input, by index.
type Group = Vec<usize>;

/// The jobs' groups in order of first appearance: one per input, one per job without one.
/// Each input's group is found by a hash lookup (a search of the groups so far made 10,000
/// inputs quadratic).
fn groups(jobs: &[BatchJob]) -> Vec<Group> {
    let mut out: Vec<Group> = Vec::new();
    let mut of: HashMap<&PathBuf, usize> = HashMap::new();
    for (i, j) in jobs.iter().enumerate() {
        match j
            .input
            .as_ref()
            .map(|inp| *of.entry(inp).or_insert(out.len()))
        {
            Some(g) if g < out.len() => out[g].push(i),
            _ => out.push(vec![i]),
        }
    }
    out
}

pub(super) fn run(batch: Batch, on_done: &(dyn Fn(&Done) + Sync)) -> Result<BatchReport> {
    conflicts::check(&batch.jobs, batch.depfiles, batch.state.as_deref())?;
    if let Some(p) = &batch.state {
        // A FIFO would block the read (and a rename would replace it): refused, before any job.
        if let Some(kind) = crate::io::atomic::special_kind(p) {
            return Err(Error::file(
                p,
                format!(
                    "is {kind}, not a regular file: the batch's state file must be one (or absent)"
                ),
            ));
        }
    }
    let mut report = BatchReport::default();
    let (mut state, warning) = match &batch.state {
        Some(p) => State::load(p),
        None => (State::default(), None),
    };
    report
        .warnings
        .extend(warning.map(crate::jobs::Warning::new));
    let mine: Vec<Group> = groups(&batch.jobs)
        .into_iter()
        .enumerate()
        .filter(|(g, jobs)| {
            let keep = batch.shard.is_none_or(|s| g % s.count == s.index);
            if !keep {
                report.other_shards += jobs.len();
            }
            keep
        })
        .map(|(_, jobs)| jobs)
        .collect();
    let hashes = Hashes::default();
    // For each job of this shard: why it runs (None: up to date).
    let mut whys: Vec<Option<Option<Why>>> = vec![None; batch.jobs.len()];
    for &i in mine.iter().flatten() {
        whys[i] = Some(if batch.force {
            Some(Why::Forced)
        } else if batch.state.is_none() {
            Some(Why::NeverRan)
        } else {
            state::why(
                &batch.jobs[i].id,
                state.jobs.get(&batch.jobs[i].id),
                &hashes,
            )
        });
    }
    let ids: Vec<String> = batch.jobs.iter().map(|j| j.id.clone()).collect();
    let outputs: Vec<PathBuf> = batch.jobs.iter().map(|j| j.output.clone()).collect();
    let slots: Vec<Mutex<Option<Done>>> = ids.iter().map(|_| Mutex::new(None)).collect();
    let finish = |i: usize, outcome: Outcome, seconds: f64| {
        let done = Done {
            id: ids[i].clone(),
            outcome,
            seconds,
        };
        on_done(&done);
        *slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(done);
    };
    // Up-to-date jobs (and a dry run's every job) end at once.
    let mut todo: Vec<Group> = Vec::new();
    for g in &mine {
        let run: Group = g
            .iter()
            .copied()
            .filter(|&i| match whys[i].clone().flatten() {
                None => {
                    // An up-to-date job's depfile, when asked for and missing: from its record.
                    let d = depfile::beside(&outputs[i]);
                    let written = match state.jobs.get(&ids[i]) {
                        Some(r) if batch.depfiles && !batch.dry_run && !d.exists() => {
                            let reads: Vec<PathBuf> =
                                r.reads.iter().map(|(p, _)| p.clone()).collect();
                            depfile::write(&d, &outputs[i], &reads, &r.outputs)
                        }
                        _ => Ok(()),
                    };
                    match written {
                        Ok(()) => finish(i, Outcome::UpToDate, 0.0),
                        Err(e) => finish(i, Outcome::Failed(e), 0.0),
                    }
                    false
                }
                Some(w) if batch.dry_run => {
                    finish(i, Outcome::WouldRun(w), 0.0);
                    false
                }
                Some(_) => true,
            })
            .collect();
        if !run.is_empty() {
            todo.push(run);
        }
    }
    // The state the batch keeps: jobs gone from the batch dropped, each finished job's record
    // put in as it ends, and the file rewritten as it goes (see SAVE_EVERY) and at the end.
    let keep = batch.state.clone().filter(|_| !batch.dry_run);
    let known: HashSet<&String> = ids.iter().collect();
    state.jobs.retain(|id, _| known.contains(id));
    let live = Mutex::new(Live {
        state,
        dirty: false,
        running: true,
    });
    let wake = Condvar::new();
    let keep_record = |id: &str, record: Option<Record>| {
        if keep.is_none() {
            return;
        }
        let mut live = live.lock().unwrap_or_else(|e| e.into_inner());
        match record {
            Some(r) => live.state.jobs.insert(id.to_string(), r),
            None => live.state.jobs.remove(id),
        };
        live.dirty = true;
    };
    // Writes the state file when a job has ended since it last did, every SAVE_EVERY, until
    // the workers are done. A failure here is reported by the save at the end.
    let saver = || {
        let Some(path) = &keep else {
            return;
        };
        let mut l = live.lock().unwrap_or_else(|e| e.into_inner());
        while l.running {
            l = wake
                .wait_timeout(l, SAVE_EVERY)
                .unwrap_or_else(|e| e.into_inner())
                .0;
            if l.running && l.dirty {
                let _ = save(path, &l.state);
                l.dirty = false;
            }
        }
    };
    let depfiles = batch.depfiles;
    let jobs: Vec<Mutex<Option<BatchJob>>> = batch
        .jobs
        .into_iter()
        .map(|j| Mutex::new(Some(j)))
        .collect();
    // Each group's peak: its largest job, and the decode the group keeps beside it.
    let bytes: Vec<u64> = todo
        .iter()
        .map(|g| {
            let most = g
                .iter()
                .filter_map(|&i| {
                    let j = jobs[i].lock().unwrap_or_else(|e| e.into_inner());
                    j.as_ref()?.job.memory_estimate().ok()
                })
                .max()
                .unwrap_or(0);
            if g.len() > 1 {
                most.saturating_mul(2)
            } else {
                most
            }
        })
        .collect();
    let queue = Mutex::new((0usize, 0u64));
    let freed = Condvar::new();
    let workers = rayon::current_num_threads().clamp(1, todo.len().max(1));
    std::thread::scope(|scope| {
        scope.spawn(saver);
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                scope.spawn(|| loop {
                    let (g, held) = {
                        let mut q = queue.lock().unwrap_or_else(|e| e.into_inner());
                        loop {
                            if q.0 >= todo.len() {
                                return;
                            }
                            let b = bytes[q.0];
                            if q.1 == 0 || q.1.saturating_add(b) <= batch.max_memory {
                                q.0 += 1;
                                q.1 = q.1.saturating_add(b);
                                break (q.0 - 1, b);
                            }
                            q = freed.wait(q).unwrap_or_else(|e| e.into_inner());
                        }
                    };
                    let guard = if todo[g].len() > 1 {
                        Session::open_shared()
                    } else {
                        Session::open()
                    };
                    for &i in &todo[g] {
                        let Some(mut bj) = jobs[i].lock().unwrap_or_else(|e| e.into_inner()).take()
                        else {
                            continue;
                        };
                        share(bj.job.as_mut(), guard.session());
                        let start = Instant::now();
                        let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                            bj.job.run(&())
                        }))
                        .unwrap_or_else(|_| {
                            Err(Error::usage("the job stopped on an internal error"))
                        });
                        let reads = guard.session().take_reads();
                        let ran = ran.and_then(|report| {
                            for p in &report.written {
                                hashes.forget(p);
                            }
                            if depfiles {
                                let d = depfile::beside(&outputs[i]);
                                depfile::write(&d, &outputs[i], &reads, &report.written)?;
                            }
                            Ok(report)
                        });
                        let (outcome, record) = match ran {
                            Ok(report) => {
                                let r =
                                    state::record(&ids[i], reads, report.written.clone(), &hashes);
                                let why = whys[i].clone().flatten().unwrap_or(Why::NeverRan);
                                (Outcome::Ran(why, report), r)
                            }
                            Err(e) => (Outcome::Failed(e), None),
                        };
                        keep_record(&ids[i], record);
                        finish(i, outcome, start.elapsed().as_secs_f64());
                    }
                    drop(guard);
                    let mut q = queue.lock().unwrap_or_else(|e| e.into_inner());
                    q.1 = q.1.saturating_sub(held);
                    freed.notify_all();
                })
            })
            .collect();
        // Join the workers, stop the saver, then pass on a worker's panic, if any.
        let ended: Vec<_> = handles.into_iter().map(|h| h.join()).collect();
        live.lock().unwrap_or_else(|e| e.into_inner()).running = false;
        wake.notify_all();
        if let Some(e) = ended.into_iter().find_map(|r| r.err()) {
            std::panic::resume_unwind(e);
        }
    });
    report.jobs = slots
        .into_iter()
        .filter_map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()))
        .collect();
    if let Some(path) = &keep {
        save(
            path,
            &live.into_inner().unwrap_or_else(|e| e.into_inner()).state,
        )?;
    }
    Ok(report)
}

/// The state while jobs run: whether it changed since the file was last written, and whether
/// any worker still runs.
struct Live {
    state: State,
    dirty: bool,
    running: bool,
}
