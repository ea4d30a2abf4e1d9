//! A signal's clean-up (`output::fs::abandon`) while other threads are writing into a
//! staging folder: the folder is gone and stays gone. A test binary of its own, because
//! `abandon` empties the process's whole list of temporaries.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use ptsa_host_sim::output::fs::{StagedDir, abandon, write_atomic};

/// Three threads write files into a staged folder as fast as they can; the clean-up runs
/// in the middle of it and holds the list as the signal handler does until the process
/// exits. 200 rounds: with the folder made outside the list's lock, 28 of 200 rounds left
/// it behind on this machine.
#[test]
fn a_staging_folder_removed_on_a_signal_is_not_made_again() {
    let root = tempfile::tempdir().unwrap();
    let mut left = Vec::new();
    for round in 0..200 {
        let staged = StagedDir::new(&root.path().join(format!("r{round}"))).unwrap();
        let dir = staged.path().to_path_buf();
        let stop = Arc::new(AtomicBool::new(false));
        let writers: Vec<_> = (0..3)
            .map(|t| {
                let (dir, stop) = (dir.clone(), Arc::clone(&stop));
                std::thread::spawn(move || {
                    let mut i = 0;
                    while !stop.load(Ordering::Relaxed) {
                        // Fails once the folder is gone: that is the point.
                        let _ = write_atomic(&dir.join(format!("f{t}-{i}")), b"x");
                        i += 1;
                    }
                })
            })
            .collect();
        std::thread::sleep(Duration::from_millis(2));
        let held = abandon();
        std::thread::sleep(Duration::from_millis(5));
        if dir.exists() {
            left.push(round);
        }
        stop.store(true, Ordering::Relaxed);
        drop(held);
        for w in writers {
            w.join().unwrap();
        }
        // Its temporary is gone already; dropping it would only try again.
        std::mem::forget(staged);
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(left.is_empty(), "left behind in rounds {left:?}");
}
