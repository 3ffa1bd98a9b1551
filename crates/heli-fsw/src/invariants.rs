//! The main control process's invariants, stated and checked (the role Daikon played in the
//! thesis's chapter 3: what the code relies on, written down so that a run can be checked
//! against it).
//!
//! [`Invariants`] watches a [`FlightCore`] from outside: after every input the caller hands
//! it the core and the actions that input produced, and it returns the first rule broken.
//! It keeps only what it needs to judge a step against the one before (the last phase, the
//! counters, each stream's last time stamp), so it costs a few comparisons and a pass over
//! the covariance per input. The lockstep simulator checks every scenario
//! run with it; the property tests (`tests/invariants.rs`) drive the core with arbitrary
//! input sequences and check every step.
//!
//! This module is not a monitor that flies: a broken invariant is a defect in the flight
//! software, reported to whoever ran it, never acted on in flight.

use core::fmt;

use heli_nav::navigator::Covariance;
use heli_nav::{NavState, Navigator};
use heli_proto::scb::Controls;

use crate::core::{Action, CoreEvent, CoreStats, FlightCore};
use crate::phase::Phase;
use crate::streams::Record;

/// How far a quaternion's norm may stray from one.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-6;

/// How far the covariance may be from symmetric, relative to its largest diagonal entry.
pub const COVARIANCE_SYMMETRY_TOLERANCE: f64 = 1e-9;

/// One invariant broken, with what broke it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Violation {
    /// A servo command not finite, or outside its channel's range.
    ServoOutOfRange(Controls),
    /// An action stamped with another time than the input's.
    ActionTime {
        /// The input's time (µs).
        input_us: u64,
        /// The action's stamp (µs).
        action_us: u64,
    },
    /// A stream's record older than the last one published on it.
    StreamWentBack {
        /// The stream's name.
        stream: &'static str,
        /// The last record's time (µs).
        last_us: u64,
        /// This record's time (µs).
        now_us: u64,
    },
    /// A servo command without a control step, or a control step without one.
    ServoWithoutStep {
        /// Servo commands in the actions.
        servos: u32,
        /// Control steps the counters moved by.
        steps: u32,
    },
    /// A loop counter went down.
    CounterWentDown(&'static str),
    /// The estimate's attitude is not a unit quaternion.
    QuaternionNorm(f64),
    /// A value of the estimate is not finite.
    EstimateNotFinite,
    /// The covariance is not symmetric, has a diagonal entry that is not positive, or a
    /// correlation larger than one.
    Covariance {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
    },
    /// The loop watchdog's deadline is further away than its period, or the core does not
    /// ask to be woken by then, or an armed watchdog was disarmed.
    WatchdogUnbounded {
        /// The input's time (µs).
        now_us: u64,
        /// The deadline the core asked for (µs), `None` if it asked for none.
        poll_at_us: Option<u64>,
    },
    /// An estimate declared invalid became valid again without an alignment in the air.
    EstimateRevived,
    /// The phase changed without a `PhaseChanged` event, or an event named another phase.
    PhaseEventMismatch {
        /// The phase before the input.
        before: &'static str,
        /// The phase after it.
        after: &'static str,
    },
    /// A change of phase the flight logic never makes.
    IllegalTransition {
        /// The phase before.
        from: &'static str,
        /// The phase after.
        to: &'static str,
    },
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Violation::ServoOutOfRange(c) => write!(f, "servo command out of range: {c:?}"),
            Violation::ActionTime {
                input_us,
                action_us,
            } => write!(
                f,
                "action stamped {action_us} µs for an input at {input_us} µs"
            ),
            Violation::StreamWentBack {
                stream,
                last_us,
                now_us,
            } => write!(
                f,
                "{stream} stream went back from {last_us} µs to {now_us} µs"
            ),
            Violation::ServoWithoutStep { servos, steps } => write!(
                f,
                "{servos} servo commands for {steps} control steps in one input"
            ),
            Violation::CounterWentDown(name) => write!(f, "counter {name} went down"),
            Violation::QuaternionNorm(n) => write!(f, "attitude quaternion of norm {n}"),
            Violation::EstimateNotFinite => write!(f, "the estimate holds a value not finite"),
            Violation::Covariance { row, col } => {
                write!(f, "covariance not symmetric positive at ({row}, {col})")
            }
            Violation::WatchdogUnbounded { now_us, poll_at_us } => write!(
                f,
                "at {now_us} µs the next watchdog deadline is {poll_at_us:?}"
            ),
            Violation::EstimateRevived => write!(f, "an invalid estimate became valid again"),
            Violation::PhaseEventMismatch { before, after } => write!(
                f,
                "phase {before} -> {after} without its PhaseChanged event"
            ),
            Violation::IllegalTransition { from, to } => {
                write!(f, "illegal phase transition {from} -> {to}")
            }
        }
    }
}

