//! The warm-start keeper: keeps the warm-start record (`crate::warm`) up to date from the
//! control loop without doing file I/O in it. The loop offers its record every step; the
//! ones that say something new go to a thread of their own, which writes the newest one
//! queued to every place a successor looks (the RAM fallback first) and says each place that
//! cannot be written, and when it can be again.
//!
//! It is not the record's format or its reading at a restart (`crate::warm`).

use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use heli_fsw::core::{Severity, WarmStart};
use heli_log::replace::Replaced;

use crate::rt;
use crate::threads::Clock;

/// Records queued for the keeper's thread; a full queue skips a rewrite.
const QUEUE: usize = 4;

/// Whether the warm-start record `warm` at `t_us` must be written, the last one written
/// being `last` (its time and record): the first, one that says something new (airborne or
/// not, another origin, a roll begun or ended), one a [`crate::warm::REWRITE_S`] after the
/// last, or in a roll one a [`crate::warm::ROLL_REWRITE_S`] after it.
fn rewrite_due(last: Option<&(u64, WarmStart)>, t_us: u64, warm: &WarmStart) -> bool {
    match last {
        None => true,
        Some((at, last)) => {
            let since_s = heli_nav::seconds_between(*at, t_us);
            last.airborne != warm.airborne
                || last.origin != warm.origin
                || last.roll.is_some() != warm.roll.is_some()
                || since_s >= crate::warm::REWRITE_S
                || (warm.roll.is_some() && since_s >= crate::warm::ROLL_REWRITE_S)
        }
    }
}

/// Keeps the warm-start file up to date from the control loop without doing file I/O in
/// it: records go to a thread of their own, newest wins.
pub(crate) struct WarmKeeper {
    tx: Option<SyncSender<Option<WarmStart>>>,
    thread: Option<std::thread::JoinHandle<()>>,
    last: Option<(u64, WarmStart)>,
}

impl WarmKeeper {
    /// Keeps the record of flight `start` at every one of `paths`, stamped on `clock`. A
    /// path that cannot be written is raised with `say` at once (and again when it can be
    /// written again): a successor may have to resume from the other one.
    pub(crate) fn spawn(
        paths: Vec<PathBuf>,
        start: heli_link::StartParameters,
        clock: Clock,
        say: impl FnMut(Severity, String) + Send + 'static,
    ) -> Self {
        let write = move |path: &Path, record: Option<WarmStart>| match record {
            Some(warm) => {
                crate::warm::WarmFile::for_successor(warm, start.clone(), &clock).write(path)
            }
            None => crate::warm::remove(path).map(|()| Replaced::Durably),
        };
        Self::spawn_with(paths, write, say)
    }

    /// [`WarmKeeper::spawn`] with the writing and the saying given: `write` writes a record
    /// at a path (`None`: removes it), `say` raises an event.
    fn spawn_with(
        paths: Vec<PathBuf>,
        write: impl FnMut(&Path, Option<WarmStart>) -> std::io::Result<Replaced> + Send + 'static,
        say: impl FnMut(Severity, String) + Send + 'static,
    ) -> Self {
        let (tx, rx) = sync_channel::<Option<WarmStart>>(QUEUE);
        let thread = rt::thread("warm-start", rt::HELPER_STACK_BYTES)
            .spawn(move || keep(&rx, &paths, write, say))
            .ok();
        Self {
            tx: Some(tx),
            thread,
            last: None,
        }
    }

    /// The record now: written when it says something new (airborne, an origin) or once a
    /// [`crate::warm::REWRITE_S`] has passed.
    pub(crate) fn offer(&mut self, t_us: u64, warm: Option<WarmStart>) {
        let Some(warm) = warm else { return };
        if rewrite_due(self.last.as_ref(), t_us, &warm)
            && let Some(tx) = &self.tx
        {
            // A full queue skips one rewrite; the next one carries newer values anyway.
            if tx.try_send(Some(warm)).is_ok() {
                self.last = Some((t_us, warm));
            }
        }
    }

