//! The warm-start file: what a flight process leaves for the one the bootstrap may start
//! after it (`heli_fsw::core::WarmStart`), with the start line it was flying, so that a
//! process restarted in the air — after a crash, or after a brown-out of the whole
//! computer — aligns in the air instead of calibrating for 80 s.
//!
//! The file is plain text, one `key = values` line each, written to a temporary file and
//! renamed over the old one (a power cut leaves the old file or the new one, never half of
//! one). A clean Stop removes it. A file that cannot be read is an error naming the line;
//! the process then starts cold and says so.

use std::path::{Path, PathBuf};

use crate::error::VehicleError;
use heli_fsw::core::{RollRecord, WarmStart};
use heli_link::StartParameters;
use heli_nav::GeoOrigin;
use heli_proto::scb::Controls;

/// The file's name in the log directory.
pub const FILE_NAME: &str = "warm-start";

/// How often the flight process rewrites the file while flying (s of flight clock): the
/// biases and the trim drift slowly; being airborne is written at once.
pub const REWRITE_S: f64 = 1.0;

/// How often the file is rewritten in a roll (s of flight clock): every control step, so
/// that a successor started within the servo board's hold knows the roll it has to finish.
pub const ROLL_REWRITE_S: f64 = 0.02;

/// The warm-start file of a log directory.
pub fn path_in(log_dir: &Path) -> PathBuf {
    log_dir.join(FILE_NAME)
}

/// What the file holds: the record and the start it flies (`start = <suffix> <mode> [plan]`).
#[derive(Clone, Debug, PartialEq)]
pub struct WarmFile {
    /// The flight software's record.
    pub warm: WarmStart,
    /// The parameters the flight was started with.
    pub start: StartParameters,
    /// The roll record's time is a wall-clock time (µs since 1970), as in the file a
    /// process leaves (`clock = unix`); otherwise it is on the reading process's own clock,
    /// as in the log's metadata, once [`WarmFile::rebased`].
    pub unix_times: bool,
}

/// The roll record's numbers, in the order of its `roll` line: angle, rates (3), attitude
/// (4), time in the roll, position (3), heading.
fn roll_numbers(r: &RollRecord) -> [f64; 13] {
    let [p, q, rr] = r.rate_rps;
    let [w, x, y, z] = r.att;
    let [n, e, d] = r.pos_ned_m;
    [
        r.angle_rad,
        p,
        q,
        rr,
        w,
        x,
        y,
        z,
        r.elapsed_s,
        n,
        e,
        d,
        r.yaw_rad,
    ]
}

/// `N` numbers whose count was checked.
fn array<const N: usize>(v: Vec<f64>) -> [f64; N] {
    v.try_into().unwrap_or([0.0; N])
}

fn numbers(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| format!("{v:e}"))
        .collect::<Vec<_>>()
        .join(" ")
}

impl WarmFile {
    /// The file's text.
    pub fn to_text(&self) -> String {
        let w = &self.warm;
        let mut text = format!(
            "start = {}\nairborne = {}\ngyro_bias_rps = {}\n",
            crate::supervisor::start_words(&self.start),
            w.airborne,
            numbers(&w.gyro_bias_rps)
        );
        if let Some(o) = w.origin {
            text.push_str(&format!(
                "origin = {}\n",
                numbers(&[o.lat_deg, o.lon_deg, o.alt_m])
            ));
        }
        if let Some(h) = w.home_ned_m {
            text.push_str(&format!("home_ned_m = {}\n", numbers(&h)));
        }
        if let Some(t) = w.trim {
            text.push_str(&format!(
                "trim = {}\n",
                numbers(&[t.aileron, t.elevator, t.rudder, t.collective, t.throttle])
            ));
        }
        if let Some(f) = w.references.earth_field_ned_gauss {
            text.push_str(&format!("earth_field_ned_gauss = {}\n", numbers(&f)));
        }
        if let Some((p, z)) = w.references.baro_reference {
            text.push_str(&format!("baro_reference = {}\n", numbers(&[p, z])));
        }
        if let Some(r) = w.roll {
            if self.unix_times {
                text.push_str("clock = unix\n");
            }
            text.push_str(&format!(
                "roll_at_us = {}\nroll_rolls_done = {}\nroll = {}\n",
                r.at_us,
                r.rolls_done,
                numbers(&roll_numbers(&r))
            ));
        }
        text
    }