/// What a checker found over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InvariantReport {
    /// Inputs checked.
    pub checked: u64,
    /// Inputs after which an invariant was broken.
    pub violations: u64,
    /// The first one, with the input's time (µs).
    pub first: Option<(u64, Violation)>,
}

impl InvariantReport {
    /// Counts one checked input and its verdict.
    pub fn record(&mut self, now_us: u64, verdict: Result<(), Violation>) {
        self.checked = self.checked.saturating_add(1);
        if let Err(v) = verdict {
            self.violations = self.violations.saturating_add(1);
            self.first.get_or_insert((now_us, v));
        }
    }

    /// Adds what another checker found (a flight process started again after it).
    pub fn merge(&mut self, other: &InvariantReport) {
        self.checked = self.checked.saturating_add(other.checked);
        self.violations = self.violations.saturating_add(other.violations);
        if self.first.is_none() {
            self.first = other.first;
        }
    }
}

/// The kinds of phase, for the transition rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Calibrating,
    Pilot,
    GroundFailsafe,
    PreflightCheck,
    TakeoffRefused,
    BlindDescent,
    TakingOff,
    Holding,
    Flying,
    Maneuver,
    Landing,
    Autorotation,
    Landed,
}

fn kind(phase: &Phase) -> Kind {
    match phase {
        Phase::Calibrating => Kind::Calibrating,
        Phase::Manual | Phase::Augmented(_) => Kind::Pilot,
        Phase::GroundFailsafe => Kind::GroundFailsafe,
        Phase::PreflightCheck { .. } => Kind::PreflightCheck,
        Phase::TakeoffRefused => Kind::TakeoffRefused,
        Phase::BlindDescent => Kind::BlindDescent,
        Phase::TakingOff { .. } => Kind::TakingOff,
        Phase::Holding { .. } => Kind::Holding,
        Phase::Flying { .. } => Kind::Flying,
        Phase::Maneuver { .. } => Kind::Maneuver,
        Phase::Landing { .. } => Kind::Landing,
        Phase::Autorotation { .. } => Kind::Autorotation,
        Phase::Landed => Kind::Landed,
    }
}

