//! Which CPUs a node's threads run on (`--cpu-affinity`, the parameter
//! `cpu_affinity`, as ros2_control's controller manager names it).
//!
//! A twin's 1 kHz threads (the controller's loop and DDS thread, the
//! simulator's loop and DDS thread) wake each other about four times a
//! cycle. Where they run on different CPUs, each wake-up of a thread on
//! an idle CPU costs that CPU's wake from its idle state, and on a virtual
//! machine that is a trip through the hypervisor: about a third of a
//! running controller's CPU time on this project's 2-core VM
//! (BENCHMARKS.md, "A twin on one CPU"). Pinned to one CPU, the threads
//! hand over to each other on a CPU that is awake.

use crate::params::{Kind, Param};
use ros2_client::ParameterValue;

/// The read-only parameter `cpu_affinity` with these CPUs (both nodes
/// have it).
pub fn param(cpus: &[usize]) -> Param {
    Param::fixed(
        "cpu_affinity",
        Kind::IntegerArray,
        "the CPUs the node's threads run on, e.g. [1]; []: any (a twin's two nodes on one CPU cost less)",
    )
    .range(0.0, (MAX_CPU - 1) as f64)
    .value(ParameterValue::IntegerArray(
        cpus.iter().map(|&c| c as i64).collect(),
    ))
}

/// `cpu_affinity`'s value as CPU numbers (its range keeps them valid).
pub fn cpus_of(v: &[i64]) -> Vec<usize> {
    v.iter().filter_map(|&c| usize::try_from(c).ok()).collect()
}

/// CPU numbers a set can hold (glibc's `CPU_SETSIZE`).
pub const MAX_CPU: usize = 1024;

/// A list of CPUs as `0-1,3`.
pub fn show_cpus(cpus: &[usize]) -> String {
    let mut v = cpus.to_vec();
    v.sort_unstable();
    v.dedup();
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        out.push(if j > i {
            format!("{}-{}", v[i], v[j])
        } else {
            v[i].to_string()
        });
        i = j + 1;
    }
    out.join(",")
}

/// The CPUs this process may run on.
pub fn allowed_cpus() -> Result<Vec<usize>, String> {
    // SAFETY: a zeroed cpu_set_t is an empty set; sched_getaffinity writes
    // at most size_of::<cpu_set_t>() bytes into it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) };
    if r != 0 {
        return Err(format!(
            "sched_getaffinity: {}",
            std::io::Error::last_os_error()
        ));
    }
    // SAFETY: CPU_ISSET reads the set for c < CPU_SETSIZE.
    Ok((0..MAX_CPU)
        .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
        .collect())
}

/// Pins every thread of this process, and every thread it starts later,
/// to `cpus` (empty: nothing changes). Each CPU must be one the process may
/// run on already; the error says which are.
pub fn pin_process(cpus: &[usize]) -> Result<(), String> {
    if cpus.is_empty() {
        return Ok(());
    }
    let allowed = allowed_cpus()?;
    if let Some(c) = cpus.iter().find(|c| !allowed.contains(c)) {
        return Err(format!(
            "CPU {c} is not one this process may run on (it may run on {})",
            show_cpus(&allowed)
        ));
    }
    // SAFETY: as in allowed_cpus; CPU_SET writes the set for c < CPU_SETSIZE
    // (every c is in `allowed`, which holds none above it).
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &c in cpus {
        unsafe { libc::CPU_SET(c, &mut set) };
    }
    // every thread there is now (a thread started later takes its
    // starter's set, so the main thread is pinned first)
    let mut tids: Vec<libc::pid_t> = vec![0];
    if let Ok(dir) = std::fs::read_dir("/proc/self/task") {
        tids.extend(
            dir.flatten()
                .filter_map(|e| e.file_name().to_str()?.parse::<libc::pid_t>().ok()),
        );
    }
    for tid in tids {
        // SAFETY: sched_setaffinity reads the set; a thread that has ended
        // meanwhile gives ESRCH, which is no error here.
        let r =
            unsafe { libc::sched_setaffinity(tid, std::mem::size_of::<libc::cpu_set_t>(), &set) };
        if r != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() != Some(libc::ESRCH) {
                return Err(format!("sched_setaffinity: {e}"));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_lists_show_as_ranges() {
        assert_eq!(show_cpus(&[3, 0, 1, 1, 5, 6]), "0-1,3,5-6");
        assert_eq!(show_cpus(&[]), "");
        assert_eq!(cpus_of(&[0, -1, 2]), vec![0, 2]);
    }

    #[test]
    fn a_cpu_the_process_may_not_use_is_refused() {
        let allowed = allowed_cpus().unwrap();
        assert!(!allowed.is_empty());
        let e = pin_process(&[MAX_CPU - 1]).unwrap_err();
        assert_eq!(
            e,
            format!(
                "CPU 1023 is not one this process may run on (it may run on {})",
                show_cpus(&allowed)
            )
        );
        // nothing asked, nothing changed
        pin_process(&[]).unwrap();
        assert_eq!(allowed_cpus().unwrap(), allowed);
    }
}
