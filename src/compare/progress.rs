//! Progress bars of the comparison commands (hidden without `progress`).

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `len` steps drawn with `template`.
pub(crate) fn bar(progress: bool, len: u64, template: &str) -> ProgressBar {
    if !progress {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(len);
    b.set_style(ProgressStyle::with_template(template).expect("valid template"));
    b
}

pub(crate) fn spinner(progress: bool) -> ProgressBar {
    if !progress {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new_spinner();
    b.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{elapsed_precise}]")
            .expect("valid template"),
    );
    b.enable_steady_tick(std::time::Duration::from_millis(200));
    b
}
