//! Calls into third-party decoders, which may panic on corrupt data (an index out of range, a
//! capacity overflow): the panic is caught and becomes a message, not printed, and every
//! message is put on one line.

#![warn(missing_docs)]

thread_local! {
    /// Set while this thread is inside a caught call.
    static QUIET: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f`, its panic (if any) caught and returned as "corrupt data (...)". The panic hook
/// stays quiet only on a thread inside such a call (`f` must not hand work to rayon, so no
/// other job runs there meanwhile); every other panic goes to the hook that was there before.
/// Aborts on failed allocations cannot be caught: callers bound the sizes a decoder allocates
/// from before they call it.
pub(crate) fn caught<T>(f: impl FnOnce() -> T) -> std::result::Result<T, String> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.try_with(|q| q.get()).unwrap_or(false) {
                previous(info)
            }
        }));
    });
    let was = QUIET.with(|q| q.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET.with(|q| q.set(was));
    result.map_err(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown failure".into());
        format!("corrupt data ({})", one_line(&what))
    })
}

/// A third-party decoder's message on one line (some span several: "I/O errors\nNot enough
/// bytes"), its runs of whitespace made single spaces.
pub(crate) fn one_line(msg: &str) -> String {
    msg.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_a_one_line_message() {
        assert_eq!(caught(|| 5), Ok(5));
        let e = caught(|| -> u8 { panic!("index out of range\n  at 7") }).unwrap_err();
        assert_eq!(e, "corrupt data (index out of range at 7)");
        let v: Vec<u8> = Vec::new();
        let e = caught(|| v[3]).unwrap_err();
        assert!(e.starts_with("corrupt data (index out of bounds"), "{e}");
    }
}
