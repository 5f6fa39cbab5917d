fn main() -> std::process::ExitCode {
    // Die quietly on a closed pipe (`gweave stats big.gcode | head`) as Unix tools do, instead of
    // Rust's default of ignoring SIGPIPE and panicking in the next `println!`.
    #[cfg(unix)]
    // SAFETY: `signal` with SIG_DFL installs no handler code; done before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    gweave_cli::run(std::env::args_os())
}
