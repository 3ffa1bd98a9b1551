//! Real-time settings for the flight process: memory locked (`mlockall`), the control loop
//! and the serial drivers under `SCHED_FIFO`, and idle CPUs kept awake enough to answer at
//! once (a CPU wake-up latency of 0 held on `/dev/cpu_dma_latency`, as `cyclictest` does).
//! All need privileges (root or `CAP_SYS_NICE` / `CAP_IPC_LOCK`); when refused the flight
//! goes on with a one-line note, as on a development machine.

use thread_priority::{
    NormalThreadSchedulePolicy, RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue,
    ThreadSchedulePolicy, set_thread_priority_and_policy, thread_native_id,
};

/// `SCHED_FIFO` priority of the control loop (1..=99; PX4 runs its rate loops near the top).
pub const LOOP_PRIORITY: u8 = 80;

/// `SCHED_FIFO` priority of the serial driver threads: under the loop, over everything else,
/// so that a byte read is handed on at once even when the logger is compressing.
pub const DRIVER_PRIORITY: u8 = 70;

/// Stack of the control thread. The deepest it went in a rolls flight was 52 KiB (a release
/// build, measured without `mlockall` from the thread's resident stack pages); the room is
/// for debug builds and for paths a flight did not take.
pub const CONTROL_STACK_BYTES: usize = 1024 * 1024;

/// Stack of the logger thread (20 KiB measured; the MCAP writer's compressor keeps its state
/// on the heap).
pub const LOGGER_STACK_BYTES: usize = 512 * 1024;

/// Stack of every other thread of the flight process: drivers and their supervisors, the
/// compass, the hot-swap, the battery and telemetry servers, the warm-start keeper, the
/// printer and the reader of the bootstrap's lines (8-12 KiB measured).
pub const HELPER_STACK_BYTES: usize = 256 * 1024;

/// A named thread with a stack of `bytes`. The flight process's threads say their stack:
/// with its memory locked every page of every stack is resident, and the default (2 MiB a
/// thread) would be most of the process's memory.
pub fn thread(name: impl Into<String>, bytes: usize) -> std::thread::Builder {
    std::thread::Builder::new()
        .name(name.into())
        .stack_size(bytes)
}

/// Locks the process's memory so no page fault stalls the loop. Returns a note.
pub fn lock_memory() -> String {
    use nix::sys::mman::{MlockAllFlags, mlockall};
    match mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE) {
        Ok(()) => "memory locked (mlockall)".to_string(),
        Err(e) => format!("memory not locked: mlockall refused ({e}); needs root or CAP_IPC_LOCK"),
    }
}

/// Holds the machine's CPU wake-up latency at 0 µs for as long as the returned file is open
/// (the kernel's PM QoS request through `/dev/cpu_dma_latency`): idle CPUs poll instead of
/// entering sleep states, so a thread woken by a serial byte runs at once. On a virtual
/// machine a halted virtual CPU waits for the host to schedule it again: with this request
/// held, the bench's IMU-to-servo p99 went from 5.2 ms to 0.42 ms (docs/BENCHMARKS.md, with
/// the HILSim's own 5 ms reader sleep still in place). The price is an idle CPU's power.
/// Returns the request (to keep) and a note.
pub fn hold_wake_latency() -> (Option<std::fs::File>, String) {
    use std::io::Write;
    let path = "/dev/cpu_dma_latency";
    let request = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .and_then(|mut f| f.write_all(&0i32.to_ne_bytes()).map(|()| f));
    match request {
        Ok(f) => (
            Some(f),
            format!("CPU wake-up latency held at 0 us ({path}): idle CPUs poll"),
        ),
        Err(e) => (
            None,
            format!("CPU wake-up latency not held: {path}: {e}; needs root"),
        ),
    }
}

/// Puts the calling thread under `SCHED_FIFO` at `priority`. Returns a note.
pub fn realtime_thread(priority: u8) -> String {
    let value = match ThreadPriorityValue::try_from(priority) {
        Ok(v) => v,
        Err(e) => return format!("loop priority {priority} refused: {e}"),
    };
    match set_thread_priority_and_policy(
        thread_native_id(),
        ThreadPriority::Crossplatform(value),
        ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
    ) {
        Ok(()) => format!("control loop under SCHED_FIFO priority {priority}"),
        Err(e) => format!(
            "control loop under the normal scheduler: SCHED_FIFO refused ({e:?}); needs root or CAP_SYS_NICE"
        ),
    }
}

