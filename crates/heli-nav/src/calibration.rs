//! The thesis's IMU bias calibration: after the IMU has warmed up, an eighty-second window
//! of samples is averaged; when the window closes the mean gyro rates are the gyro biases,
//! and the mean specific force tells which way is down.
//!
//! The average must be of a still helicopter: a fuselage that turns on its skids while the
//! rotor spins up would be averaged in as bias, and the whole flight flown with it. Motion
//! is judged by the sensors that can see it — the gyros and the accelerometers — second by
//! second (blocks of [`BLOCK`] samples):
//!
//! - a second whose mean rate is more than [`MOTION_RATE_RPS`] from the window's (the
//!   median of its seconds: a turn cannot drag it) **moved**: it is left out of the average
//!   and the window is that much longer ([`BiasCalibration::take_left_out`] says so). A gust
//!   that turns or rocks the helicopter for a few seconds is calibrated through;
//! - the seconds kept may not add up to a turn: their rates' net rotation from the median
//!   beyond [`MOTION_TURN_RAD`] (a creep too slow for the one-second check, or the edges of
//!   turns) starts the window again;
//! - gravity's direction more than [`MOTION_TILT_RAD`] from the window's for
//!   [`TILTED_SECONDS`] seconds in a row (the helicopter now stands differently) starts it
//!   again, as does a window whose seconds moved more than they were still (and more than
//!   [`NEVER_STILL_SECONDS`]).
//!
//! The second before a motion and the one after it are left out with it: they hold the
//! turn's start and end, too little in a second's mean to be judged but enough, over many
//! gusts, to add up to a bias.
//!
//! A restart is said once by [`BiasCalibration::take_motion`]; nothing else starts the
//! window again.
//!
//! The warm-up, the window and its seconds are counted in IMU samples ([`SAMPLES_PER_S`] a
//! second), not read off the clock: the same samples give the same calibration however
//! they arrived. A window timed by the clock closed on whichever sample first came after
//! its end — a sample's jitter moved the close by one, left a part-second of one or two
//! samples whose noise alone looks like a tilt, and so made the window a second longer on
//! one run of a recorded flight and not on another (measured: a replay of a recorded flight
//! calibrated into the take-off it was fed). Samples the IMU did not deliver do not count:
//! a window with gaps lasts longer.

use heli_proto::imu::ImuRepr;
use nalgebra::Vector3;

/// Biases found by the calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuBiases {
    /// Gyro bias (rad/s), subtracted from every rate sample.
    pub gyro_rps: Vector3<f64>,
    /// Mean specific force over the window (m/s²), body axes: the helicopter sat still, so
    /// this is the reaction to gravity and gives the initial roll and pitch.
    pub mean_accel_mps2: Vector3<f64>,
    /// Number of samples averaged.
    pub samples: u32,
}

/// Where the calibration is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CalibrationPhase {
    /// Waiting for the first IMU sample.
    Waiting,
    /// The IMU is warming up.
    WarmingUp {
        /// Samples of warm-up still to come.
        samples_left: u32,
    },
    /// Accumulating samples.
    Accumulating {
        /// Samples the window still takes, more by each second left out.
        samples_left: u32,
    },
    /// Finished.
    Done(ImuBiases),
}

/// A second's mean rate this far from the window's median is motion, left out of the
/// average (rad/s): 3 deg/s — handling, a push, a turn on the skids; far above what the
/// IMU's noise and the rotor's vibration leave in a second's mean.
pub const MOTION_RATE_RPS: f64 = 0.05;

/// A second's mean direction of gravity this far from the window's is tilted (rad): 2 deg.
pub const MOTION_TILT_RAD: f64 = 0.035;

/// Seconds tilted in a row that mean the helicopter stands differently now: the window
/// starts again. Fewer are rocking, left out.
pub const TILTED_SECONDS: u32 = 3;

/// The net rotation of the seconds kept, from the window's median rate, that starts the
/// window again (rad): 5 deg, which averaged over the 80 s window would put 0.06 deg/s into
/// a gyro bias.
pub const MOTION_TURN_RAD: f64 = 0.087;

/// Seconds of a window that moved which, once more of them moved than were still, mean it
/// is never still (the median of its seconds is no longer a still one): the window starts
/// again.
pub const NEVER_STILL_SECONDS: usize = 10;

/// The most seconds a window's buffers are sized for at start-up (a window configured
/// longer grows them as it goes).
const MAX_ROOM_SECONDS: usize = 2000;

/// IMU samples in a second: the thesis's IMU speaks at 100 Hz.
pub const SAMPLES_PER_S: u32 = 100;