    /// The flight ended cleanly: the files are removed.
    pub(crate) fn finish(mut self) {
        if let Some(tx) = self.tx.take() {
            let _ = tx.send(None);
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The keeper's thread: until the loop's end, writes the newest record queued (`None`: the
/// flight ended cleanly, the record is removed) at every path, the last one (the RAM
/// fallback) first, and says each path that begins or ends failing.
fn keep(
    rx: &Receiver<Option<WarmStart>>,
    paths: &[PathBuf],
    mut write: impl FnMut(&Path, Option<WarmStart>) -> std::io::Result<Replaced>,
    mut say: impl FnMut(Severity, String),
) {
    let mut failing = vec![false; paths.len()];
    while let Ok(mut record) = rx.recv() {
        // Newest wins: records that queued up while the storage was slow (each write is
        // synced) are passed over for the last one.
        while let Ok(newer) = rx.try_recv() {
            record = newer;
        }
        // The last path first: the fallback directory, in RAM, is written at once, whatever
        // the log directory's storage takes.
        for (path, failing) in paths.iter().zip(failing.iter_mut()).rev() {
            let problem = match write(path, record) {
                Err(e) => Some(format!(
                    "{e}: a restart now resumes from an older record or none"
                )),
                Ok(replaced) => replaced.warning(),
            };
            let text = match (problem, *failing) {
                (Some(problem), false) => {
                    format!("warm-start record {}: {problem}", path.display())
                }
                (None, true) => format!("warm-start record {}: written again", path.display()),
                _ => continue,
            };
            *failing = !*failing;
            let severity = if *failing {
                Severity::WarningHi
            } else {
                Severity::ActivityHi
            };
            say(severity, text);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::channel;
    use std::sync::{Arc, Mutex};

    fn record(bias_rps: f64) -> WarmStart {
        WarmStart {
            gyro_bias_rps: [bias_rps, 0.0, 0.0],
            origin: None,
            home_ned_m: None,
            airborne: false,
            trim: None,
            references: heli_nav::GroundReferences::default(),
            roll: None,
        }
    }

    /// Longest a test waits for the keeper's thread (a keeper that writes nothing fails the
    /// test instead of hanging it).
    const WAIT: std::time::Duration = std::time::Duration::from_secs(10);

    /// What the keeper's writer was asked, in order: the path and the record's x bias
    /// (`None`: a removal).
    type Writes = Arc<Mutex<Vec<(PathBuf, Option<f64>)>>>;

    fn paths() -> Vec<PathBuf> {
        vec![PathBuf::from("/log/warm"), PathBuf::from("/ram/warm")]
    }

    #[test]
    fn the_newest_queued_record_is_written_and_the_ram_copy_first() {
        let writes: Writes = Arc::default();
        // The first write hangs (a slow card) until the test lets it go.
        let (entered_tx, entered) = channel::<()>();
        let (release, released) = channel::<()>();
        let mut first = true;
        let log = Arc::clone(&writes);
        let write = move |path: &Path, record: Option<WarmStart>| {
            log.lock()
                .map_err(|_| std::io::Error::other("poisoned"))?
                .push((path.to_path_buf(), record.map(|w| w.gyro_bias_rps[0])));
            if std::mem::take(&mut first) {
                let _ = entered_tx.send(());
                let _ = released.recv();
            }
            Ok(Replaced::Durably)
        };
        let mut keeper = WarmKeeper::spawn_with(paths(), write, |_, _| {});
        keeper.offer(0, Some(record(0.1)));
        entered
            .recv_timeout(WAIT)
            .expect("the keeper writes the first record");
        // While the storage is slow, three records queue up: only the newest is written.
        for (i, bias) in [0.2, 0.3, 0.4].into_iter().enumerate() {
            let t_us = 20_000_000 * (i as u64 + 1);
            keeper.offer(t_us, Some(record(bias)));
        }
        assert_eq!(
            keeper.last.map(|(t_us, _)| t_us),
            Some(60_000_000),
            "all queued"
        );
        release.send(()).expect("the writer waits");
        keeper.finish();
        let ram = PathBuf::from("/ram/warm");
        let log = PathBuf::from("/log/warm");
        let writes = writes.lock().expect("not poisoned").clone();
        // The clean end's removal may join the queue's newest before the thread looks: then
        // it alone wins, and the record 0.4 is never written.
        let ended = [(ram.clone(), None), (log.clone(), None)];
        let first_record = [(ram.clone(), Some(0.1)), (log.clone(), Some(0.1))];
        let newest = [(ram.clone(), Some(0.4)), (log.clone(), Some(0.4))];
        assert_eq!(writes[..2], first_record, "the RAM copy first: {writes:?}");
        let rest = &writes[2..];
        assert!(
            rest == [newest.as_slice(), ended.as_slice()].concat() || rest == ended,
            "only the newest queued record, then the removal: {writes:?}"
        );
    }

    #[test]
    fn a_path_that_fails_is_said_once_and_again_when_it_is_written() {
        let (said_tx, said) = channel::<(Severity, String)>();
        let (wrote_tx, wrote) = channel::<()>();
        // The log directory's copy fails twice, then works; the RAM copy always works.
        let mut log_writes = 0;
        let write = move |path: &Path, _: Option<WarmStart>| {
            let result = if path == Path::new("/log/warm") {
                log_writes += 1;
                if log_writes <= 2 {
                    Err(std::io::Error::other("card removed"))
                } else {
                    Ok(Replaced::Durably)
                }
            } else {
                Ok(Replaced::Durably)
            };
            let _ = wrote_tx.send(());
            result
        };
        let say = move |severity, text| {
            let _ = said_tx.send((severity, text));
        };
        let mut keeper = WarmKeeper::spawn_with(paths(), write, say);
        for (i, bias) in [0.1, 0.2, 0.3].into_iter().enumerate() {
            keeper.offer(20_000_000 * i as u64, Some(record(bias)));
            // Both places written before the next record (else the newest would win).
            for _ in 0..2 {
                wrote.recv_timeout(WAIT).expect("the keeper writes");
            }
        }
        keeper.finish();
        let said: Vec<_> = said.try_iter().collect();
        assert_eq!(said.len(), 2, "{said:?}");
        assert_eq!(said[0].0, Severity::WarningHi);
        assert!(
            said[0]
                .1
                .starts_with("warm-start record /log/warm: card removed: a restart"),
            "{said:?}"
        );
        assert_eq!(
            said[1],
            (
                Severity::ActivityHi,
                "warm-start record /log/warm: written again".to_string()
            )
        );
    }

    #[test]
    fn the_warm_start_record_is_rewritten_when_it_says_something_new_or_is_old() {
        let warm = record(0.001);
        assert!(rewrite_due(None, 0, &warm), "the first");
        let last = (10_000_000, warm);
        // The biases drift a little: not worth a write until the record is old.
        let drifted = WarmStart {
            gyro_bias_rps: [0.0011, 0.0, 0.0],
            ..warm
        };
        let rewrite_us = 10_000_000 + (crate::warm::REWRITE_S * 1e6) as u64;
        assert!(!rewrite_due(Some(&last), 10_500_000, &drifted));
        assert!(!rewrite_due(Some(&last), rewrite_us - 1, &drifted));
        assert!(rewrite_due(Some(&last), rewrite_us, &drifted));
        // Taking off, or an origin found: at once.
        let flying = WarmStart {
            airborne: true,
            ..warm
        };
        assert!(rewrite_due(Some(&last), 10_000_001, &flying));
        let located = WarmStart {
            origin: Some(heli_nav::GeoOrigin {
                lat_deg: 42.0,
                lon_deg: -71.0,
                alt_m: 3.0,
            }),
            ..warm
        };
        assert!(rewrite_due(Some(&last), 10_000_001, &located));
        // A roll begun: at once; in the roll, every control step; the roll over: at once.
        let rolling = WarmStart {
            roll: Some(heli_fsw::core::RollRecord {
                at_us: 10_000_000,
                angle_rad: 0.1,
                rate_rps: [3.0, 0.0, 0.0],
                att: [1.0, 0.0, 0.0, 0.0],
                elapsed_s: 0.02,
                rolls_done: 0,
                pos_ned_m: [0.0; 3],
                yaw_rad: 0.0,
            }),
            ..warm
        };
        assert!(rewrite_due(Some(&last), 10_000_001, &rolling));
        let in_roll = (10_000_000, rolling);
        let step_us = 10_000_000 + (crate::warm::ROLL_REWRITE_S * 1e6) as u64;
        assert!(!rewrite_due(Some(&in_roll), step_us - 1, &rolling));
        assert!(rewrite_due(Some(&in_roll), step_us, &rolling));
        assert!(rewrite_due(Some(&in_roll), 10_000_001, &warm));
    }
}
