//! FMU log messages. The `fmi` crate forwards every fmi2CallbackLogger call to the `log` crate
//! with the instance name as target; this logger keeps the last messages of each instance so that
//! an error from an FMI call can quote what the FMU said, and prints warnings and errors. A
//! message an instance repeats, word for word or with only its numbers changed (an out-of-range
//! input clamped at every doStep names the value it got each time), is printed
//! [`PRINTED_REPEATS`] times and then once more with a note that further repeats are not
//! printed; they are still kept for [`take_recent`].

use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, Once};

const KEPT_PER_INSTANCE: usize = 8;
/// How often the same message of one instance is printed before its repeats are dropped.
pub const PRINTED_REPEATS: u32 = 3;
/// Distinct messages counted per instance; beyond them every new message is printed uncounted,
/// so the counts stay bounded whatever an FMU logs.
const COUNTED_PER_INSTANCE: usize = 256;

/// What to do with one printable message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Printing {
    Print,
    /// Print it with a note that its further repeats will not be printed.
    PrintLast,
    Suppress,
}

/// Counts each instance's messages, to print a repeated one only [`PRINTED_REPEATS`] times.
struct RepeatFilter {
    counts: BTreeMap<String, BTreeMap<String, u32>>,
}

impl RepeatFilter {
    const fn new() -> Self {
        Self {
            counts: BTreeMap::new(),
        }
    }

    fn admit(&mut self, instance: &str, message: &str) -> Printing {
        let counts = self.counts.entry(instance.to_string()).or_default();
        let shape = shape(message);
        if !counts.contains_key(&shape) && counts.len() >= COUNTED_PER_INSTANCE {
            return Printing::Print;
        }
        let count = counts.entry(shape).or_insert(0);
        *count = count.saturating_add(1);
        match (*count).cmp(&PRINTED_REPEATS) {
            std::cmp::Ordering::Less => Printing::Print,
            std::cmp::Ordering::Equal => Printing::PrintLast,
            std::cmp::Ordering::Greater => Printing::Suppress,
        }
    }
}

/// `message` with every number (a run of digits and the points between them) replaced by `#`:
/// what makes two messages repeats of one another.
fn shape(message: &str) -> String {
    let mut shaped = String::with_capacity(message.len());
    let mut in_number = false;
    for c in message.chars() {
        if c.is_ascii_digit() || (in_number && c == '.') {
            if !in_number {
                shaped.push('#');
            }
            in_number = true;
        } else {
            shaped.push(c);
            in_number = false;
        }
    }
    shaped
}

struct FmuLogger {
    recent: Mutex<BTreeMap<String, VecDeque<String>>>,
    printed: Mutex<RepeatFilter>,
}

static LOGGER: FmuLogger = FmuLogger {
    recent: Mutex::new(BTreeMap::new()),
    printed: Mutex::new(RepeatFilter::new()),
};
static INSTALL: Once = Once::new();

impl log::Log for FmuLogger {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::Level::Info
    }

    fn log(&self, record: &log::Record) {
        // Only messages forwarded from FMUs carry module path "logger" (fmi-sys); ignore the
        // crates' own debug chatter.
        if record.module_path() != Some("logger") || !self.enabled(record.metadata()) {
            return;
        }
        let message = format!("{}: {}", record.level(), record.args());
        if record.level() <= log::Level::Warn {
            let printing = self.printed.lock().map_or(Printing::Print, |mut filter| {
                filter.admit(record.target(), &message)
            });
            let line = match printing {
                Printing::Print => Some(format!("[FMU {}] {message}", record.target())),
                Printing::PrintLast => Some(format!(
                    "[FMU {}] {message} (repeated {PRINTED_REPEATS} times, numbers aside; further repeats not printed)",
                    record.target()
                )),
                Printing::Suppress => None,
            };
            if let Some(line) = line {
                let recordable =
                    record.level() == log::Level::Warn || RECORD_ERRORS.load(Ordering::SeqCst);
                let expected = recordable && Recorder::keep(&line);
                if !expected {
                    eprintln!("{line}");
                }
            }
        }
        if let Ok(mut recent) = self.recent.lock() {
            let queue = recent.entry(record.target().to_string()).or_default();
            if queue.len() == KEPT_PER_INSTANCE {
                queue.pop_front();
            }
            queue.push_back(message);
        }
    }

    fn flush(&self) {}
}

/// Install the logger once per process (later calls do nothing).
pub fn install() {
    INSTALL.call_once(|| {
        if log::set_logger(&LOGGER).is_ok() {
            log::set_max_level(log::LevelFilter::Info);
        }
    });
}

/// Take the messages kept for `instance` (empties the buffer).
pub fn take_recent(instance: &str) -> Vec<String> {
    LOGGER
        .recent
        .lock()
        .ok()
        .and_then(|mut r| r.remove(instance))
        .map(|q| q.into_iter().collect())
        .unwrap_or_default()
}

/// Forget what was kept and counted for `instance` (at the end of a run).
pub fn forget(instance: &str) {
    if let Ok(mut r) = LOGGER.recent.lock() {
        r.remove(instance);
    }
    if let Ok(mut filter) = LOGGER.printed.lock() {
        filter.counts.remove(instance);
    }
}

