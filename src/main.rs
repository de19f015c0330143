//! The `contourcheck` command: arguments in, exit status out (0 ok, 1 prediction over
//! tolerance, 2 error). Everything else lives in the library.

fn main() -> std::process::ExitCode {
    restore_broken_pipe_default();
    contourcheck::cli::main()
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
