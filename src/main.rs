//! The `contourcheck` command: arguments in, exit status out (0 ok, 1 prediction over
//! tolerance, 2 error). Everything else lives in the library.

fn main() -> std::process::ExitCode {
    restore_broken_pipe_default();
    quiet_mat_reader_panics();
    contourcheck::cli::main()
}

/// The MAT-file reader asserts on some damaged files; the trace reader catches that and
/// reports the file as damaged, so the assertion's own message would only add noise in
/// front of the real error. Every other panic is reported as usual.
fn quiet_mat_reader_panics() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let in_mat_reader = info
            .location()
            .is_some_and(|at| at.file().contains("/matrw-"));
        if !in_mat_reader {
            report(info);
        }
    }));
}

/// Piped into `head`, a command-line tool should stop quietly when the reader goes away, as
/// `cat` does; Rust's runtime ignores SIGPIPE, which would turn that into a failed print.
#[cfg(unix)]
fn restore_broken_pipe_default() {
    // SAFETY: setting a signal's disposition to its default at start-up, before any other
    // thread exists, is sound.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn restore_broken_pipe_default() {}