/// Now on `CLOCK_MONOTONIC` (ns since an arbitrary moment shared by every process of the
/// machine); 0 if the clock cannot be read.
pub fn mono_ns() -> u64 {
    nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC).map_or(0, |t| {
        let s = u64::try_from(t.tv_sec()).unwrap_or(0);
        let ns = u64::try_from(t.tv_nsec()).unwrap_or(0);
        s.saturating_mul(1_000_000_000).saturating_add(ns)
    })
}

/// The instant `at` (past or future) on `CLOCK_MONOTONIC` (ns): both clocks read together now,
/// so no skew between two clocks' starts enters (`Instant` reads the same clock on Linux).
pub fn mono_ns_at(at: std::time::Instant) -> u64 {
    let now = std::time::Instant::now();
    let now_ns = mono_ns();
    let ns = |d: std::time::Duration| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX);
    match at.checked_duration_since(now) {
        Some(ahead) => now_ns.saturating_add(ns(ahead)),
        None => now_ns.saturating_sub(ns(now.saturating_duration_since(at))),
    }
}

/// How the flight's real-time threads (control loop, drivers) are set up.
#[derive(Clone, Copy, Debug, Default)]
pub struct RtThreads {
    /// Under `SCHED_FIFO` where the machine allows.
    pub realtime: bool,
    /// Pinned to this CPU, if any.
    pub cpu: Option<usize>,
}

impl RtThreads {
    /// Sets up the calling driver thread: `SCHED_FIFO` at [`DRIVER_PRIORITY`] and the CPU.
    /// Refusals are said once by the control loop's own notes.
    pub fn driver(&self) {
        if self.realtime {
            let _ = realtime_thread(DRIVER_PRIORITY);
        }
        if let Some(cpu) = self.cpu {
            let _ = pin_to_cpu(cpu);
        }
    }
}

/// Pins the calling thread to CPU `cpu` (`sched_setaffinity`): the flight's real-time
/// threads on a CPU of their own, away from the one that takes the network's interrupts
/// (docs/architecture.md, "Timing"). Returns a note.
pub fn pin_to_cpu(cpu: usize) -> String {
    use nix::sched::{CpuSet, sched_setaffinity};
    use nix::unistd::Pid;
    let mut set = CpuSet::new();
    if let Err(e) = set.set(cpu) {
        return format!("CPU {cpu} refused: {e}");
    }
    match sched_setaffinity(Pid::from_raw(0), &set) {
        Ok(()) => format!("pinned to CPU {cpu}"),
        Err(e) => format!("not pinned to CPU {cpu}: {e}"),
    }
}

/// Nice value of the threads that must never take the flight's time: the link, which a
/// flood of datagrams can keep busy.
pub const BACKGROUND_NICE: i32 = 9;

