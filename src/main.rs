//! The `cubeforge` command: parses arguments, calls the library, reports.

mod cli;

fn main() {
    // Messages name parameters by their flags (--size), not the library's field names.
    cubeforge::error::name_parameters_as_flags();
    // A bug or an exhausted machine still ends with one line, not a backtrace.
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown failure".into());
        let at = info
            .location()
            .map(|l| format!(" ({}:{})", l.file(), l.line()))
            .unwrap_or_default();
        let msg = msg.replace(['\n', '\r'], " ");
        cli::tell(format_args!("cubeforge: error: internal error: {msg}{at}"));
    }));
    std::process::exit(cli::run());
}
