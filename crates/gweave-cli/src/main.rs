fn main() -> std::process::ExitCode {
    gweave_cli::run(std::env::args_os())
}
