//! Progress of a long run on stderr, for a person at a terminal and for a log file alike.
//!
//! On a terminal a [`Progress`] is an `indicatif` bar. Anywhere else — a batch job's log
//! (Slurm, Kubernetes), `nohup`, CI — `indicatif` draws nothing, and a five-hour `simulate`
//! or a half-hour `train` would say nothing until it ends; there a [`Progress`] writes a
//! plain line instead: one where each stage starts and ends, and between them at most one
//! every [`log_interval`] (lines from a dataset resumed under `nohup`, and from a toy
//! training that stopped early):
//!
//! ```text
//! samples 1134/6000 (18.9 %), 0s elapsed, ETA unknown
//! samples 1191/6000 (19.9 %), 3m 09s elapsed, ETA 4h 25m  2 not converged (last: m2 p191)
//! fitting epoch 3/300 (1.0 %), 0s elapsed, ETA 1s  train 1.1139  dev 4.4037  best 3.8289 @2
//! fitting epoch 3/3 (100.0 %), 0s elapsed, ETA 0s  train 1.1139  best 3.8289 @2  stopped early: no better development loss in 1 epochs
//! ```
//!
//! The rate behind the ETA counts only the work of this run ([`Progress::start_at`]): a
//! resumed dataset or training starts at its own position without taking the work already
//! done for work done in no time.
//!
//! ```
//! use std::time::Duration;
//! use garmatnet_train::{Progress, SharedLog};
//!
//! let log = SharedLog::default();
//! let progress = Progress::to_log(log.clone(), Duration::ZERO, 10, "samples");
//! progress.start_at(10, 4); // four samples were already on disk
//! progress.inc(1);
//! progress.finish();
//! assert!(log.contents().contains("samples 5/10 (50.0 %)"));
//! ```

use std::io::{IsTerminal, Write};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// The environment variable that sets [`log_interval`] in seconds (`0`: a line at every
/// update).
pub const LOG_INTERVAL_VAR: &str = "GARMATNET_PROGRESS_SECS";

/// Default seconds between two progress lines written to a log.
pub const DEFAULT_LOG_INTERVAL_SECS: u64 = 60;

/// How often a [`Progress`] writing to a log (stderr not a terminal) writes a line:
/// [`LOG_INTERVAL_VAR`] seconds when it holds a whole number, else
/// [`DEFAULT_LOG_INTERVAL_SECS`].
#[must_use]
pub fn log_interval() -> Duration {
    let secs = std::env::var(LOG_INTERVAL_VAR)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .unwrap_or(DEFAULT_LOG_INTERVAL_SECS);
    Duration::from_secs(secs)
}

/// An in-memory log a [`Progress`] can write to (for tests, or to show the lines elsewhere).
#[derive(Debug, Clone, Default)]
pub struct SharedLog(Arc<Mutex<Vec<u8>>>);

impl SharedLog {
    /// Everything written so far, as text.
    #[must_use]
    pub fn contents(&self) -> String {
        String::from_utf8_lossy(&self.0.lock().unwrap_or_else(PoisonError::into_inner)).into_owned()
    }
}

impl Write for SharedLog {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The progress of a run counted in units (samples, epochs): a bar on a terminal, periodic
/// lines in a log, or nothing. Every method takes `&self`, so workers on several threads
/// may report to one `Progress`.
pub struct Progress {
    mode: Mode,
}

enum Mode {
    Hidden,
    Bar(ProgressBar),
    Log(Mutex<LogState>),
}

struct LogState {
    sink: Box<dyn Write + Send>,
    interval: Duration,
    unit: String,
    prefix: String,
    message: String,
    length: u64,
    position: u64,
    /// The position and time the ETA's rate is measured from.
    rate_from: (u64, Instant),
    started: Instant,
    last_line: Option<Instant>,
    /// Whether anything changed since the last line.
    dirty: bool,
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mode = match self.mode {
            Mode::Hidden => "hidden",
            Mode::Bar(_) => "bar",
            Mode::Log(_) => "log",
        };
        f.debug_struct("Progress").field("mode", &mode).finish()
    }
}