/// Puts the calling thread under the normal scheduler at a lower weight (nice
/// [`BACKGROUND_NICE`]): it still runs whenever a CPU is free, but a busy one gets about a
/// tenth of what a normal thread gets beside it. Needs no privileges. Returns a note.
pub fn background_thread() -> String {
    // thread-priority maps 0..=99 onto nice 20..=-20; 25 is nice 9.
    let value = match ThreadPriorityValue::try_from(25u8) {
        Ok(v) => v,
        Err(e) => return format!("background priority refused: {e}"),
    };
    match set_thread_priority_and_policy(
        thread_native_id(),
        ThreadPriority::Crossplatform(value),
        ThreadSchedulePolicy::Normal(NormalThreadSchedulePolicy::Other),
    ) {
        Ok(()) => format!("nice {BACKGROUND_NICE}"),
        Err(e) => format!("background priority refused: {e:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each stack has at least 16 times the room its thread was measured to use in a release
    /// build (docs/BENCHMARKS.md: control 52 KiB, logger 20 KiB, the others 8-12 KiB), for
    /// debug builds and paths a flight did not take; and none is more than half the 2 MiB
    /// default, which locked in memory was most of the process.
    #[test]
    fn every_stack_has_its_measured_room_and_no_more_than_it_needs() {
        const KIB: usize = 1024;
        for (stack, measured) in [
            (CONTROL_STACK_BYTES, 52 * KIB),
            (LOGGER_STACK_BYTES, 20 * KIB),
            (HELPER_STACK_BYTES, 12 * KIB),
        ] {
            assert!(stack >= 16 * measured, "{stack} for {measured}");
            assert!(stack <= 1024 * KIB, "{stack}");
        }
        // And a thread is given what it asks for.
        let used = thread("probe", HELPER_STACK_BYTES)
            .spawn(|| {
                let mut room = [0u8; 128 * 1024];
                room[room.len() - 1] = 1;
                std::hint::black_box(&room).len()
            })
            .unwrap()
            .join()
            .unwrap();
        assert_eq!(used, 128 * 1024);
    }

    /// What a refused call may say: no privilege, or not enough lockable memory; never that
    /// the request itself was malformed.
    fn refused_for_privileges(note: &str) -> bool {
        note.contains("EPERM")
            || note.contains("ENOMEM")
            || note.starts_with("control loop under the normal scheduler")
    }

    /// The nice value of the calling thread, from `/proc/thread-self/stat` (field 19).
    fn own_nice() -> i32 {
        let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap();
        let rest = stat.rsplit_once(')').unwrap().1;
        rest.split_whitespace().nth(16).unwrap().parse().unwrap()
    }

    #[test]
    fn a_pinned_thread_runs_on_its_cpu_only_and_a_cpu_not_there_is_refused() {
        let (note, allowed) = std::thread::spawn(|| {
            let note = pin_to_cpu(0);
            let status = std::fs::read_to_string("/proc/thread-self/status").unwrap();
            let allowed = status
                .lines()
                .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
                .unwrap()
                .trim()
                .to_string();
            (note, allowed)
        })
        .join()
        .unwrap();
        assert_eq!(note, "pinned to CPU 0");
        assert_eq!(allowed, "0");
        let far = std::thread::spawn(|| pin_to_cpu(100_000)).join().unwrap();
        assert!(far.starts_with("CPU 100000 refused"), "{far}");
    }

    #[test]
    fn the_wake_latency_request_holds_zero_while_kept_or_says_why_not() {
        let (request, note) = hold_wake_latency();
        assert!(note.contains("/dev/cpu_dma_latency"), "{note}");
        match request {
            Some(_held) => {
                assert!(
                    note.starts_with("CPU wake-up latency held at 0 us"),
                    "{note}"
                );
                // The machine's effective value, read back while the request is open.
                let value = std::fs::read("/dev/cpu_dma_latency").unwrap();
                assert_eq!(i32::from_ne_bytes(value[..4].try_into().unwrap()), 0);
            }
            None => assert!(note.starts_with("CPU wake-up latency not held"), "{note}"),
        }
    }

    #[test]
    fn an_instant_past_or_future_is_said_on_the_monotonic_clock() {
        let now = std::time::Instant::now();
        let ns = mono_ns();
        let second = std::time::Duration::from_secs(1);
        let near = |a: u64, b: u64| a.abs_diff(b) < 50_000;
        assert!(near(mono_ns_at(now), ns));
        assert!(near(mono_ns_at(now + second), ns + 1_000_000_000));
        assert!(near(mono_ns_at(now - second), ns - 1_000_000_000));
    }

    #[test]
    fn a_driver_thread_takes_its_cpu() {
        let allowed = std::thread::spawn(|| {
            RtThreads {
                realtime: false,
                cpu: Some(0),
            }
            .driver();
            std::fs::read_to_string("/proc/thread-self/status")
                .unwrap()
                .lines()
                .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
                .unwrap()
                .trim()
                .to_string()
        })
        .join()
        .unwrap();
        assert_eq!(allowed, "0");
    }

    #[test]
    fn a_background_thread_runs_at_its_nice_value() {
        let before = own_nice();
        let (note, nice) = std::thread::spawn(|| (background_thread(), own_nice()))
            .join()
            .unwrap();
        // (Tests run under a higher nice than 9 may not lower it without privileges.)
        if before <= BACKGROUND_NICE {
            assert_eq!(note, format!("nice {BACKGROUND_NICE}"));
            assert_eq!(nice, BACKGROUND_NICE);
        }
        // The thread that asked, only.
        assert_eq!(own_nice(), before);
    }

    #[test]
    fn the_real_time_notes_say_what_was_done_or_why_not() {
        let memory = lock_memory();
        assert!(
            memory == "memory locked (mlockall)" || refused_for_privileges(&memory),
            "{memory}"
        );
        let note = std::thread::spawn(|| realtime_thread(DRIVER_PRIORITY))
            .join()
            .unwrap_or_default();
        assert!(
            note == format!("control loop under SCHED_FIFO priority {DRIVER_PRIORITY}")
                || refused_for_privileges(&note),
            "{note}"
        );
        // Priority 0 is not a SCHED_FIFO priority (1..=99): refused whoever asks.
        let zero = std::thread::spawn(|| realtime_thread(0))
            .join()
            .unwrap_or_default();
        assert!(
            zero.starts_with("control loop under the normal scheduler: SCHED_FIFO refused")
                || zero.starts_with("loop priority 0 refused"),
            "{zero}"
        );
    }
}