/// Whether the flight logic may go from `from` to `to` in one control step (`engine_failed`:
/// the engine failure was raised before this step; `refused`: a refused take-off stands, the
/// pilot's switch not taken off since).
///
/// The rules, each what some part of the core relies on:
/// - the ground calibration happens once: nothing goes back to calibrating;
/// - a roll sequence starts only from autonomous flight with a target (a climb, a hold or a
///   path), never from the ground or from the pilot;
/// - the take-off is refused only after its pre-flight check (or, a refusal standing, again
///   after the ground failsafe that interrupted it, or at the end of the calibration of a
///   process started again on the ground with the switch on);
/// - a standing refusal is neither checked again nor taken off from: only the pilot's
///   switch, off (the pilot's phase) and on, asks again;
/// - landed follows a landing, an autorotation, or a phase on the ground whose plan is done,
///   never straight from autonomous flight in the air;
/// - autorotation follows the engine failure, and after it the engine is never flown on
///   again: no climb, hold, path, roll, powered landing or pre-flight check;
/// - a take-off never starts from landed, an autorotation or a refusal.
fn legal(from: Kind, to: Kind, engine_failed: bool, refused: bool) -> bool {
    use Kind::*;
    if from == to {
        return true;
    }
    if refused && matches!(to, PreflightCheck | TakingOff) {
        return false;
    }
    if engine_failed
        && matches!(
            to,
            TakingOff | Holding | Flying | Maneuver | Landing | PreflightCheck
        )
    {
        return false;
    }
    match to {
        Calibrating => false,
        Maneuver => matches!(from, TakingOff | Holding | Flying),
        TakeoffRefused => {
            from == PreflightCheck || (refused && matches!(from, GroundFailsafe | Calibrating))
        }
        Landed => matches!(
            from,
            Landing | Autorotation | Calibrating | Pilot | GroundFailsafe | BlindDescent
        ),
        Autorotation => engine_failed,
        TakingOff => !matches!(from, Landed | Autorotation | TakeoffRefused),
        Pilot | GroundFailsafe | PreflightCheck | BlindDescent | Holding | Flying | Landing => true,
    }
}

fn servo_in_range(c: &Controls) -> bool {
    let unit = |v: f64| v.is_finite() && (-1.0..=1.0).contains(&v);
    unit(c.aileron)
        && unit(c.elevator)
        && unit(c.rudder)
        && unit(c.collective)
        && c.throttle.is_finite()
        && (0.0..=1.0).contains(&c.throttle)
}

fn record_stream(record: &Record) -> (usize, &'static str, u64) {
    match record {
        Record::Imu(r) => (0, "imu", r.t_us),
        Record::State(r) => (1, "state", r.t_us),
        Record::Servo(r) => (2, "servo", r.t_us),
        Record::Uplink(r) => (3, "uplink", r.t_us),
        Record::Gps(r) => (4, "gps", r.t_us),
        Record::Baro(r) => (5, "baro", r.t_us),
        Record::Compass(r) => (6, "compass", r.t_us),
    }
}

fn counters_went_down(before: &CoreStats, after: &CoreStats) -> Option<&'static str> {
    let pairs = [
        ("imu_samples", before.imu_samples, after.imu_samples),
        (
            "watchdog_fires",
            before.watchdog_fires,
            after.watchdog_fires,
        ),
        ("control_steps", before.control_steps, after.control_steps),
        ("uplinks", before.uplinks, after.uplinks),
        ("gps_fixes", before.gps_fixes, after.gps_fixes),
        ("baro_readings", before.baro_readings, after.baro_readings),
        (
            "compass_readings",
            before.compass_readings,
            after.compass_readings,
        ),
        (
            "rejected_inputs",
            before.rejected_inputs,
            after.rejected_inputs,
        ),
        (
            "gps_implausible",
            before.gps_implausible,
            after.gps_implausible,
        ),
        (
            "rolls_completed",
            before.rolls_completed,
            after.rolls_completed,
        ),
    ];
    pairs
        .into_iter()
        .find(|(_, b, a)| a < b)
        .map(|(name, _, _)| name)
}

/// The checker: feed it every input's actions and the core after it.
#[derive(Clone, Debug)]
pub struct Invariants {
    watchdog_us: u64,
    phase: Phase,
    stats: CoreStats,
    estimate_valid: bool,
    engine_failed: bool,
    /// A refused take-off stands: refused since the pilot last had the helicopter.
    refusal_standing: bool,
    /// Each stream's last record time (µs).
    stream_us: [Option<u64>; 7],
    /// The watchdog has been armed (the core started, or heard the IMU).
    armed: bool,
    /// The latest input time seen (µs): an input from the past is refused, and the
    /// watchdog's deadline stays where the latest one put it.
    latest_us: u64,
    checked: u64,
}

