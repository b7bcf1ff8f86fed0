//! Recordings after the fact: `cnc bag compare` and `cnc bag rerun`.
//!
//! [`compare`] reads two MCAP recordings (as [`crate::record`] writes them,
//! or any ROS 2 MCAP with CDR payloads) and reports, per topic, missing and
//! extra messages, log-time differences and payload differences; for
//! topics with positions it reports the largest deviation per value and
//! where it first exceeds the tolerance, with the source line:
//!
//! | type | values compared with the tolerance (mm) |
//! |---|---|
//! | sensor_msgs/JointState | `position` per joint name (m in the file) |
//! | geometry_msgs/PoseStamped | `pose.position` x, y, z |
//! | tf2_msgs/TFMessage | `translation` x, y, z per child frame |
//! | sensor_msgs/PointCloud2 | every float32/float64 field of every point |
//!
//! Messages are paired by their index on the topic. The source line of a
//! message is that of the last `/cnc/status` of file B stamped at or before
//! it (file A's if B has none). Offline recordings
//! ([`record::record_simulation`]) have a status on every line change (and
//! at 10 Hz), so there this is the exact line of the sample; in a live
//! recording it is as exact as the node's status rate.
//!
//! Tolerance 0 means exact equality: every payload byte-identical. With a
//! tolerance > 0 the values above may differ by up to the tolerance; the
//! rest of such a message (names, stamps, frames, sizes) must be equal, and
//! velocities and efforts (finite differences of the positions in
//! `/sim/joint_states`) are not compared. Other topics must be
//! byte-identical either way. Log times must always be equal.
//!
//! [`rerun`] runs the controller again on the program and the machine file
//! a recording carries and writes a new recording.
//!
//! [`write_rrd`] (`cnc bag rrd`) writes a recording as a Rerun file with
//! its layout, through the converter `cnc_node/rerun/cnc_rrd.py`.
//!
//! For a program with G33, [`compare`] also reports the groove's phase of
//! every thread pass in both files (setpoints and actual positions against
//! each file's recorded encoder, and the difference), measured as
//! `cnc plot --thread` measures a recording ([`measure_recording`]); it
//! does not count against the tolerance.
//!
//! Every recording is read by one reader, [`Bag`] (`cnc bag compare`,
//! `cnc bag replay`, `cnc bag rerun`, `cnc plot` of a recording); only
//! `cnc bag recover` ([`crate::recover`]) reads cut files record by record.

mod compare;
mod reader;
mod rrd;
mod thread_phase;

pub use compare::{compare, compare_bags, At, CompareReport, ThreadPhases, TopicDiff, ValueDiff};
pub use reader::{Bag, Extent, Job, MessageView, TopicData};
pub use rrd::{programmed_moves, programmed_text, write_rrd, ProgrammedMove, CONVERTER};
pub use thread_phase::{
    measure_bag, measure_recording, NotMeasured, PassPhase, PassWindow, RecordingThreads,
    MAX_GAP_NS,
};

use crate::record::{self, RecordSummary};
use std::path::Path;

/// Runs the controller again on the program and the machine file recorded
/// in `recording` (attachments `program.nc` and `machine.toml`, else the
/// `/cnc/program` and `/cnc/machine_file` messages; dialect and program
/// name from the `cnc` metadata) and records the run to `out` with
/// [`record::record_simulation`].
///
/// The controller does not consume encoder data yet: once synchronized
/// moves exist (G95 coupling to the measured spindle, G33 threading), the
/// recorded encoder stream will drive them here instead of the simulated
/// spindle. Today the simulated spindle is seeded deterministically, so a
/// rerun with the same code reproduces the original recording's messages
/// exactly ([`compare`] with tolerance 0 passes).
pub fn rerun(recording: &Path, out: &Path) -> Result<RecordSummary, String> {
    let job = Bag::read(recording)?
        .job()
        .map_err(|e| format!("{}: {e}", recording.display()))?;
    record::record_simulation_as(
        &job.machine,
        Some(&job.machine_text),
        &job.program_name,
        &job.program_text,
        job.dialect,
        out,
    )
}
