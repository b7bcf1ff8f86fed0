//! Ending a node on SIGINT or SIGTERM as rclcpp's nodes do: Ctrl-C in a
//! terminal, or `ros2 launch` ending (it sends SIGINT, then SIGTERM after
//! a grace period). The handler only sets a flag; the node's own loop sees
//! it, finishes what must not be cut (a running job stops under control, a
//! recording is closed) and returns, so the process exits with status 0
//! and `ros2 launch` reports it as finished cleanly.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Catches SIGINT and SIGTERM from now on (once per process).
pub fn catch_signals() -> Result<(), String> {
    ctrlc::set_handler(|| REQUESTED.store(true, Ordering::SeqCst))
        .map_err(|e| format!("SIGINT/SIGTERM handler: {e}"))
}

/// Whether a SIGINT or SIGTERM arrived.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