/// Samples in one block of the motion check (a second).
pub const BLOCK: u32 = SAMPLES_PER_S;

/// Motion seen during the calibration window, by the gyros and accelerometers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    /// How far a second's mean rate was from the window's (rad/s).
    pub rate_rps: f64,
    /// How far a second's direction of gravity was from the window's (rad).
    pub tilt_rad: f64,
    /// The net rotation of the seconds kept, from the window's median rate (rad).
    pub turn_rad: f64,
}

/// A second that moved, left out of the average.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeftOut {
    /// How the second moved.
    pub motion: Motion,
    /// Seconds left out of this window so far.
    pub seconds: u32,
}

/// One judged second of the window.
#[derive(Clone, Copy, Debug)]
struct Second {
    /// Its mean rate (rad/s).
    gyro: Vector3<f64>,
    /// Its samples' sums and count.
    gyro_sum: Vector3<f64>,
    accel_sum: Vector3<f64>,
    count: u32,
    kept: bool,
}

/// What became of a second.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Verdict {
    /// Kept in the average.
    Kept,
    /// Left out, with the second before it if that was kept (a turn's edge): the motion, if
    /// the second moved (none for the still edge after a turn), and how many samples longer
    /// the window is.
    LeftOut(Option<Motion>, u32),
    /// The window starts again.
    Restart(Motion),
}

/// The seconds of the window and the sums of those kept. Its buffers are taken once, at
/// start-up, and reused by every window ([`Window::clear`]).
#[derive(Clone, Debug, Default)]
struct Window {
    seconds: Vec<Second>,
    /// Scratch for the median, one axis at a time.
    axis: Vec<f64>,
    gyro_sum: Vector3<f64>,
    accel_sum: Vector3<f64>,
    count: u32,
    left_out: u32,
    /// Seconds that moved (left out, not counting the edges left out with them).
    moved: u32,
    tilted_run: u32,
    /// The last second moved: the next, still or not, is left out too (a turn's edge).
    after_motion: bool,
    /// How the last second that moved moved.
    last_motion: Motion,
}

impl Window {
    /// A window with room for `seconds` seconds before its buffers grow.
    fn with_capacity(seconds: usize) -> Self {
        Self {
            seconds: Vec::with_capacity(seconds),
            axis: Vec::with_capacity(seconds),
            ..Self::default()
        }
    }

    /// Empty again, keeping its buffers.
    fn clear(&mut self) {
        let mut seconds = std::mem::take(&mut self.seconds);
        let mut axis = std::mem::take(&mut self.axis);
        seconds.clear();
        axis.clear();
        *self = Self {
            seconds,
            axis,
            ..Self::default()
        };
    }

    fn kept(&self) -> impl Iterator<Item = &Second> {
        self.seconds.iter().filter(|s| s.kept)
    }

    /// The median of every second's mean rate, axis by axis.
    fn median_rate(&mut self) -> Vector3<f64> {
        let (seconds, axis) = (&self.seconds, &mut self.axis);
        Vector3::from_fn(|i, _| {
            axis.clear();
            axis.extend(seconds.iter().filter_map(|s| s.gyro.get(i).copied()));
            median(axis)
        })
    }

    /// Judges a finished second: kept (added to the sums), left out, or the window must start
    /// again.
    fn judge(&mut self, second: Second) -> Verdict {
        self.seconds.push(second);
        let median = self.median_rate();
        // The window's first second has nothing to be compared with; gravity's direction
        // is compared with the seconds kept, if any.
        let first = self.seconds.len() == 1;
        let rate_rps = (second.gyro - median).norm();
        let tilt_rad = if self.count == 0 {
            0.0
        } else {
            second.accel_sum.angle(&self.accel_sum)
        };
        let motion = Motion {
            rate_rps,
            tilt_rad,
            turn_rad: 0.0,
        };
        if beyond(tilt_rad, MOTION_TILT_RAD) {
            self.tilted_run = self.tilted_run.saturating_add(1);
            if self.tilted_run >= TILTED_SECONDS {
                return Verdict::Restart(motion);
            }
            return self.leave_out(Some(motion));
        }
        self.tilted_run = 0;
        if !first && beyond(rate_rps, MOTION_RATE_RPS) {
            return self.leave_out(Some(motion));
        }
        if self.after_motion {
            self.after_motion = false;
            return self.leave_out(None);
        }
        if let Some(last) = self.seconds.last_mut() {
            last.kept = true;
        }
        self.add(&second);
        let turn_rad = self
            .kept()
            .map(|s| s.gyro - median)
            .sum::<Vector3<f64>>()
            .norm();
        if beyond(turn_rad, MOTION_TURN_RAD) {
            return Verdict::Restart(Motion { turn_rad, ..motion });
        }
        Verdict::Kept
    }

