//! Running a batch: which jobs run and why, inputs side by side within the budget, the jobs
//! of one input in turn over its one decode, and the state file brought up to date.

use super::cache::Cache;
use super::state::{self, Hashes, Record, State, Why};
use super::{conflicts, save, share, Batch, BatchJob, BatchReport, Done, Outcome};
use crate::error::{Error, Result};
use crate::io::Session;
use crate::output::depfile;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
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
    refuse_special_state(&batch)?;
    let mut report = BatchReport::default();
    let (mut state, warning) = match &batch.state {
        Some(p) => State::load(p),
        None => (State::default(), None),
    };
    report
        .warnings
        .extend(warning.map(crate::jobs::Warning::new));
    let mine = shard_groups(&batch, &mut report);
    let hashes = Hashes::default();
    let whys = reasons(&batch, &mine, &state, &hashes);
    // The state the batch keeps: jobs gone from the batch dropped, each finished job's record
    // put in as it ends, and the file rewritten as it goes (see SAVE_EVERY) and at the end.
    let ids: Vec<String> = batch.jobs.iter().map(|j| j.id.clone()).collect();
    let known: HashSet<&String> = ids.iter().collect();
    state.jobs.retain(|id, _| known.contains(id));
    let run = Running {
        slots: ids.iter().map(|_| Mutex::new(None)).collect(),
        outputs: batch.jobs.iter().map(|j| j.output.clone()).collect(),
        ids,
        whys,
        on_done,
        hashes,
        depfiles: batch.depfiles,
        keep: batch.state.clone().filter(|_| !batch.dry_run),
        live: Mutex::new(Live {
            state,
            dirty: false,
            running: true,
        }),
        wake: Condvar::new(),
        jobs: Vec::new(),
        missed: batch.jobs.iter().map(|_| AtomicBool::new(false)).collect(),
        cache: batch.cache,
        stop: batch.stop,
    };
    let todo: Vec<Group> = mine
        .iter()
        .map(|g| run.settle(g, batch.dry_run))
        .filter(|g| !g.is_empty())
        .collect();
    let run = Running {
        jobs: batch
            .jobs
            .into_iter()
            .map(|j| Mutex::new(Some(j)))
            .collect(),
        ..run
    };
    run.all(&todo, batch.max_memory);
    if let Some(c) = &run.cache {
        (report.blobs_uploaded, report.blobs_present) = c.blob_counts();
        let ws = c.take_warnings();
        report
            .warnings
            .extend(ws.into_iter().map(crate::jobs::Warning::new));
    }
    report.jobs = run
        .slots
        .into_iter()
        .filter_map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()))
        .collect();
    if let Some(path) = &run.keep {
        let live = run.live.into_inner().unwrap_or_else(|e| e.into_inner());
        save(path, &live.state)?;
    }
    Ok(report)
}

/// A state file that is a FIFO or a device: refused before any job (a FIFO would block the
/// read, and a rename would replace it).
fn refuse_special_state(batch: &Batch) -> Result<()> {
    let Some(p) = &batch.state else {
        return Ok(());
    };
    match crate::io::atomic::special_kind(p) {
        Some(kind) => Err(Error::file(
            p,
            format!(
                "is {kind}, not a regular file: the batch's state file must be one (or absent)"
            ),
        )),
        None => Ok(()),
    }
}

