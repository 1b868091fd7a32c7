//! A progress bar on stderr for runs expected to take more than a second, on a terminal only: nothing is drawn
//! when stderr is piped or redirected, and a short run draws nothing either. The runtime reports the fraction
//! done through [`invsim_runtime::Progress`]; the bar appears once the run has taken a quarter of a second and
//! its estimated total time (elapsed / fraction done) exceeds a second.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use invsim_runtime::Progress;

/// Ticks of the bar for the whole run.
const TICKS: u64 = 1000;

/// The bar while a run is under way; [`Bar::finish`] clears it.
pub struct Bar(Option<ProgressBar>);

/// True when a run `elapsed` into it, `fraction` done, is expected to take more than a second in all.
pub fn expected_long(elapsed: Duration, fraction: f64) -> bool {
    let e = elapsed.as_secs_f64();
    e >= 0.25 && fraction < 1.0 && (fraction <= 0.0 || e / fraction > 1.0)
}

/// A progress callback for the runtime and the bar it drives (`label`: what runs); no bar off a terminal.
pub fn start(label: &str) -> (Progress, Bar) {
    if !std::io::stderr().is_terminal() {
        return (Progress::none(), Bar(None));
    }
    let bar = ProgressBar::with_draw_target(Some(TICKS), ProgressDrawTarget::hidden());
    if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:40}] {percent:>3}% (eta {eta})") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_string());
    let shown = Arc::new(AtomicBool::new(false));
    let started = Instant::now();
    let handle = bar.clone();
    let progress = Progress::new(move |fraction| {
        if !shown.load(Ordering::Relaxed) {
            if !expected_long(started.elapsed(), fraction) {
                return;
            }
            shown.store(true, Ordering::Relaxed);
            handle.set_draw_target(ProgressDrawTarget::stderr());
        }
        handle.set_position((fraction.clamp(0.0, 1.0) * TICKS as f64) as u64);
    });
    (progress, Bar(Some(bar)))
}

impl Bar {
    /// Remove the bar from the terminal.
    pub fn finish(self) {
        if let Some(bar) = self.0 {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_long_runs_show_a_bar() {
        let ms = Duration::from_millis;
        assert!(!expected_long(ms(100), 0.01), "too early to tell");
        assert!(!expected_long(ms(300), 0.5), "0.6 s in all");
        assert!(expected_long(ms(300), 0.2), "1.5 s in all");
        assert!(!expected_long(ms(2000), 1.0), "done");
    }
}
