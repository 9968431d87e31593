//! Jobs run from Python: built from a command line by the CLI's own parser, run on a thread of
//! their own without the GIL, while the calling thread calls the progress callback and checks
//! for Ctrl-C; a stop unwinds the job at its next progress step (nothing written).

use crate::cli;
use cubeforge::Progress;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// The payload a stopped job unwinds with.
pub(crate) struct Cancelled;

/// Silences the unwinding of a stopped job; any other panic goes to the hook before.
pub fn quiet_cancel_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let before = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if info.payload().downcast_ref::<Cancelled>().is_none() {
                before(info);
            }
        }));
    });
}

/// What the job thread reports, read by the Python thread.
#[derive(Default)]
pub(crate) struct Shared {
    pub(crate) total: AtomicU64,
    pub(crate) done: AtomicU64,
    pub(crate) label: Mutex<String>,
    /// Set when Python asked the work to stop (a batch checks it between jobs).
    pub(crate) stop: std::sync::Arc<AtomicBool>,
}

impl Progress for Shared {
    fn start(&self, total: u64, label: &str) {
        self.check();
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        if let Ok(mut l) = self.label.lock() {
            *l = label.to_owned();
        }
    }
    fn advance(&self, units: u64) {
        self.check();
        self.done.fetch_add(units, Ordering::Relaxed);
    }
    fn finish(&self) {
        self.done
            .store(self.total.load(Ordering::Relaxed), Ordering::Relaxed);
    }
    fn stage(&self, _name: &str) {
        self.check();
    }
}

impl Shared {
    /// Unwinds the job when Python asked it to stop.
    fn check(&self) {
        if self.stop.load(Ordering::Relaxed) {
            std::panic::panic_any(Cancelled);
        }
    }
}

/// How a job's thread ended.
enum Ended<T> {
    Done(T),
    Stopped,
    Panicked(String),
}

/// Runs `work` on a thread of its own without the GIL while this thread calls `progress`
/// about ten times a second and checks for Ctrl-C; either raising sets `shared.stop` (the
/// work stops at its next progress step) and is what this returns once the work has ended.
pub(crate) fn polled<T: Send>(
    py: Python<'_>,
    shared: &Shared,
    progress: &Option<Py<PyAny>>,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let mut interrupt: Option<PyErr> = None;
    let ended = std::thread::scope(|s| {
        let (tx, rx) = std::sync::mpsc::channel();
        // Receivers are not Sync; the wait below hands it to the GIL-free closure by a lock.
        let rx = Mutex::new(rx);
        s.spawn(move || {
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
            let _ = tx.send(match r {
                Ok(r) => Ended::Done(r),
                Err(p) if p.downcast_ref::<Cancelled>().is_some() => Ended::Stopped,
                Err(p) => Ended::Panicked(panic_text(p)),
            });
        });
        loop {
            let got = py.detach(|| {
                let rx = rx.lock().unwrap_or_else(|e| e.into_inner());
                rx.recv_timeout(Duration::from_millis(100))
            });
            match got {
                Ok(ended) => return ended,
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    return Ended::Panicked("the job's thread ended without a word".into())
                }
                Err(_) if interrupt.is_some() => continue,
                Err(_) => {}
            }
            let called = py.check_signals().and_then(|()| match progress {
                Some(cb) => call_progress(py, cb, shared).map(|_| ()),
                None => Ok(()),
            });
            if let Err(e) = called {
                interrupt = Some(e);
                shared.stop.store(true, Ordering::Relaxed);
            }
        }
    });
    if let Some(e) = interrupt {
        return Err(e);
    }
    match ended {
        Ended::Done(r) => {
            if let Some(cb) = progress {
                call_progress(py, cb, shared)?;
            }
            Ok(r)
        }
        Ended::Stopped => Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("stopped")),
        Ended::Panicked(msg) => Err(crate::raise_as(
            py,
            "Error",
            format!("internal error: {msg}"),
        )),
    }
}

/// Runs the job the command line `argv` (the words after `cubeforge`) describes; returns its
/// report as a dict. `progress(done, total, label)` is called about ten times a second.
#[pyfunction]
#[pyo3(signature = (argv, progress=None))]
pub fn run_job(
    py: Python<'_>,
    argv: Vec<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyDict>> {
    let job = cli::job_of_words(&argv).map_err(|e| crate::error(py, &e))?;
    let shared = Shared::default();
    let report = polled(py, &shared, &progress, || job.run(&shared))?;
    let report = report.map_err(|e| crate::error(py, &e))?;
    report_dict(py, &report)
}

fn call_progress(py: Python<'_>, cb: &Py<PyAny>, s: &Shared) -> PyResult<Py<PyAny>> {
    let label = s.label.lock().map(|l| l.clone()).unwrap_or_default();
    let (done, total) = (
        s.done.load(Ordering::Relaxed),
        s.total.load(Ordering::Relaxed),
    );
    cb.call1(py, (done.min(total), total, label))
}

fn panic_text(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown failure".into())
}

/// The report as Python reads it: written (paths), warnings and summary (lines), quality.
pub(crate) fn report_dict(py: Python<'_>, r: &cubeforge::Report) -> PyResult<Py<PyDict>> {
    let d = PyDict::new(py);
    let written: Vec<String> = r.written.iter().map(|p| p.display().to_string()).collect();
    d.set_item("written", PyList::new(py, written)?)?;
    let warnings: Vec<String> = r.warnings.iter().map(|w| w.with_flags()).collect();
    d.set_item("warnings", PyList::new(py, warnings)?)?;
    let summary: Vec<String> = r.summary.iter().map(|w| w.with_flags()).collect();
    d.set_item("summary", PyList::new(py, summary)?)?;
    match &r.quality {
        Some(q) => {
            let qd = PyDict::new(py);
            qd.set_item("format", q.format.name())?;
            qd.set_item("psnr_db", q.psnr_db)?;
            d.set_item("quality", qd)?;
        }
        None => d.set_item("quality", py.None())?,
    }
    Ok(d.unbind())
}

/// `info`'s report of one file as JSON (what `cubeforge info FILE --json` prints), from the
/// words after `cubeforge`.
#[pyfunction]
pub fn info(py: Python<'_>, argv: Vec<String>) -> PyResult<String> {
    use clap::Parser;
    let words = std::iter::once("cubeforge".to_owned()).chain(argv);
    let parsed = cli::Cli::try_parse_from(words)
        .map_err(|e| crate::bad_arg(py, crate::cli::one_line(&e)))?;
    let cli::Command::Info(a) = parsed.command else {
        return Err(crate::bad_arg(py, "not an info command line"));
    };
    py.detach(|| {
        let opts = cubeforge::ReadOptions {
            limits: a.limits.limits(),
            linear: a.linear,
            as_stored: true,
            exr_part: a.part.index(&a.files)?,
            exr_level: 0,
            hdr_encoding: a.decode.decode,
        };
        let f = &a.files[0];
        let shown = cubeforge::internals::ibl::specular_of(f).map(|(file, _)| file);
        let r = cubeforge::internals::info::describe(shown.as_ref().unwrap_or(f), a.from, &opts)?;
        Ok(serde_json::to_string(&r).unwrap_or_default())
    })
    .map_err(|e: cubeforge::Error| crate::error(py, &e))
}