/// This shard's groups (all of them without a shard); the jobs of the others are counted in
/// the report, and each shard's estimated cost.
fn shard_groups(batch: &Batch, report: &mut BatchReport) -> Vec<Group> {
    let all = groups(&batch.jobs);
    let Some(shard) = batch.shard else {
        return all;
    };
    // A group's cost: its jobs' planned bytes, from the headers (a job that cannot plan costs
    // nothing here; it fails when it runs).
    let costs: Vec<u64> = all
        .iter()
        .map(|g| {
            g.iter()
                .map(|&i| batch.jobs[i].job.memory_estimate().unwrap_or(0))
                .fold(0u64, u64::saturating_add)
        })
        .collect();
    let owner = super::shard::assign(&costs, shard.count, shard.by);
    report.shard_costs = vec![(0, 0); shard.count];
    for ((g, &cost), &s) in all.iter().zip(&costs).zip(&owner) {
        let entry = &mut report.shard_costs[s];
        entry.0 = entry.0.saturating_add(cost);
        entry.1 += g.len();
    }
    all.into_iter()
        .zip(owner)
        .filter_map(|(g, s)| {
            if s == shard.index {
                Some(g)
            } else {
                report.other_shards += g.len();
                None
            }
        })
        .collect()
}

/// For each job of this shard: why it runs (`Some(None)`: up to date; `None`: another
/// shard's).
fn reasons(
    batch: &Batch,
    mine: &[Group],
    state: &State,
    hashes: &Hashes,
) -> Vec<Option<Option<Why>>> {
    let mut whys = vec![None; batch.jobs.len()];
    for &i in mine.iter().flatten() {
        let id = &batch.jobs[i].id;
        whys[i] = Some(if batch.force {
            Some(Why::Forced)
        } else if batch.state.is_none() {
            Some(Why::NeverRan)
        } else {
            state::why(id, state.jobs.get(id), hashes)
        });
    }
    whys
}

/// What the workers share while the batch runs: each job's id, output, reason, end and the
/// job itself (taken by the worker that runs it), and the state being kept.
struct Running<'a> {
    ids: Vec<String>,
    outputs: Vec<PathBuf>,
    whys: Vec<Option<Option<Why>>>,
    slots: Vec<Mutex<Option<Done>>>,
    on_done: &'a (dyn Fn(&Done) + Sync),
    hashes: Hashes,
    depfiles: bool,
    /// The state file, unless there is none or this is a dry run.
    keep: Option<PathBuf>,
    live: Mutex<Live>,
    /// Wakes the saver when the workers are done.
    wake: Condvar,
    jobs: Vec<Mutex<Option<BatchJob>>>,
    /// The cache was asked for each job and did not serve it.
    missed: Vec<AtomicBool>,
    cache: Option<Cache>,
    stop: Option<std::sync::Arc<AtomicBool>>,
}

