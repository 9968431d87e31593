//! How long work reports on itself: one trait that jobs, the specular and diffuse stages of
//! `ibl` and the command line's progress bar share. It sits at the bottom of the layers so
//! every module that works for long can take one.

/// What a long call tells its caller while it works. Every method has a default that does
/// nothing, so `&()` is a silent observer.
pub trait Progress: Sync {
    /// What the job is about to do, in one line, for a front end to show before a long wait.
    fn begin(&self, _what: &str) {}
    /// A stage ended (decode, resample, filter, encode, write), for timings.
    fn stage(&self, _name: &str) {}
    /// Work of `total` units starts, named `label` (a progress bar's length and prefix).
    fn start(&self, _total: u64, _label: &str) {}
    /// `units` more of the work started last are done.
    fn advance(&self, _units: u64) {}
    /// The work started last is over.
    fn finish(&self) {}
    /// A warning, as soon as it is known (it is in the report too).
    fn warning(&self, _w: &crate::error::Text) {}
    /// A detail of how the work is done (a chain's mapping, where a setting came from), for
    /// a verbose front end.
    fn note(&self, _text: &str) {}
}

impl Progress for () {}
