//! Signals: the temporaries of a stopped command taken back, and one line on what it left.

#[cfg(unix)]
use super::tell;

/// On SIGINT, SIGTERM or SIGHUP: take back the temporaries written so far, then end as the
/// signal would have (the shell sees the usual status).
pub(super) fn remove_temporaries_on_signals() {
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let kept = cubeforge::internals::io::remove_temporaries();
                let name = match sig {
                    SIGINT => "interrupted (SIGINT)",
                    SIGTERM => "stopped (SIGTERM)",
                    _ => "stopped (SIGHUP)",
                };
                // One line: what the stop left, so a user never guesses at half a result.
                tell(format_args!(
                    "cubeforge: {name}: {}",
                    match kept {
                        0 => "nothing written".to_string(),
                        n => format!(
                            "the {n} output{} written before it kept whole, nothing half-written left",
                            if n == 1 { "" } else { "s" }
                        ),
                    }
                ));
                let _ = signal_hook::low_level::emulate_default_handler(sig);
                std::process::exit(128 + sig);
            }
        });
    }
}