impl Running<'_> {
    /// Job `i` ended: `on_done` hears it, and its slot keeps it for the report.
    fn finish(&self, i: usize, outcome: Outcome, seconds: f64) {
        let done = Done {
            id: self.ids[i].clone(),
            outcome,
            seconds,
            cache_miss: self.missed[i].load(Ordering::Relaxed),
        };
        (self.on_done)(&done);
        *self.slots[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(done);
    }

    /// Ends a group's up-to-date jobs (and a dry run's every job) at once; returns those to
    /// run.
    fn settle(&self, group: &[usize], dry_run: bool) -> Group {
        let up_to_date = |i: usize| {
            // An up-to-date job's depfile, when asked for and missing: from its record.
            let d = depfile::beside(&self.outputs[i]);
            let live = self.live.lock().unwrap_or_else(|e| e.into_inner());
            match live.state.jobs.get(&self.ids[i]) {
                Some(r) if self.depfiles && !dry_run && !d.exists() => {
                    let reads: Vec<PathBuf> = r.reads.iter().map(|(p, _)| p.clone()).collect();
                    depfile::write(&d, &self.outputs[i], &reads, &r.outputs)
                }
                _ => Ok(()),
            }
        };
        group
            .iter()
            .copied()
            .filter(|&i| match self.whys[i].clone().flatten() {
                None => {
                    match up_to_date(i) {
                        Ok(()) => self.finish(i, Outcome::UpToDate, 0.0),
                        Err(e) => self.finish(i, Outcome::Failed(e), 0.0),
                    }
                    false
                }
                Some(w) if dry_run => {
                    let cache = self.cache.as_ref().filter(|_| w != Why::Forced);
                    let hit = cache.and_then(|c| c.lookup(&self.ids[i], &self.outputs[i]));
                    self.missed[i].store(cache.is_some() && hit.is_none(), Ordering::Relaxed);
                    let outcome = match hit {
                        Some(_) => Outcome::WouldFetch(w),
                        None => Outcome::WouldRun(w),
                    };
                    self.finish(i, outcome, 0.0);
                    false
                }
                Some(_) => true,
            })
            .collect()
    }

    /// Runs every group of `todo`: worker threads (one per thread of the pool) take groups
    /// in order while their memory plans fit `budget`, and a saver keeps the state file.
    fn all(&self, todo: &[Group], budget: u64) {
        let queue = Queue {
            bytes: self.peaks(todo),
            at: Mutex::new((0, 0)),
            freed: Condvar::new(),
            budget,
        };
        let workers = rayon::current_num_threads().clamp(1, todo.len().max(1));
        std::thread::scope(|scope| {
            scope.spawn(|| self.save_while_running());
            let handles: Vec<_> = (0..workers)
                .map(|_| {
                    scope.spawn(|| {
                        while let Some((g, held)) = queue.take() {
                            self.group(&todo[g]);
                            queue.give_back(held);
                        }
                    })
                })
                .collect();
            // Join the workers, stop the saver, then pass on a worker's panic, if any.
            let ended: Vec<_> = handles.into_iter().map(|h| h.join()).collect();
            self.live.lock().unwrap_or_else(|e| e.into_inner()).running = false;
            self.wake.notify_all();
            if let Some(e) = ended.into_iter().find_map(|r| r.err()) {
                std::panic::resume_unwind(e);
            }
        });
    }

    /// Each group's peak: its largest job, and the decode the group keeps beside it.
    fn peaks(&self, todo: &[Group]) -> Vec<u64> {
        todo.iter()
            .map(|g| {
                let most = g
                    .iter()
                    .filter_map(|&i| {
                        let j = self.jobs[i].lock().unwrap_or_else(|e| e.into_inner());
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
            .collect()
    }

    /// The jobs of one input, one after another in one session (shared when there are
    /// several, so the input is decoded once).
    fn group(&self, group: &[usize]) {
        let guard = if group.len() > 1 {
            Session::open_shared()
        } else {
            Session::open()
        };
        for &i in group {
            let Some(mut bj) = self.jobs[i]
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .take()
            else {
                continue;
            };
            if self
                .stop
                .as_ref()
                .is_some_and(|s| s.load(Ordering::Relaxed))
            {
                let e = Error::usage("not run: the batch was stopped");
                self.finish(i, Outcome::Failed(e), 0.0);
                continue;
            }
            share(bj.job.as_mut(), guard.session());
            let start = Instant::now();
            if self.fetched(i) {
                continue;
            }
            let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| bj.job.run(&())))
                .unwrap_or_else(|_| Err(Error::usage("the job stopped on an internal error")));
            let reads = guard.session().take_reads();
            let ran = ran.and_then(|report| {
                for p in &report.written {
                    self.hashes.forget(p);
                }
                if self.depfiles {
                    let d = depfile::beside(&self.outputs[i]);
                    depfile::write(&d, &self.outputs[i], &reads, &report.written)?;
                }
                Ok(report)
            });
            let (outcome, record) = match ran {
                Ok(report) => {
                    if let Some(c) = &self.cache {
                        c.upload(&self.ids[i], &self.outputs[i], &reads, &report.written);
                    }
                    let r =
                        state::record(&self.ids[i], reads, report.written.clone(), &self.hashes);
                    let why = self.whys[i].clone().flatten().unwrap_or(Why::NeverRan);
                    (Outcome::Ran(why, report), r)
                }
                Err(e) => (Outcome::Failed(e), None),
            };
            self.keep_record(&self.ids[i], record);
            self.finish(i, outcome, start.elapsed().as_secs_f64());
        }
    }

    /// Job `i`'s outputs from the cache, written and recorded as if it ran (with its
    /// depfile); false when there is no cache, it missed, or `--force` runs every job.
    fn fetched(&self, i: usize) -> bool {
        let why = self.whys[i].clone().flatten().unwrap_or(Why::NeverRan);
        let Some(cache) = self.cache.as_ref().filter(|_| why != Why::Forced) else {
            return false;
        };
        let start = Instant::now();
        let (id, output) = (&self.ids[i], &self.outputs[i]);
        let Some(hit) = cache.fetch(id, output) else {
            self.missed[i].store(true, Ordering::Relaxed);
            return false;
        };
        let reads = hit.reads.clone();
        let written = hit.deliver(output).and_then(|written| {
            for p in &written {
                self.hashes.forget(p);
            }
            if self.depfiles {
                depfile::write(&depfile::beside(output), output, &reads, &written)?;
            }
            Ok(written)
        });
        match written {
            Ok(w) => {
                let r = state::record(id, reads, w.clone(), &self.hashes);
                self.keep_record(id, r);
                let outcome = Outcome::Fetched(why, w);
                self.finish(i, outcome, start.elapsed().as_secs_f64());
                true
            }
            // Written as a run would have been, it would have failed the same way: it runs.
            Err(e) => {
                cache.warn(format!(
                    "`{id}`: the cache's outputs not written ({e}); it runs here"
                ));
                self.missed[i].store(true, Ordering::Relaxed);
                false
            }
        }
    }

    /// A finished job's record (None: it failed, and its old record goes) into the state kept.
    fn keep_record(&self, id: &str, record: Option<Record>) {
        if self.keep.is_none() {
            return;
        }
        let mut live = self.live.lock().unwrap_or_else(|e| e.into_inner());
        match record {
            Some(r) => live.state.jobs.insert(id.to_string(), r),
            None => live.state.jobs.remove(id),
        };
        live.dirty = true;
    }

    /// Writes the state file when a job has ended since it last did, every SAVE_EVERY, until
    /// the workers are done. A failure here is reported by the save at the end.
    fn save_while_running(&self) {
        let Some(path) = &self.keep else {
            return;
        };
        let mut l = self.live.lock().unwrap_or_else(|e| e.into_inner());
        while l.running {
            l = self
                .wake
                .wait_timeout(l, SAVE_EVERY)
                .unwrap_or_else(|e| e.into_inner())
                .0;
            if l.running && l.dirty {
                let _ = save(path, &l.state);
                l.dirty = false;
            }
        }
    }
}

/// The groups to run in order, each with its memory peak, and the bytes the running ones
/// hold within the budget.
struct Queue {
    bytes: Vec<u64>,
    /// The next group, and the bytes held.
    at: Mutex<(usize, u64)>,
    freed: Condvar,
    budget: u64,
}

impl Queue {
    /// The next group and its bytes, once they fit beside those held (a group alone always
    /// does); None when every group is taken.
    fn take(&self) -> Option<(usize, u64)> {
        let mut q = self.at.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if q.0 >= self.bytes.len() {
                return None;
            }
            let b = self.bytes[q.0];
            if q.1 == 0 || q.1.saturating_add(b) <= self.budget {
                q.0 += 1;
                q.1 = q.1.saturating_add(b);
                return Some((q.0 - 1, b));
            }
            q = self.freed.wait(q).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// A group ended: its bytes are free for the next.
    fn give_back(&self, held: u64) {
        let mut q = self.at.lock().unwrap_or_else(|e| e.into_inner());
        q.1 = q.1.saturating_sub(held);
        self.freed.notify_all();
    }
}

/// The state while jobs run: whether it changed since the file was last written, and whether
/// any worker still runs.
struct Live {
    state: State,
    dirty: bool,
    running: bool,
}
