//! FMU log messages. The `fmi` crate forwards every fmi2CallbackLogger call to the `log` crate
//! with the instance name as target; this logger keeps the last messages of each instance so that
//! an error from an FMI call can quote what the FMU said, and prints warnings and errors.

use std::collections::{BTreeMap, VecDeque};
use std::sync::{Mutex, Once};

const KEPT_PER_INSTANCE: usize = 8;

struct FmuLogger {
    recent: Mutex<BTreeMap<String, VecDeque<String>>>,
}

static LOGGER: FmuLogger = FmuLogger {
    recent: Mutex::new(BTreeMap::new()),
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
            eprintln!("[FMU {}] {message}", record.target());
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

/// Forget what was kept for `instance` (at the end of a run).
pub fn forget(instance: &str) {
    if let Ok(mut r) = LOGGER.recent.lock() {
        r.remove(instance);
    }
}