    /// Adds a second's sums to the average.
    fn add(&mut self, second: &Second) {
        self.gyro_sum += second.gyro_sum;
        self.accel_sum += second.accel_sum;
        self.count = self.count.saturating_add(second.count);
    }

    /// Takes a second's sums out of the average.
    fn take_out(&mut self, second: &Second) {
        self.gyro_sum -= second.gyro_sum;
        self.accel_sum -= second.accel_sum;
        self.count = self.count.saturating_sub(second.count);
    }

    /// The last second left out (moved, or the still edge after a motion), with the kept
    /// second before a motion (its edge); the window starts again once more of its seconds
    /// moved than were still (and more than [`NEVER_STILL_SECONDS`]).
    fn leave_out(&mut self, motion: Option<Motion>) -> Verdict {
        let n = self.seconds.len();
        let mut longer = self.seconds.last().map_or(0, |s| s.count);
        self.left_out = self.left_out.saturating_add(1);
        if let Some(motion) = motion {
            self.moved = self.moved.saturating_add(1);
            self.last_motion = motion;
            self.after_motion = true;
            let before = n.checked_sub(2).and_then(|i| self.seconds.get(i));
            if let Some(edge) = before.filter(|s| s.kept).copied() {
                if let Some(s) = self.seconds.get_mut(n.saturating_sub(2)) {
                    s.kept = false;
                }
                self.take_out(&edge);
                self.left_out = self.left_out.saturating_add(1);
                longer = longer.saturating_add(edge.count);
            }
        }
        // The median's breakdown: more seconds moved than were still.
        let still = self.seconds.len().saturating_sub(self.moved as usize);
        if self.moved as usize > still.max(NEVER_STILL_SECONDS) {
            return Verdict::Restart(self.last_motion);
        }
        Verdict::LeftOut(motion, longer)
    }
}

/// The median of `values` (sorted in place; 0 for none).
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    let upper = values.get(n / 2).copied().unwrap_or(0.0);
    if n.is_multiple_of(2) {
        values
            .get((n / 2).saturating_sub(1))
            .map_or(upper, |lower| (lower + upper) / 2.0)
    } else {
        upper
    }
}

/// Whether a second moved by `value` is beyond the motion limit `limit`: a second exactly at
/// the limit is still.
fn beyond(value: f64, limit: f64) -> bool {
    value > limit
}

/// Accumulates IMU samples into bias estimates.
#[derive(Clone, Debug)]
pub struct BiasCalibration {
    warm_up_samples: u32,
    window_samples: u32,
    phase: CalibrationPhase,
    window: Window,
    block_gyro: Vector3<f64>,
    block_accel: Vector3<f64>,
    block_count: u32,
    motion: Option<Motion>,
    left_out: Option<LeftOut>,
    /// The last second judged moved: a run of them is said once.
    moving: bool,
    restarts: u32,
}

impl BiasCalibration {
    /// The thesis's window is 80 s; the warm-up is the IMU's (a few seconds). Both are
    /// counted in samples, [`SAMPLES_PER_S`] a second.
    pub fn new(warm_up_s: f64, window_s: f64) -> Self {
        Self {
            warm_up_samples: seconds_to_samples(warm_up_s),
            window_samples: seconds_to_samples(window_s),
            phase: CalibrationPhase::Waiting,
            // A window's seconds and those left out before it starts again: each second
            // that moved takes its two edges with it, and no more moved than were still.
            window: Window::with_capacity(
                usize::try_from(seconds_to_samples(window_s) / SAMPLES_PER_S)
                    .unwrap_or(0)
                    .saturating_mul(4)
                    .min(MAX_ROOM_SECONDS),
            ),
            block_gyro: Vector3::zeros(),
            block_accel: Vector3::zeros(),
            block_count: 0,
            motion: None,
            left_out: None,
            moving: false,
            restarts: 0,
        }
    }

    /// Motion that restarted the window since the last call (once).
    pub fn take_motion(&mut self) -> Option<Motion> {
        self.motion.take()
    }

    /// A second that moved and was left out, since the last call: the first of a run of
    /// them (once).
    pub fn take_left_out(&mut self) -> Option<LeftOut> {
        self.left_out.take()
    }

    /// Times the window was started again.
    pub fn restarts(&self) -> u32 {
        self.restarts
    }

    /// Seconds left out of the window now open.
    pub fn left_out_s(&self) -> u32 {
        self.window.left_out
    }

    /// Seconds of the window now open judged so far (kept or left out).
    pub fn seconds_judged(&self) -> usize {
        self.window.seconds.len()
    }

