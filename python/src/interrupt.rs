//! Long calls that Ctrl-C (a notebook's "interrupt the kernel") stops, and that say they
//! are running.
//!
//! Python runs its signal handlers only between bytecodes, so a call into Rust would keep
//! Ctrl-C waiting until it returns. Each long call therefore runs on a thread of its own,
//! the GIL released, while the calling thread looks for Python's signals every
//! [`POLL`]; on a signal's exception it asks the library to stop
//! (`work::cancel`), waits for the work to unwind at its next `work::checkpoint` (the end
//! of a closed-loop run, a batch engine's step, an Allan analysis's averaging time), and
//! raises the exception. A call that runs longer than `work::progress_s()` (10 s, or
//! `PTSA_PROGRESS_S`) writes a line to Python's `sys.stderr` (a notebook shows it under
//! the cell) once a period: the command line's progress line, with the library's stage.

use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::{Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};

use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use ptsa_host_sim::simulation::work::{self, Cancelled, Lines};

/// How often a waiting call looks for Python's signals.
pub const POLL: Duration = Duration::from_millis(50);

/// `f()`, stopped by Ctrl-C: the exception Python's signal handler raised (usually
/// `KeyboardInterrupt`), after the work has unwound. A panic in `f` is raised again here
/// (pyo3 makes it a `PanicException`). `what` names the call in its progress lines.
///
/// The cancellation is the process's: another call running at the same time on another
/// Python thread stops too, with `KeyboardInterrupt`.
///
/// # Errors
/// The signal handler's exception.
pub fn interruptible<T: Send>(
    py: Python<'_>,
    what: &str,
    f: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    // The stage is the process's: one call's last stage is not the next one's.
    work::set_stage("");
    let r = run_and_watch(py, what, f);
    work::set_stage("");
    r
}

/// [`interruptible`] without its stage reset.
fn run_and_watch<T: Send>(py: Python<'_>, what: &str, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    let finished = (Mutex::new(false), Condvar::new());
    let (start, mut lines) = (Instant::now(), Lines::new(work::progress_s()));
    std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let r = catch_unwind(AssertUnwindSafe(f));
            *finished.0.lock().unwrap_or_else(PoisonError::into_inner) = true;
            finished.1.notify_all();
            r
        });
        loop {
            let done = py.detach(|| {
                let g = finished.0.lock().unwrap_or_else(PoisonError::into_inner);
                let (g, _) = finished
                    .1
                    .wait_timeout_while(g, POLL, |done| !*done)
                    .unwrap_or_else(PoisonError::into_inner);
                *g
            });
            if done {
                break;
            }
            let elapsed = start.elapsed().as_secs_f64();
            if lines.due(elapsed) {
                progress(py, &work::line(what, &work::stage(), None, elapsed));
            }
            if let Err(e) = py.check_signals() {
                work::cancel();
                // The work's own end (a result, or the unwinding) is not wanted any more.
                let _ = py.detach(|| worker.join());
                work::resume();
                return Err(e);
            }
        }
        match worker.join() {
            Ok(Ok(v)) => Ok(v),
            Ok(Err(p)) | Err(p) if p.is::<Cancelled>() => Err(PyKeyboardInterrupt::new_err(
                "cancelled: another call of this process was interrupted",
            )),
            Ok(Err(p)) | Err(p) => resume_unwind(p),
        }
    })
}

/// `line` on Python's `sys.stderr` (where a notebook shows it); a stream that refuses it
/// costs the line only.
fn progress(py: Python<'_>, line: &str) {
    let write = || -> PyResult<()> {
        let err = py.import("sys")?.getattr("stderr")?;
        err.call_method1("write", (format!("{line}\n"),))?;
        err.call_method0("flush")?;
        Ok(())
    };
    let _ = write();
}