impl Invariants {
    /// A checker for `core` as it is now (before its first input).
    pub fn new(core: &FlightCore, watchdog_us: u64) -> Self {
        Self {
            watchdog_us,
            phase: core.phase(),
            stats: core.stats(),
            estimate_valid: core.estimate_valid(),
            engine_failed: false,
            refusal_standing: core.phase() == Phase::TakeoffRefused,
            stream_us: [None; 7],
            armed: core.watchdog_deadline_us().is_some(),
            // Started: the start's time is a period before the first deadline.
            latest_us: core
                .watchdog_deadline_us()
                .map_or(0, |t| t.saturating_sub(watchdog_us)),
            checked: 0,
        }
    }

    /// Inputs checked so far.
    pub fn checked(&self) -> u64 {
        self.checked
    }

    /// Checks the step the core just took on an input at `now_us` that produced `actions`.
    /// The checker moves on to the new state whatever the verdict, so one defect is reported
    /// once.
    pub fn check(
        &mut self,
        core: &FlightCore,
        now_us: u64,
        actions: &[Action],
    ) -> Result<(), Violation> {
        self.checked = self.checked.saturating_add(1);
        let before = (self.phase, self.stats, self.estimate_valid);
        let stats = core.stats();
        // The engine failure raised before this input, or by it.
        let mut engine_failed = self.engine_failed;
        let mut refused_now = false;
        let mut aligned_in_air = false;
        let mut phase_events = Vec::new();
        let mut result = Ok(());
        let mut servos = 0u32;
        for action in actions {
            let (t_us, verdict) = match action {
                Action::Servo(s) => {
                    servos = servos.saturating_add(1);
                    let ok = servo_in_range(&s.value);
                    (s.t_us, (!ok).then_some(Violation::ServoOutOfRange(s.value)))
                }
                Action::Publish(record) => {
                    let (i, stream, t_us) = record_stream(record);
                    let verdict = self.stream_record(i, stream, t_us);
                    (t_us, verdict)
                }
                Action::Event(e) => {
                    match e.value {
                        CoreEvent::PhaseChanged(p) => phase_events.push(p),
                        CoreEvent::EngineFailure { .. } => engine_failed = true,
                        CoreEvent::TakeoffRefused(_) => refused_now = true,
                        CoreEvent::AlignedInAir { .. } => aligned_in_air = true,
                        _ => {}
                    }
                    (e.t_us, None)
                }
            };
            let verdict = verdict.or_else(|| {
                (t_us != now_us).then_some(Violation::ActionTime {
                    input_us: now_us,
                    action_us: t_us,
                })
            });
            if let (Ok(()), Some(v)) = (&result, verdict) {
                result = Err(v);
            }
        }
        let after = core.phase();
        let steps = stats.control_steps.saturating_sub(before.1.control_steps);
        let mut judge = || -> Result<(), Violation> {
            result?;
            if let Some(name) = counters_went_down(&before.1, &stats) {
                return Err(Violation::CounterWentDown(name));
            }
            if servos != steps {
                return Err(Violation::ServoWithoutStep { servos, steps });
            }
            check_phase_events(&before.0, &after, &phase_events)?;
            if !legal(
                kind(&before.0),
                kind(&after),
                engine_failed,
                self.refusal_standing || refused_now,
            ) {
                return Err(Violation::IllegalTransition {
                    from: before.0.name(),
                    to: after.name(),
                });
            }
            // Only an alignment in the air (after the IMU came back) starts it again.
            if !before.2 && core.estimate_valid() && !aligned_in_air {
                return Err(Violation::EstimateRevived);
            }
            self.check_watchdog(core, now_us)?;
            check_estimate(core.navigator())
        };
        let result = judge();
        self.phase = after;
        // Raised, a refusal stands until the pilot has the helicopter (the switch off).
        self.refusal_standing =
            kind(&after) != Kind::Pilot && (self.refusal_standing || refused_now);
        self.stats = stats;
        self.estimate_valid = core.estimate_valid();
        self.engine_failed = engine_failed;
        result
    }

