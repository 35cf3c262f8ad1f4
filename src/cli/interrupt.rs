//! Ctrl-C (SIGINT), SIGTERM (a timeout, a batch scheduler's preemption, `docker stop`) and
//! SIGHUP (a closed terminal or ssh session), alike: the first asks the command to stop where
//! it can still write what it has; another, later, stops at once (exit 130).
//!
//! Signals within [`ONE_STOP`] of the first are that same stop, delivered twice: GNU
//! `timeout` sends its signal to the command and then to the command's process group, and a
//! scheduler may signal both a job step and its processes. Taken as "Ctrl-C again", they
//! would throw away the image the first signal asked to write.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Signals this soon after the first are the same request to stop.
pub const ONE_STOP: Duration = Duration::from_millis(500);

/// Whether a stop was asked for.
static STOPPING: AtomicBool = AtomicBool::new(false);

/// What a signal asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Request {
    /// The first: stop where what was done can still be written.
    Stop,
    /// The first one again, delivered twice: nothing more.
    Same,
    /// A later one: stop at once.
    Now,
}

/// What a signal at `now` asks for, given when the first arrived (`first`, set by the first).
pub fn request(first: &mut Option<Instant>, now: Instant) -> Request {
    match *first {
        None => {
            *first = Some(now);
            Request::Stop
        }
        Some(t) if now.saturating_duration_since(t) < ONE_STOP => Request::Same,
        Some(_) => Request::Now,
    }
}

/// Handles the three signals from now on: the first prints `message` and calls `stop`; a
/// later one removes any temporary file being written and exits 130.
pub fn install(message: &'static str, stop: impl Fn() + Send + 'static) {
    let first: Mutex<Option<Instant>> = Mutex::new(None);
    // Fails only if a handler is already installed (a second command in one process).
    let installed = ctrlc::set_handler(move || {
        let mut first = first.lock().unwrap_or_else(|e| e.into_inner());
        match request(&mut first, Instant::now()) {
            Request::Stop => {
                STOPPING.store(true, Ordering::SeqCst);
                note!("\ninterrupt: {message}");
                stop();
            }
            Request::Same => {}
            Request::Now => {
                note!("\ninterrupt: stopped at once, nothing more written");
                // Exiting skips destructors: remove a half-written image or checkpoint first.
                crate::output::atomic::remove_unfinished();
                std::process::exit(130);
            }
        }
    });
    if let Err(e) = installed {
        note!("warning: cannot catch Ctrl-C: {e}");
    }
}

/// Whether a signal asked the command to stop.
pub fn stopping() -> bool {
    STOPPING.load(Ordering::SeqCst)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signal_delivered_twice_is_one_stop_and_a_later_one_stops_at_once() {
        let t = Instant::now();
        let mut first = None;
        assert_eq!(request(&mut first, t), Request::Stop);
        // timeout's second delivery, to the process group, microseconds later.
        assert_eq!(
            request(&mut first, t + Duration::from_micros(30)),
            Request::Same
        );
        assert_eq!(request(&mut first, t + ONE_STOP / 2), Request::Same);
        assert_eq!(request(&mut first, t + ONE_STOP), Request::Now);
        assert_eq!(request(&mut first, t + 10 * ONE_STOP), Request::Now);
    }
}
