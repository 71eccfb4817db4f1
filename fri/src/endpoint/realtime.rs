//! Best-effort real-time setup of the endpoint thread: each step logs a warning instead of
//! failing when the process lacks the privilege (CAP_SYS_NICE, RLIMIT_MEMLOCK, …).

use serde::{Deserialize, Serialize};

/// Real-time settings of the endpoint thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct RealtimeConfig {
    /// SCHED_FIFO priority of the thread (1…99), `None` to keep the default scheduler.
    pub fifo_priority: Option<i32>,
    /// CPU index to pin the thread to, `None` for no pinning.
    pub cpu: Option<usize>,
    /// Lock current and future pages of the whole process in RAM (`mlockall`).
    pub lock_memory: bool,
}

impl RealtimeConfig {
    /// No real-time settings (tests, tools).
    pub const NONE: Self = Self {
        fifo_priority: None,
        cpu: None,
        lock_memory: false,
    };
}

impl Default for RealtimeConfig {
    /// SCHED_FIFO 80, no pinning, memory locked: what a 1 ms controller link wants.
    fn default() -> Self {
        Self {
            fifo_priority: Some(80),
            cpu: None,
            lock_memory: true,
        }
    }
}

/// Which settings took effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RealtimeReport {
    /// SCHED_FIFO applied.
    pub fifo: bool,
    /// CPU affinity applied.
    pub affinity: bool,
    /// `mlockall` applied.
    pub memory_locked: bool,
}

/// Applies `config` to the calling thread (and, for `mlockall`, the process).
pub fn apply(config: &RealtimeConfig) -> RealtimeReport {
    let mut report = RealtimeReport::default();
    if let Some(priority) = config.fifo_priority {
        let param = libc::sched_param {
            sched_priority: priority,
        };
        // SAFETY: pthread_self() is always valid for the calling thread and `param` outlives
        // the call.
        let rc =
            unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
        if rc == 0 {
            report.fifo = true;
        } else {
            tracing::warn!(
                priority,
                error = %std::io::Error::from_raw_os_error(rc),
                "SCHED_FIFO not applied; the FRI thread runs with normal priority"
            );
        }
    }
    if let Some(cpu) = config.cpu {
        report.affinity = pin_to_cpu(cpu);
    }
    if config.lock_memory {
        // SAFETY: plain system call without pointers.
        let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
        if rc == 0 {
            report.memory_locked = true;
        } else {
            tracing::warn!(error = %std::io::Error::last_os_error(), "mlockall failed; pages may be swapped out");
        }
    }
    report
}

fn pin_to_cpu(cpu: usize) -> bool {
    if cpu >= libc::CPU_SETSIZE as usize {
        tracing::warn!(cpu, "CPU index out of range; affinity not applied");
        return false;
    }
    // SAFETY: cpu_set_t is plain data; CPU_ZERO/CPU_SET stay inside it (index checked above);
    // sched_setaffinity reads `size_of::<cpu_set_t>()` bytes from a valid reference.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_ZERO(&mut set);
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 {
        true
    } else {
        tracing::warn!(cpu, error = %std::io::Error::last_os_error(), "CPU affinity not applied");
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn none_applies_nothing_and_never_fails() {
        assert_eq!(apply(&RealtimeConfig::NONE), RealtimeReport::default());
    }

    #[test]
    fn out_of_range_cpu_is_reported_not_fatal() {
        let config = RealtimeConfig {
            fifo_priority: None,
            cpu: Some(1 << 20),
            lock_memory: false,
        };
        assert!(!apply(&config).affinity);
    }
}
