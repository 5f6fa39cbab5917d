//! A progress bar on stderr, only when stderr is a terminal and the input is large.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

/// Inputs smaller than this finish too fast for a bar to help.
const MIN_BYTES: u64 = 32 << 20;

pub struct Bar(Option<ProgressBar>);

impl Bar {
    pub fn new(quiet: bool) -> Self {
        if quiet || !std::io::stderr().is_terminal() {
            return Bar(None);
        }
        Bar(Some(ProgressBar::hidden()))
    }
}

impl gweave::Progress for Bar {
    fn set_len(&mut self, bytes: u64) {
        if let Some(bar) = &self.0 {
            if bytes < MIN_BYTES {
                self.0 = None;
                return;
            }
            bar.set_length(bytes);
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {bytes}/{total_bytes} {bytes_per_sec} {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
    }

    fn advance(&mut self, done_bytes: u64) {
        if let Some(bar) = &self.0 {
            bar.set_position(done_bytes);
        }
    }

    /// The work after reading (a preview's drawing) gets a bar of its own, named, so that the
    /// bar never sits finished while the command still works.
    fn stage(&mut self, name: &'static str, len: u64) {
        if let Some(bar) = &self.0 {
            bar.set_style(
                ProgressStyle::with_template("{bar:40} {msg} {percent:>3}% {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message(name);
            bar.set_length(len);
            bar.reset();
        }
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}