/// The warnings a [`Recorder`] keeps instead of printing; None while none lives.
static RECORDED: Mutex<Option<Vec<String>>> = Mutex::new(None);

/// Whether the living [`Recorder`] keeps errors too ([`Recorder::start_with_errors`]).
static RECORD_ERRORS: AtomicBool = AtomicBool::new(false);

/// While a `Recorder` lives, the FMU warnings that would be printed (repeats limited as for
/// printing) are kept for it instead: a study that feeds
/// inputs out of range on purpose reports the warnings it expects instead of printing them among
/// the ones nobody expects. Errors are printed as always. One recorder at a time: the study runs
/// its deliberate case alone.
pub struct Recorder(());

impl Recorder {
    pub fn start() -> Recorder {
        if let Ok(mut recorded) = RECORDED.lock() {
            *recorded = Some(Vec::new());
        }
        Recorder(())
    }

    /// Like [`Recorder::start`], and errors are kept too: for a study that runs configurations
    /// an FMU refuses on purpose and reports each refusal in its own table.
    pub fn start_with_errors() -> Recorder {
        let recorder = Recorder::start();
        RECORD_ERRORS.store(true, Ordering::SeqCst);
        recorder
    }

    /// The warnings recorded so far, each as it would have been printed, in order.
    pub fn take(&self) -> Vec<String> {
        RECORDED
            .lock()
            .ok()
            .and_then(|mut recorded| recorded.as_mut().map(std::mem::take))
            .unwrap_or_default()
    }

    /// Keeps `line` if a recorder lives; whether it did.
    fn keep(line: &str) -> bool {
        RECORDED
            .lock()
            .ok()
            .and_then(|mut recorded| recorded.as_mut().map(|r| r.push(line.to_string())))
            .is_some()
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        RECORD_ERRORS.store(false, Ordering::SeqCst);
        if let Ok(mut recorded) = RECORDED.lock() {
            *recorded = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_repeated_message_is_printed_three_times_then_dropped_per_instance() {
        let mut filter = RepeatFilter::new();
        let seen: Vec<Printing> = (0..5)
            .map(|_| filter.admit("EKF", "WARN: clamped"))
            .collect();
        assert_eq!(
            seen,
            [
                Printing::Print,
                Printing::Print,
                Printing::PrintLast,
                Printing::Suppress,
                Printing::Suppress
            ]
        );
        // Another instance, or another message, is counted on its own.
        assert_eq!(filter.admit("UKF", "WARN: clamped"), Printing::Print);
        assert_eq!(filter.admit("EKF", "WARN: other"), Printing::Print);
    }

    #[test]
    fn a_message_repeated_with_other_numbers_is_a_repeat() {
        let mut filter = RepeatFilter::new();
        let clamped = |value: f64| {
            format!(
                "WARN: fmi2SetReal: variable 'drive_torque' (valueReference 2): value {value} is \
                 outside its range [-10000, 10000]; clamped to 10000"
            )
        };
        let seen: Vec<Printing> = [11203.26, 11150.2, 10998.0, 10500.5]
            .map(|value| filter.admit("vehicle", &clamped(value)))
            .to_vec();
        assert_eq!(
            seen,
            [
                Printing::Print,
                Printing::Print,
                Printing::PrintLast,
                Printing::Suppress
            ]
        );
        // other words are another message
        let other = "WARN: fmi2SetReal: variable 'brake_torque' (valueReference 3): value 1.5e5";
        assert_eq!(filter.admit("vehicle", other), Printing::Print);
        assert_eq!(shape("a 1.5e-5 b 42."), "a #e-# b #");
    }

    #[test]
    fn beyond_the_counted_messages_new_ones_are_printed_uncounted() {
        let mut filter = RepeatFilter::new();
        for k in 0..COUNTED_PER_INSTANCE {
            // distinct words, not numbers (those would be repeats of one message)
            let word: String = format!("{k:b}")
                .chars()
                .map(|bit| if bit == '0' { 'a' } else { 'b' })
                .collect();
            assert_eq!(
                filter.admit("PF", &format!("message {word}")),
                Printing::Print
            );
        }
        for _ in 0..5 {
            assert_eq!(filter.admit("PF", "one more"), Printing::Print);
        }
        assert_eq!(filter.counts["PF"].len(), COUNTED_PER_INSTANCE);
    }

    #[test]
    fn a_recorder_keeps_the_warnings_it_expects_and_lets_errors_through() {
        let log = |level: log::Level, text: &str| {
            log::Log::log(
                &LOGGER,
                &log::Record::builder()
                    .module_path(Some("logger"))
                    .target("recorder-test")
                    .level(level)
                    .args(format_args!("{text}"))
                    .build(),
            )
        };
        let recorder = Recorder::start();
        log(log::Level::Warn, "steering_angle clamped");
        log(log::Level::Error, "a real error");
        assert_eq!(
            recorder.take(),
            ["[FMU recorder-test] WARN: steering_angle clamped"]
        );
        drop(recorder);
        assert!(!Recorder::keep("after the recorder"));
        forget("recorder-test");
    }
}