    /// The record with its roll's time moved from the wall clock onto `clock` (the reading
    /// process's flight clock): how long ago the roll was seen is then a difference of two
    /// times on the clock the flight software runs on.
    pub fn rebased(mut self, clock: &crate::threads::Clock) -> Self {
        if self.unix_times {
            if let Some(r) = self.warm.roll.as_mut() {
                r.at_us = clock.flight_us_of_unix(r.at_us);
            }
            self.unix_times = false;
        }
        self
    }

    /// The record as its writer on `clock` leaves it in a file: its roll's time on the wall
    /// clock, which a successor's clock can be set against.
    pub fn for_successor(
        warm: WarmStart,
        start: StartParameters,
        clock: &crate::threads::Clock,
    ) -> Self {
        let mut warm = warm;
        if let Some(r) = warm.roll.as_mut() {
            r.at_us = clock.unix_us(r.at_us);
        }
        Self {
            warm,
            start,
            unix_times: true,
        }
    }

    /// Reads the file's text; an error names the line and what is wrong with it.
    pub fn parse(text: &str) -> Result<Self, VehicleError> {
        let mut start = None;
        let mut airborne = None;
        let mut gyro = None;
        let mut origin = None;
        let mut home = None;
        let mut trim = None;
        let mut field = None;
        let mut baro = None;
        let mut roll = None;
        let mut roll_at = None;
        let mut rolls_done = None;
        let mut unix_times = false;
        for (n, line) in (1usize..).zip(text.lines().map(str::trim)) {
            if line.is_empty() {
                continue;
            }
            let (key, value) = line
                .split_once('=')
                .map(|(k, v)| (k.trim(), v.trim()))
                .ok_or_else(|| {
                    VehicleError::invalid(
                        format!("line {n}"),
                        format!("'{line}' is not 'key = value'"),
                    )
                })?;
            let floats = |count: usize| -> Result<Vec<f64>, VehicleError> {
                let v: Vec<f64> = value
                    .split_whitespace()
                    .map(str::parse::<f64>)
                    .collect::<Result<_, _>>()
                    .map_err(|e| VehicleError::invalid(format!("line {n}: {key}"), e))?;
                if v.len() != count || !v.iter().all(|x| x.is_finite()) {
                    return Err(VehicleError::invalid(
                        format!("line {n}"),
                        format!("{key} needs {count} finite numbers"),
                    ));
                }
                Ok(v)
            };
            match key {
                "start" => {
                    start = Some(
                        crate::supervisor::parse_start_words(value)
                            .map_err(|e| VehicleError::invalid(format!("line {n}: start"), e))?,
                    );
                }
                "airborne" => {
                    airborne = Some(value.parse::<bool>().map_err(|_| {
                        VehicleError::invalid(format!("line {n}"), "airborne is true or false")
                    })?);
                }
                "gyro_bias_rps" => gyro = Some(array::<3>(floats(3)?)),
                "origin" => origin = Some(array::<3>(floats(3)?)),
                "home_ned_m" => home = Some(array::<3>(floats(3)?)),
                "trim" => trim = Some(array::<5>(floats(5)?)),
                "earth_field_ned_gauss" => field = Some(array::<3>(floats(3)?)),
                "baro_reference" => baro = Some(array::<2>(floats(2)?)),
                "roll" => roll = Some(array::<13>(floats(13)?)),
                "roll_at_us" => {
                    roll_at =
                        Some(value.parse::<i64>().map_err(|e| {
                            VehicleError::invalid(format!("line {n}: roll_at_us"), e)
                        })?);
                }
                "roll_rolls_done" => {
                    rolls_done = Some(value.parse::<u32>().map_err(|e| {
                        VehicleError::invalid(format!("line {n}: roll_rolls_done"), e)
                    })?);
                }
                "clock" => {
                    if value != "unix" {
                        return Err(VehicleError::invalid(
                            format!("line {n}"),
                            format!("clock '{value}' is not 'unix' (the wall clock)"),
                        ));
                    }
                    unix_times = true;
                }
                _ => {
                    return Err(VehicleError::invalid(
                        format!("line {n}"),
                        format!("unknown key '{key}'"),
                    ));
                }
            }
        }
        Ok(Self {
            start: start.ok_or_else(|| missing("start"))?,
            warm: WarmStart {
                gyro_bias_rps: gyro.ok_or_else(|| missing("gyro_bias_rps"))?,
                origin: origin.map(|[lat_deg, lon_deg, alt_m]| GeoOrigin {
                    lat_deg,
                    lon_deg,
                    alt_m,
                }),
                home_ned_m: home,
                airborne: airborne.ok_or_else(|| missing("airborne"))?,
                trim: trim.map(
                    |[aileron, elevator, rudder, collective, throttle]| Controls {
                        aileron,
                        elevator,
                        rudder,
                        collective,
                        throttle,
                    },
                ),
                references: heli_nav::GroundReferences {
                    earth_field_ned_gauss: field,
                    baro_reference: baro.map(|[p, z]| (p, z)),
                },
                roll: match (roll, roll_at) {
                    (Some(v), Some(at_us)) => Some(roll_record(v, at_us, rolls_done.unwrap_or(0))),
                    (None, None) => None,
                    _ => {
                        return Err(VehicleError::invalid(
                            "",
                            "'roll' and 'roll_at_us' go together",
                        ));
                    }
                },
            },
            unix_times,
        })
    }

