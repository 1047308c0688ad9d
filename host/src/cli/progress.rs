//! A progress bar on stderr for long work; invisible when stderr is not a terminal.

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};

/// A progress bar over a known number of items.
pub struct Progress(ProgressBar);

impl Progress {
    /// A bar for `total` items, labelled `what`.
    pub fn new(total: u64, what: &str) -> Self {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {human_pos}/{human_len} eta {eta}")
                .expect("static template")
                .progress_chars("=> "),
        );
        bar.set_message(what.to_string());
        Progress(bar)
    }

    /// A bar for `total` items, labelled `what`, drawn with the other bars of `group` (work running at once).
    pub fn in_group(group: &MultiProgress, total: u64, what: &str) -> Self {
        Progress(group.add(Progress::new(total, what).0))
    }

    /// Items done so far.
    pub fn set(&self, done: u64) {
        self.0.set_position(done);
    }

    /// Change the number of items.
    pub fn set_length(&self, total: u64) {
        self.0.set_length(total);
    }

    /// Remove the bar.
    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}
