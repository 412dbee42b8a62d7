//! Ctrl-C during a long call that released the GIL: the call asks now and then, with the
//! GIL taken back for a moment, whether Python has a pending signal (KeyboardInterrupt).
use pyo3::prelude::*;

/// True when Python has a pending exception from a signal handler; the exception is
/// kept in `slot` so that the caller can raise it once the work has stopped.
pub fn requested(slot: &mut Option<PyErr>) -> bool {
    if slot.is_some() {
        return true;
    }
    Python::attach(|py| match py.check_signals() {
        Ok(()) => false,
        Err(e) => {
            *slot = Some(e);
            true
        }
    })
}
