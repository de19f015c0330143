//! The `contourcheck` command: arguments in, exit status out (0 ok, 1 prediction over
//! tolerance, 2 error). Everything else lives in the library.

fn main() -> std::process::ExitCode {
    contourcheck::cli::main()
}