impl Progress {
    /// Progress on stderr: `template` (an `indicatif` template, e.g.
    /// `"{bar:40} {pos}/{len} samples  ETA {eta}  {msg}"`) on a terminal; lines every
    /// [`log_interval`] naming `unit` otherwise; nothing when `quiet`.
    #[must_use]
    pub fn stderr(length: u64, unit: &str, template: &str, quiet: bool) -> Self {
        if quiet {
            return Self::hidden();
        }
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(length);
            if let Ok(style) = ProgressStyle::with_template(template) {
                bar.set_style(style.progress_chars("=> "));
            }
            return Self {
                mode: Mode::Bar(bar),
            };
        }
        Self::to_log(std::io::stderr(), log_interval(), length, unit)
    }

    /// Progress written as lines to `sink`: one at the first update after each `interval`
    /// (counted from its creation), and one whenever [`Progress::line`] or
    /// [`Progress::finish`] is called after a change.
    #[must_use]
    pub fn to_log(
        sink: impl Write + Send + 'static,
        interval: Duration,
        length: u64,
        unit: &str,
    ) -> Self {
        let now = Instant::now();
        Self {
            mode: Mode::Log(Mutex::new(LogState {
                sink: Box::new(sink),
                interval,
                unit: unit.to_owned(),
                prefix: String::new(),
                message: String::new(),
                length,
                position: 0,
                rate_from: (0, now),
                started: now,
                last_line: None,
                dirty: false,
            })),
        }
    }

    /// Progress that shows nothing.
    #[must_use]
    pub fn hidden() -> Self {
        Self { mode: Mode::Hidden }
    }

    /// A change of position: drawn on a bar, written to a log once its interval is up.
    fn advance(&self, bar: impl FnOnce(&ProgressBar), log: impl FnOnce(&mut LogState)) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(b) => bar(b),
            Mode::Log(state) => {
                let mut s = state.lock().unwrap_or_else(PoisonError::into_inner);
                log(&mut s);
                s.dirty = true;
                if s.last_line.unwrap_or(s.started).elapsed() >= s.interval {
                    s.write_line();
                }
            }
        }
    }

    /// Names the stage (e.g. the net being trained), shown before the counts from the next
    /// line on; call [`Progress::start_at`] next.
    pub fn set_prefix(&self, prefix: &str) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(b) => b.set_prefix(prefix.to_owned()),
            Mode::Log(state) => {
                prefix.clone_into(&mut state.lock().unwrap_or_else(PoisonError::into_inner).prefix)
            }
        }
    }

    /// The number of units done.
    pub fn set_position(&self, position: u64) {
        self.advance(|b| b.set_position(position), |s| s.position = position);
    }

    /// One or more units done.
    pub fn inc(&self, delta: u64) {
        self.advance(|b| b.inc(delta), |s| s.position += delta);
    }

    /// A note shown after the counts (losses, samples that did not converge); a log shows
    /// it from its next line, so set it before the position it goes with.
    pub fn set_message(&self, message: &str) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(b) => b.set_message(message.to_owned()),
            Mode::Log(state) => {
                let mut s = state.lock().unwrap_or_else(PoisonError::into_inner);
                message.clone_into(&mut s.message);
                s.dirty = true;
            }
        }
    }

    /// Starts (or restarts, for the next stage) at `position` of `length`, with no message:
    /// the rate behind the ETA is measured from here, so a resumed run does not count the
    /// units it found done as done in no time. A log gets a line at once.
    pub fn start_at(&self, length: u64, position: u64) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(b) => {
                b.set_length(length);
                b.set_position(position);
                b.set_message("");
                b.reset_eta();
            }
            Mode::Log(state) => {
                let mut s = state.lock().unwrap_or_else(PoisonError::into_inner);
                s.length = length;
                s.position = position;
                s.message.clear();
                s.rate_from = (position, Instant::now());
                s.write_line();
            }
        }
    }

    /// Writes a line now if anything changed since the last (a log only): the end of a
    /// stage, which the interval would otherwise skip.
    pub fn line(&self) {
        if let Mode::Log(state) = &self.mode {
            let mut s = state.lock().unwrap_or_else(PoisonError::into_inner);
            if s.dirty {
                s.write_line();
            }
        }
    }

    /// The stage is over where it stands (an early stop ends a training before its last
    /// epoch): its length becomes its position, and a log gets that line.
    pub fn end_stage(&self) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(b) => b.set_length(b.position()),
            Mode::Log(state) => {
                let mut s = state.lock().unwrap_or_else(PoisonError::into_inner);
                if s.dirty || s.length != s.position {
                    s.length = s.position;
                    s.write_line();
                }
            }
        }
    }

    /// The run is over: clears a bar, writes a last line to a log.
    pub fn finish(&self) {
        match &self.mode {
            Mode::Hidden => {}
            Mode::Bar(b) => b.finish_and_clear(),
            Mode::Log(_) => self.line(),
        }
    }
}