    /// Starts the window again with the next sample, throwing away what it had. Nothing
    /// happens before the window has opened or after it has closed.
    pub fn restart(&mut self, motion: Motion) {
        if let CalibrationPhase::Accumulating { .. } = self.phase {
            self.open();
            self.motion = Some(motion);
            self.restarts = self.restarts.saturating_add(1);
        }
    }

    fn open(&mut self) {
        self.phase = CalibrationPhase::Accumulating {
            samples_left: self.window_samples,
        };
        self.window.clear();
        self.block_gyro = Vector3::zeros();
        self.block_accel = Vector3::zeros();
        self.block_count = 0;
        self.moving = false;
    }

    /// Current phase.
    pub fn phase(&self) -> CalibrationPhase {
        self.phase
    }

    /// The biases, once the window has closed.
    pub fn biases(&self) -> Option<ImuBiases> {
        match self.phase {
            CalibrationPhase::Done(b) => Some(b),
            _ => None,
        }
    }

    /// Feeds one real IMU sample (the main loop's stand-ins for a late one are not
    /// samples). Returns the biases on the sample after the window's last (once), `None`
    /// otherwise: that sample is not in the window.
    pub fn push(&mut self, imu: &ImuRepr) -> Option<ImuBiases> {
        match self.phase {
            CalibrationPhase::Waiting => {
                // The first sample is the warm-up's first.
                self.phase = CalibrationPhase::WarmingUp {
                    samples_left: self.warm_up_samples.saturating_sub(1),
                };
                None
            }
            CalibrationPhase::WarmingUp { samples_left } => {
                if samples_left == 0 {
                    self.open();
                    self.block(imu);
                } else {
                    self.phase = CalibrationPhase::WarmingUp {
                        samples_left: samples_left.saturating_sub(1),
                    };
                }
                None
            }
            CalibrationPhase::Accumulating { samples_left } => {
                if samples_left > 0 {
                    self.block(imu);
                    return None;
                }
                let n = f64::from(self.window.count.max(1));
                let biases = ImuBiases {
                    gyro_rps: self.window.gyro_sum / n,
                    mean_accel_mps2: self.window.accel_sum / n,
                    samples: self.window.count,
                };
                self.phase = CalibrationPhase::Done(biases);
                Some(biases)
            }
            CalibrationPhase::Done(_) => None,
        }
    }

    /// Adds a sample to the current second's block, judging the block when it is full or
    /// the window's last sample is in (a window of a fractional number of seconds ends on
    /// a part-second, always the same one).
    fn block(&mut self, imu: &ImuRepr) {
        self.block_gyro += Vector3::from(imu.rate_rps);
        self.block_accel += Vector3::from(imu.accel_mps2);
        self.block_count = self.block_count.saturating_add(1);
        let last = match &mut self.phase {
            CalibrationPhase::Accumulating { samples_left } => {
                *samples_left = samples_left.saturating_sub(1);
                *samples_left == 0
            }
            _ => false,
        };
        if self.block_count >= BLOCK || last {
            self.end_block();
        }
    }

    /// Judges the block just ended: kept, left out (the window made as much longer), or the
    /// window started again.
    fn end_block(&mut self) {
        let count = self.block_count;
        let second = Second {
            gyro: self.block_gyro / f64::from(count.max(1)),
            gyro_sum: self.block_gyro,
            accel_sum: self.block_accel,
            count,
            kept: false,
        };
        self.block_gyro = Vector3::zeros();
        self.block_accel = Vector3::zeros();
        self.block_count = 0;
        match self.window.judge(second) {
            Verdict::Kept => self.moving = false,
            Verdict::LeftOut(motion, longer) => {
                if let CalibrationPhase::Accumulating { samples_left } = &mut self.phase {
                    *samples_left = samples_left.saturating_add(longer);
                }
                if let Some(motion) = motion {
                    if !self.moving {
                        self.left_out = Some(LeftOut {
                            motion,
                            seconds: self.window.left_out,
                        });
                    }
                    self.moving = true;
                }
            }
            Verdict::Restart(motion) => self.restart(motion),
        }
    }
}

/// Seconds to whole samples at [`SAMPLES_PER_S`], saturating (negative and NaN give 0).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub fn seconds_to_samples(s: f64) -> u32 {
    (s * f64::from(SAMPLES_PER_S)).round() as u32
}

/// Seconds to whole microseconds, saturating (negative and NaN give 0).
#[expect(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "`as` from a float saturates at the target type's limits and maps NaN to 0, which is what is wanted here"
)]
pub fn seconds_to_us(s: f64) -> u64 {
    (s * 1e6).round() as u64
}

#[cfg(test)]
mod tests;