    fn stream_record(&mut self, i: usize, stream: &'static str, t_us: u64) -> Option<Violation> {
        let slot = self.stream_us.get_mut(i)?;
        let verdict = match *slot {
            Some(last_us) if t_us < last_us => Some(Violation::StreamWentBack {
                stream,
                last_us,
                now_us: t_us,
            }),
            _ => None,
        };
        *slot = Some(t_us);
        verdict
    }

    fn check_watchdog(&mut self, core: &FlightCore, now_us: u64) -> Result<(), Violation> {
        self.latest_us = self.latest_us.max(now_us);
        let deadline_us = core.watchdog_deadline_us();
        let poll_at_us = core.poll_at();
        self.armed |= deadline_us.is_some();
        let bounded = match deadline_us {
            // Never further than one period, and the caller is asked to come by then.
            Some(t) => {
                t <= self.latest_us.saturating_add(self.watchdog_us)
                    && poll_at_us.is_some_and(|p| p <= t)
            }
            None => !self.armed,
        };
        if bounded {
            Ok(())
        } else {
            Err(Violation::WatchdogUnbounded { now_us, poll_at_us })
        }
    }
}

fn check_phase_events(before: &Phase, after: &Phase, events: &[Phase]) -> Result<(), Violation> {
    let mismatch = Violation::PhaseEventMismatch {
        before: before.name(),
        after: after.name(),
    };
    let changed = kind(before) != kind(after) || before.name() != after.name();
    match events {
        [] if !changed => Ok(()),
        [p] if changed && p == after => Ok(()),
        _ => Err(mismatch),
    }
}

fn check_estimate(nav: &Navigator) -> Result<(), Violation> {
    match nav.state() {
        Some(state) => check_state(state, nav.covariance()),
        None => Ok(()),
    }
}

/// A quaternion norm within [`QUATERNION_NORM_TOLERANCE`] of one (never a NaN or an
/// infinity: the comparison is false for both).
fn unit_norm(norm: f64) -> bool {
    (norm - 1.0).abs() <= QUATERNION_NORM_TOLERANCE
}

/// The estimate's own invariants: a unit quaternion, finite values, and a covariance that
/// is symmetric with positive variances and correlations of at most one.
pub fn check_state(state: &NavState, p: &Covariance) -> Result<(), Violation> {
    let norm = state.att.quaternion().norm();
    if !unit_norm(norm) {
        return Err(Violation::QuaternionNorm(norm));
    }
    let vectors = [
        &state.vel_ned_mps,
        &state.pos_ned_m,
        &state.rate_body_rps,
        &state.accel_body_mps2,
        &state.gyro_bias_rps,
        &state.accel_bias_mps2,
    ];
    if !vectors.iter().all(|v| v.iter().all(|x| x.is_finite())) {
        return Err(Violation::EstimateNotFinite);
    }
    let n = p.nrows();
    let scale = p.diagonal().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let symmetric_tol = COVARIANCE_SYMMETRY_TOLERANCE * scale.max(f64::MIN_POSITIVE);
    if let Some(row) = (0..n).find(|&i| !p.get((i, i)).is_some_and(|v| v.is_finite() && *v > 0.0)) {
        return Err(Violation::Covariance { row, col: row });
    }
    for row in 0..n {
        let pii = p.get((row, row)).copied().unwrap_or(f64::NAN);
        for col in row.saturating_add(1)..n {
            let (Some(&pij), Some(&pji), Some(&pjj)) =
                (p.get((row, col)), p.get((col, row)), p.get((col, col)))
            else {
                return Err(Violation::Covariance { row, col });
            };
            let symmetric = (pij - pji).abs() <= symmetric_tol;
            // A correlation of at most one: necessary for a positive semi-definite matrix.
            let bounded = pij.is_finite() && pij * pij <= pii * pjj * (1.0 + 1e-9);
            if !(symmetric && bounded) {
                return Err(Violation::Covariance { row, col });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