impl LogState {
    fn write_line(&mut self) {
        let now = Instant::now();
        let (from, since) = self.rate_from;
        let done = self.position.saturating_sub(from);
        let remaining = self.length.saturating_sub(self.position);
        let eta = if remaining == 0 {
            "0s".to_owned()
        } else if done == 0 {
            "unknown".to_owned()
        } else {
            let per_unit = now.duration_since(since).as_secs_f64() / done as f64;
            human(Duration::from_secs_f64(per_unit * remaining as f64))
        };
        let percent = if self.length == 0 {
            100.0
        } else {
            100.0 * self.position as f64 / self.length as f64
        };
        let prefix = if self.prefix.is_empty() {
            String::new()
        } else {
            format!("{} ", self.prefix)
        };
        let message = if self.message.is_empty() {
            String::new()
        } else {
            format!("  {}", self.message)
        };
        // A log that cannot be written to must not stop the run it reports on.
        let _ = writeln!(
            self.sink,
            "{prefix}{} {}/{} ({percent:.1} %), {} elapsed, ETA {eta}{message}",
            self.unit,
            self.position,
            self.length,
            human(now.duration_since(self.started)),
        );
        let _ = self.sink.flush();
        self.last_line = Some(now);
        self.dirty = false;
    }
}

/// `1h 05m`, `3m 20s` or `45s`.
fn human(d: Duration) -> String {
    let secs = d.as_secs();
    let (h, m, s) = (secs / 3600, secs / 60 % 60, secs % 60);
    if h > 0 {
        format!("{h}h {m:02}m")
    } else if m > 0 {
        format!("{m}m {s:02}s")
    } else {
        format!("{s}s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_counts_the_rate_from_where_a_resumed_run_starts() {
        let log = SharedLog::default();
        let progress = Progress::to_log(log.clone(), Duration::from_secs(3600), 0, "samples");
        progress.start_at(100, 60);
        assert_eq!(
            log.contents(),
            "samples 60/100 (60.0 %), 0s elapsed, ETA unknown\n"
        );
        std::thread::sleep(Duration::from_millis(1100));
        progress.inc(1);
        progress.line();
        // One sample in ≥ 1.1 s leaves 39 samples ≥ 42 s: a rate taken from the 60 already
        // on disk would have said under a second.
        let text = log.contents();
        let last = text.lines().last().unwrap_or_default();
        assert!(
            last.starts_with("samples 61/100 (61.0 %), 1s elapsed"),
            "{text}"
        );
        let eta = last.split("ETA ").nth(1).unwrap_or_default();
        let seconds = eta
            .trim_end_matches('s')
            .parse::<u64>()
            .unwrap_or(if eta.contains('m') { 60 } else { 0 });
        assert!(seconds >= 42, "{text}");
    }

    #[test]
    fn a_log_writes_a_line_per_interval_and_on_request() {
        let log = SharedLog::default();
        let progress = Progress::to_log(log.clone(), Duration::from_secs(3600), 400, "epoch");
        progress.set_prefix("fitting");
        for epoch in 1..=57 {
            progress.set_message(&format!("dev {:.3}", 1.0 / epoch as f64));
            progress.set_position(epoch);
        }
        progress.line();
        progress.line(); // nothing changed since: no second copy
        let text = log.contents();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 1, "{text}");
        assert!(
            lines[0].starts_with("fitting epoch 57/400 (14.2 %)")
                && lines[0].ends_with("dev 0.018"),
            "{text}"
        );
        let every = SharedLog::default();
        let progress = Progress::to_log(every.clone(), Duration::ZERO, 3, "samples");
        (0..3).for_each(|_| progress.inc(1));
        progress.finish();
        assert_eq!(
            every.contents().lines().count(),
            3,
            "a zero interval: a line per update"
        );
    }

    #[test]
    fn an_early_stop_ends_the_stage_where_it_stands() {
        let log = SharedLog::default();
        let progress = Progress::to_log(log.clone(), Duration::from_secs(3600), 0, "epoch");
        progress.set_prefix("local");
        progress.start_at(400, 0);
        progress.set_position(250);
        progress.end_stage();
        progress.end_stage(); // nothing new: no second line
        let text = log.contents();
        assert_eq!(text.lines().count(), 2, "{text}");
        assert!(
            text.lines()
                .last()
                .unwrap_or_default()
                .starts_with("local epoch 250/250 (100.0 %)")
                && text.ends_with("ETA 0s\n"),
            "{text}"
        );
    }

    #[test]
    fn durations_read_as_hours_minutes_or_seconds() {
        assert_eq!(human(Duration::from_secs(45)), "45s");
        assert_eq!(human(Duration::from_secs(200)), "3m 20s");
        assert_eq!(human(Duration::from_secs(3900)), "1h 05m");
    }

    #[test]
    fn a_hidden_progress_and_a_finished_log_ignore_further_updates_quietly() {
        let hidden = Progress::hidden();
        hidden.inc(3);
        hidden.finish();
        let log = SharedLog::default();
        let progress = Progress::to_log(log.clone(), Duration::ZERO, 0, "samples");
        progress.finish();
        assert!(
            log.contents().is_empty(),
            "nothing happened, nothing to say"
        );
    }
}
