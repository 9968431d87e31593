//! The command line's view of a running job: stage timings with -v, a progress bar on a
//! terminal, warnings as they come, and the report's lines at the end.

use super::Stages;
use cubeforge::{Progress, Report, Warning};
use std::sync::Mutex;

/// Watches one job for the command line.
pub struct Observer {
    stages: Mutex<Stages>,
    bar: Mutex<Option<indicatif::ProgressBar>>,
}

impl Observer {
    pub fn new(verbose: bool) -> Self {
        Observer {
            stages: Mutex::new(Stages::new(verbose)),
            bar: Mutex::new(None),
        }
    }

    /// Prints what the job made: the quality note (-v), the summary lines, the total time.
    pub fn report(&self, report: &Report) -> cubeforge::Result<()> {
        let stages = self.stages.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(q) = report.quality {
            stages.quality(q.format, Some(q.psnr_db));
        }
        for line in &report.summary {
            super::report(line.with_flags())?;
        }
        stages.total();
        Ok(())
    }
}

impl Progress for Observer {
    fn begin(&self, what: &str) {
        use std::io::IsTerminal;
        // On a terminal, as the progress bars: logs and pipelines get the report alone.
        if !super::quiet() && std::io::stderr().is_terminal() {
            super::tell(cubeforge::internals::error::name_params(what, true));
        }
    }
    fn stage(&self, name: &str) {
        self.stages
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .done(name);
    }
    fn start(&self, total: u64, label: &str) {
        *self.bar.lock().unwrap_or_else(|e| e.into_inner()) =
            super::progress(total, label.to_owned());
    }
    fn advance(&self, units: u64) {
        if let Some(b) = &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            b.inc(units);
        }
    }
    fn finish(&self) {
        if let Some(b) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
    fn warning(&self, w: &Warning) {
        super::warn(w.with_flags());
    }
    fn note(&self, text: &str) {
        self.stages
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .note(cubeforge::internals::error::name_params(text, true));
    }
}