    /// Writes the file whole: a temporary file beside it, synced, then renamed over it
    /// (a power loss leaves the old record or this one, never an empty file).
    pub fn write(&self, path: &Path) -> std::io::Result<heli_log::replace::Replaced> {
        heli_log::replace::replace_file(
            path,
            &path.with_extension("tmp"),
            self.to_text().as_bytes(),
        )
    }

    /// Reads the file; `Ok(None)` when there is none.
    pub fn read(path: &Path) -> Result<Option<Self>, VehicleError> {
        match std::fs::read_to_string(path) {
            Ok(text) => Self::parse(&text)
                .map(Some)
                .map_err(|e| e.within(path.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(VehicleError::file(path, e)),
        }
    }
}

/// The newest record that can be read of those at `paths` (the log directory's and the
/// fallback's: when the log disk refused writes, the fallback's is the fresher), by the
/// time each was written. What cannot be read is said through `note`, and so is finding
/// none: the restart then calibrates from scratch.
pub fn newest(paths: &[PathBuf], note: &dyn Fn(String)) -> Option<WarmFile> {
    let mut best: Option<(std::time::SystemTime, WarmFile)> = None;
    for path in paths {
        match WarmFile::read(path) {
            Ok(Some(file)) => {
                let written = std::fs::metadata(path)
                    .and_then(|m| m.modified())
                    .unwrap_or(std::time::UNIX_EPOCH);
                if best.as_ref().is_none_or(|(t, _)| written > *t) {
                    best = Some((written, file));
                }
            }
            Ok(None) => {}
            Err(e) => note(format!("warm-start record unreadable ({e})")),
        }
    }
    if best.is_none() {
        note("restarted without a warm-start record: calibrating from scratch".into());
    }
    best.map(|(_, file)| file)
}

/// The roll record of a `roll` line's numbers ([`roll_numbers`]).
fn roll_record(v: [f64; 13], at_us: i64, rolls_done: u32) -> RollRecord {
    let [angle_rad, p, q, r, w, x, y, z, elapsed_s, n, e, d, yaw_rad] = v;
    RollRecord {
        at_us,
        angle_rad,
        rate_rps: [p, q, r],
        att: [w, x, y, z],
        elapsed_s,
        rolls_done,
        pos_ned_m: [n, e, d],
        yaw_rad,
    }
}

/// A line the file must have.
fn missing(key: &str) -> VehicleError {
    VehicleError::invalid("", format!("no '{key}' line"))
}

/// Removes the file (a clean end of the flight); a missing file is no error.
pub fn remove(path: &Path) -> std::io::Result<()> {
    match std::fs::remove_file(path) {
        // Its directory synced: a record removed at a clean Stop does not come back after a
        // power loss.
        Ok(()) => heli_log::replace::sync_dir(path),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_restart_resumes_from_the_newest_record_it_can_read_and_says_what_it_could_not() {
        let dir = tempfile::tempdir().unwrap();
        let (disk, ram) = (dir.path().join("disk"), dir.path().join("ram"));
        let said = std::cell::RefCell::new(Vec::<String>::new());
        let note = |text: String| said.borrow_mut().push(text);
        let paths = [disk.clone(), ram.clone()];
        assert_eq!(newest(&paths, &note), None);
        assert!(said.borrow()[0].contains("without a warm-start record"));
        // The disk's record is old (its writes failed); the RAM's is the fresher.
        let old = sample();
        let mut fresh = sample();
        fresh.warm.gyro_bias_rps = [0.5, 0.5, 0.5];
        assert!(old.write(&disk).unwrap().warning().is_none());
        assert!(fresh.write(&ram).unwrap().warning().is_none());
        let then = std::time::SystemTime::now() - std::time::Duration::from_secs(30);
        std::fs::File::options()
            .write(true)
            .open(&disk)
            .unwrap()
            .set_modified(then)
            .unwrap();
        assert_eq!(newest(&paths, &note), Some(fresh.clone()));
        // Reversed, the disk's wins; a damaged one is said and passed over.
        let now = std::time::SystemTime::now() + std::time::Duration::from_secs(30);
        std::fs::File::options()
            .write(true)
            .open(&disk)
            .unwrap()
            .set_modified(now)
            .unwrap();
        assert_eq!(newest(&paths, &note), Some(old));
        std::fs::write(&disk, "not a record\n").unwrap();
        said.borrow_mut().clear();
        assert_eq!(newest(&paths, &note), Some(fresh));
        assert!(
            said.borrow().iter().any(|t| t.contains("unreadable")),
            "{:?}",
            said.borrow()
        );
    }

    fn sample() -> WarmFile {
        WarmFile {
            start: crate::supervisor::parse_start_words("hover1 autonomous hover").unwrap(),
            warm: WarmStart {
                gyro_bias_rps: [0.001, -0.0135, 2.5e-7],
                origin: Some(GeoOrigin {
                    lat_deg: 42.3581,
                    lon_deg: -71.0966,
                    alt_m: 5.0,
                }),
                home_ned_m: Some([0.1, -0.2, 0.3]),
                airborne: true,
                trim: Some(Controls {
                    aileron: 0.02,
                    elevator: 0.0,
                    rudder: 0.41,
                    collective: 0.55,
                    throttle: 0.8,
                }),
                references: heli_nav::GroundReferences {
                    earth_field_ned_gauss: Some([0.19, -0.05, 0.48]),
                    baro_reference: Some((1012.25, -0.5)),
                },
                roll: Some(RollRecord {
                    at_us: 1_795_765_182_802_125,
                    angle_rad: 1.25,
                    rate_rps: [3.1, -0.02, 0.4],
                    att: [0.8, 0.6, 0.0, 0.0],
                    elapsed_s: 0.42,
                    rolls_done: 1,
                    pos_ned_m: [70.0, -0.4, -31.5],
                    yaw_rad: 0.05,
                }),
            },
            unix_times: true,
        }
    }

    #[test]
    fn a_roll_seen_on_the_wall_clock_is_set_against_the_successors_clock() {
        use std::time::{Duration, SystemTime, UNIX_EPOCH};
        let unix_now_us = |ago: Duration| {
            i64::try_from(
                (SystemTime::now() - ago)
                    .duration_since(UNIX_EPOCH)
                    .unwrap()
                    .as_micros(),
            )
            .unwrap()
        };
        for speed in [1.0, 4.0] {
            let clock = crate::threads::Clock::with_speed(speed);
            // Seen 0.6 s of wall clock before this clock began: that far back on it, at its speed.
            let mut file = sample();
            file.warm.roll.as_mut().unwrap().at_us = unix_now_us(Duration::from_millis(600));
            let rebased = file.clone().rebased(&clock);
            assert!(!rebased.unix_times);
            let at = rebased.warm.roll.unwrap().at_us;
            let expect = -600_000.0 * speed;
            assert!(
                (at as f64 - expect).abs() < 50_000.0 * speed,
                "{at} at speed {speed}"
            );
            // Rebasing twice changes nothing; the metadata's text keeps the flight clock's time.
            assert_eq!(rebased.clone().rebased(&clock), rebased);
            assert_eq!(
                WarmFile::parse(&rebased.to_text()).ok(),
                Some(rebased.clone())
            );
            // And a writer's record goes out on the wall clock its successor reads.
            let out = WarmFile::for_successor(rebased.warm, rebased.start.clone(), &clock);
            assert!(out.unix_times);
            let back = out.warm.roll.unwrap().at_us;
            assert!((back - file.warm.roll.unwrap().at_us).abs() < 50, "{back}");
        }
    }

    #[test]
    fn round_trips_exactly_through_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = path_in(dir.path());
        assert_eq!(WarmFile::read(&path).ok(), Some(None));
        assert!(sample().write(&path).unwrap().warning().is_none());
        assert_eq!(WarmFile::read(&path).ok(), Some(Some(sample())));
        let bare = WarmFile {
            warm: WarmStart {
                origin: None,
                home_ned_m: None,
                trim: None,
                references: heli_nav::GroundReferences::default(),
                roll: None,
                ..sample().warm
            },
            unix_times: false,
            ..sample()
        };
        assert_eq!(WarmFile::parse(&bare.to_text()).ok(), Some(bare));
        remove(&path).unwrap();
        remove(&path).unwrap();
        assert_eq!(WarmFile::read(&path).ok(), Some(None));
    }

    #[test]
    fn a_damaged_file_is_an_error_naming_the_line() {
        for (text, expect) in [
            ("start = a manual\nairborne = maybe\n", "line 2: airborne"),
            (
                "start = a manual\ngyro_bias_rps = 1 2\n",
                "line 2: gyro_bias_rps needs 3",
            ),
            (
                "start = a manual\ngyro_bias_rps = 1 nan 2\n",
                "line 2: gyro_bias_rps needs 3",
            ),
            ("start = a manual\nwhat\n", "line 2: 'what'"),
            ("start = a manual\ncolour = 3\n", "unknown key 'colour'"),
            (
                "airborne = true\ngyro_bias_rps = 0 0 0\n",
                "no 'start' line",
            ),
            ("start = a loop\n", "line 1: start: "),
            ("start = a manual\nroll = 1 2 3\n", "line 2: roll needs 13"),
            (
                "start = a manual\nroll_at_us = soon\n",
                "line 2: roll_at_us",
            ),
            ("start = a manual\nclock = local\n", "line 2: clock 'local'"),
        ] {
            let e = WarmFile::parse(text).unwrap_err().to_string();
            assert!(e.contains(expect), "{text:?}: {e}");
        }
    }

    #[test]
    fn a_missing_record_is_none_and_removing_it_is_no_error_but_others_are() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("warm-start");
        assert_eq!(WarmFile::read(&path).ok(), Some(None));
        assert!(remove(&path).is_ok());
        // A directory where the file should be: neither read nor removed.
        std::fs::create_dir(&path).unwrap();
        assert!(WarmFile::read(&path).is_err());
        assert!(remove(&path).is_err());
    }
}
