//! Ctrl-C: the thread that called the kernel waits for its work and checks
//! Python's signals every [`POLL`]; on a pending SIGINT it raises this flag,
//! which the workers check between groups and between the steps of a large
//! group (the triangulation's insertions, the stages of a group), so the call
//! ends within about [`POLL`] plus one step and raises `KeyboardInterrupt`.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// How often the waiting thread checks Python's signals.
pub const POLL: Duration = Duration::from_millis(50);

/// The error of work that stopped on the flag.
pub const INTERRUPTED: &str = "the kernel was interrupted (Ctrl-C)";

/// Calls interrupted and still winding down: work stops while it is above 0.
static STOP: AtomicUsize = AtomicUsize::new(0);

/// Whether work should stop now (a call is being interrupted). Every kernel
/// call running at that moment stops: Ctrl-C stops the process's kernel work.
pub fn requested() -> bool {
    STOP.load(Ordering::Relaxed) > 0
}

/// Raise the flag for one interrupted call, until [`Request`] is dropped.
pub fn request() -> Request {
    STOP.fetch_add(1, Ordering::Relaxed);
    Request(())
}

/// A raised flag, lowered when dropped (when the interrupted work is done).
pub struct Request(());

impl Drop for Request {
    fn drop(&mut self) {
        STOP.fetch_sub(1, Ordering::Relaxed);
    }
}

/// `Err(INTERRUPTED)` when work should stop.
pub fn check() -> Result<(), String> {
    if requested() {
        Err(INTERRUPTED.to_string())
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flag_is_up_while_a_request_lives() {
        assert!(check().is_ok());
        let r = request();
        assert!(requested() && check() == Err(INTERRUPTED.to_string()));
        drop(r);
        assert!(!requested());
    }
}
