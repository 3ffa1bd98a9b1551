//! The aileron-roll maneuver's stage machine: accelerate to trim speed, pull up, roll,
//! recover, as many rolls as the plan asks for.
//!
//! A component without memory of its own: the stage travels in the phase
//! ([`Phase::Maneuver`]); one step takes the stage, the estimate and the plan's leg, and
//! says what comes next — the maneuver's next phase, or the next leg — and the roll it
//! finished or gave up, if any.

use heli_control::{RollGains, Target};
use heli_nav::{NavState, seconds_between};
use heli_types::Leg;
use nalgebra::Vector3;

use super::ACCELERATE_TIMEOUT_S;
use super::brake::BRAKE_DECEL_MPS2;
use crate::phase::{Phase, RollStage};

/// How fast the run-up's trajectory speeds up to the trim speed (m/s²): the hold's braking
/// rate the other way. A trajectory at the trim speed from the start left the helicopter
/// behind its point: it pitched down 30° to catch up, overshot the trim by half (12 m/s for
/// 8), and was still pitching back (10–18° nose up) when the pull-up began.
pub const RUN_UP_ACCEL_MPS2: f64 = BRAKE_DECEL_MPS2;

/// How long the run-up holds the trim speed, at the least, before the pull-up (s): the
/// helicopter settles on the trim it rolls from.
pub const RUN_UP_SETTLE_S: f64 = 3.0;

/// A roll that ended in this step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RollEnd {
    /// Turned all the way round.
    Completed,
    /// Took more than twice its nominal time: given up.
    Abandoned,
}

/// What comes after one step of the maneuver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RollStep {
    /// The maneuver goes on in this phase.
    Fly(Phase),
    /// The maneuver is over (or no rolls are planned): the plan's next leg, started from
    /// this phase's target when one is given.
    NextLeg(Option<Phase>),
}

/// The angle turned after `dt_s` more at the body roll rate `roll_rate_rps`, counted in the
/// commanded direction, and how the roll ends there, if it does: turned all the way round
/// less the exit lead, or given up after twice its nominal time.
fn turn(
    g: &RollGains,
    angle_rad: f64,
    roll_rate_rps: f64,
    since_us: u64,
    now_us: u64,
    dt_s: f64,
) -> (f64, Option<RollEnd>) {
    let angle_rad = angle_rad + roll_rate_rps * g.rate_cmd_rps.signum() * dt_s;
    let nominal_s = 2.0 * core::f64::consts::PI / g.rate_cmd_rps.abs().max(0.5);
    let end = if angle_rad >= 2.0 * core::f64::consts::PI - g.exit_lead_rad {
        Some(RollEnd::Completed)
    } else if seconds_between(since_us, now_us) > 2.0 * nominal_s {
        Some(RollEnd::Abandoned)
    } else {
        None
    };
    (angle_rad, end)
}

/// How a roll the estimate is gone from goes on ([`blind_step`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BlindRoll {
    /// Still rolling, in this stage.
    Rolling(RollStage),
    /// Stopped where it was, less than a quarter of the way round: the cyclic is levelled.
    Stopped,
    /// Turned all the way round (or given up after twice its nominal time): levelled.
    Finished,
}

/// A roll is stopped blind, rather than finished, when it is less than this far round
/// (rad): nearer upright that way, where the rest of a roll flown open loop would tumble.
pub const BLIND_STOP_BEFORE_RAD: f64 = core::f64::consts::FRAC_PI_2;

/// One step of a roll the estimate is gone from (the IMU fell silent in it, or the process
/// was restarted in it). Less than a quarter of the way round with the IMU silent it is
/// stopped at once; further round, or on the gyros, it is finished rather than
/// left on its side or inverted with no attitude to recover by. The angle turned goes on at
/// the body roll rate the gyro measures (`roll_rate_rps`, a real sample less the known
/// bias) or, while the IMU is silent, at the commanded rate that the roll's feedforward flies
/// open loop.
pub fn blind_step(
    g: &RollGains,
    stage: RollStage,
    roll_rate_rps: Option<f64>,
    now_us: u64,
    dt_s: f64,
) -> BlindRoll {
    let RollStage::Rolling {
        angle_rad,
        since_us,
    } = stage
    else {
        return BlindRoll::Stopped;
    };
    // Stopped only while the IMU is silent: with the gyros (a real sample — the IMU back,
    // or a process restarted in the roll) the roll law has what it flies on, the rate and
    // the angle turned, and finishing leaves the helicopter upright, where stopping would
    // leave it on its side with nothing to right it.
    if angle_rad < BLIND_STOP_BEFORE_RAD && roll_rate_rps.is_none() {
        return BlindRoll::Stopped;
    }
    let rate_rps = roll_rate_rps.unwrap_or(g.rate_cmd_rps);
    match turn(g, angle_rad, rate_rps, since_us, now_us, dt_s) {
        (_, Some(_)) => BlindRoll::Finished,
        (angle_rad, None) => BlindRoll::Rolling(RollStage::Rolling {
            angle_rad,
            since_us,
        }),
    }
}

/// The angle turned, in the commanded direction, while a roll went unseen for `unseen_s`
/// on the command the servo board held: the body rate went from `rate_then_rps` (the last
/// one recorded) to `rate_now_rps` (the first sample after) as a first-order response with
/// the time constant [`RollGains::rate_response_s`], so that it was near its new value for
/// most of the time.
pub fn turned_unseen(g: &RollGains, rate_then_rps: f64, rate_now_rps: f64, unseen_s: f64) -> f64 {
    let sign = g.rate_cmd_rps.signum();
    let (then, now) = (rate_then_rps * sign, rate_now_rps * sign);
    let tau = g.rate_response_s.max(1e-3);
    now * unseen_s - (now - then) * tau * (1.0 - (-unseen_s / tau).exp())
}

/// The trajectory's point `target_ned_m` brought to within `lead_m` of the helicopter at
/// `pos_ned_m`, horizontally, along the line between them; its height is kept. A position
/// that is not a number leaves the point where it is (carried into the next step, a point
/// made of it would stay NaN after the estimate came back).
fn within_lead(target_ned_m: Vector3<f64>, pos_ned_m: Vector3<f64>, lead_m: f64) -> Vector3<f64> {
    let ahead = target_ned_m - pos_ned_m;
    let ahead_m = ahead.xy().norm();
    if !ahead_m.is_finite() || ahead_m <= lead_m.max(0.0) {
        return target_ned_m;
    }
    let kept = pos_ned_m.xy() + ahead.xy() * (lead_m.max(0.0) / ahead_m);
    Vector3::new(kept.x, kept.y, target_ned_m.z)
}

/// The run-up of a rolls leg just begun (`phase`, from [`super::legs::begin`]), its
/// trajectory's speed along the heading set to the helicopter's (none backwards, none past
/// the trim speed): begun at rest it would brake a helicopter still moving — a rolls leg
/// after another, or after a hold too short to stop in — and speed it up again. Any other
/// phase is returned as it is.
pub fn run_up_from(phase: Phase, leg: Option<Leg>, est: &NavState) -> Phase {
    let (
        Phase::Maneuver {
            mut target,
            stage: stage @ RollStage::Accelerate { .. },
            rolls_done,
        },
        Some(Leg::Rolls { speed_mps, .. }),
    ) = (phase, leg)
    else {
        return phase;
    };
    let dir = Vector3::new(target.yaw_rad.cos(), target.yaw_rad.sin(), 0.0);
    let along_mps = est.vel_ned_mps.dot(&dir);
    target.vel_ned_mps = if along_mps.is_finite() {
        dir * along_mps.clamp(0.0, speed_mps.max(0.0))
    } else {
        Vector3::zeros()
    };
    Phase::Maneuver {
        target,
        stage,
        rolls_done,
    }
}

/// One step of the roll maneuver on the leg being flown (`leg`), from `stage` with
/// `rolls_done` rolls behind it.
#[allow(clippy::too_many_arguments)]
pub fn step(
    g: &RollGains,
    leg: Option<Leg>,
    est: &NavState,
    now_us: u64,
    dt_s: f64,
    target: Target,
    stage: RollStage,
    rolls_done: u32,
) -> (RollStep, Option<RollEnd>) {
    let Some(Leg::Rolls { count, speed_mps }) = leg else {
        return (RollStep::NextLeg(None), None);
    };
    let dir = Vector3::new(target.yaw_rad.cos(), target.yaw_rad.sin(), 0.0);
    let trim_vel = dir * speed_mps;
    // The trim trajectory: straight and level at the trim speed, carried along.
    let carried = Target {
        pos_ned_m: target.pos_ned_m + target.vel_ned_mps * dt_s,
        ..target
    };
    // The run-up's trajectory speeds up from where it is to the trim at a steady rate.
    let run_up_vel = {
        let to_go = trim_vel - target.vel_ned_mps;
        let step_mps = RUN_UP_ACCEL_MPS2 * dt_s.max(0.0);
        if to_go.norm() <= step_mps {
            trim_vel
        } else {
            target.vel_ned_mps + to_go.normalize() * step_mps
        }
    };
    let stage = match stage {
        RollStage::Accelerate { since_us } => {
            let settled = (est.vel_ned_mps - trim_vel).norm() < 1.0;
            let elapsed = seconds_between(since_us, now_us);
            // The trajectory's ramp (from rest at the longest), then the settling at the trim
            // speed; the wait for it to settle is counted from the ramp's end.
            let ramp_s = speed_mps / RUN_UP_ACCEL_MPS2;
            let run_up_s = (ramp_s + RUN_UP_SETTLE_S).max(6.0);
            if settled && run_up_vel == trim_vel && elapsed > run_up_s {
                RollStage::PullUp { since_us: now_us }
            } else if elapsed > ramp_s + ACCELERATE_TIMEOUT_S {
                // Never settled on the trim (a headwind, a weak rotor): no rolls today.
                let phase = Phase::Maneuver {
                    target: carried,
                    stage,
                    rolls_done,
                };
                return (RollStep::NextLeg(Some(phase)), None);
            } else {
                stage
            }
        }
        RollStage::PullUp { since_us } => {
            if seconds_between(since_us, now_us) >= g.pull_up_s {
                RollStage::Rolling {
                    angle_rad: 0.0,
                    since_us: now_us,
                }
            } else {
                stage
            }
        }
        RollStage::Rolling {
            angle_rad,
            since_us,
        } => {
            // Turned in the commanded direction; a roll that takes more than twice its
            // nominal time is given up and the trim controller takes over.
            let (angle_rad, end) = turn(g, angle_rad, est.rate_body_rps.x, since_us, now_us, dt_s);
            if let Some(end) = end {
                // Back on the trim trajectory from here, at this height.
                let target = Target {
                    pos_ned_m: est.pos_ned_m,
                    vel_ned_mps: trim_vel,
                    ..target
                };
                let phase = Phase::Maneuver {
                    target,
                    stage: RollStage::Recover { since_us: now_us },
                    rolls_done: rolls_done.saturating_add(1),
                };
                return (RollStep::Fly(phase), Some(end));
            }
            RollStage::Rolling {
                angle_rad,
                since_us,
            }
        }
        RollStage::Recover { since_us } => {
            if seconds_between(since_us, now_us) < g.recover_s {
                stage
            } else if rolls_done < count {
                RollStage::PullUp { since_us: now_us }
            } else {
                let phase = Phase::Maneuver {
                    target: carried,
                    stage,
                    rolls_done,
                };
                return (RollStep::NextLeg(Some(phase)), None);
            }
        }
    };
    let vel_ned_mps = match stage {
        RollStage::PullUp { .. } => trim_vel + Vector3::new(0.0, 0.0, -g.pull_up_climb_mps),
        RollStage::Accelerate { .. } => run_up_vel,
        _ => trim_vel,
    };
    let mut target = Target {
        vel_ned_mps,
        ..carried
    };
    match stage {
        // While rolling the trajectory only keeps up with the helicopter.
        RollStage::Rolling { .. } => target.pos_ned_m = est.pos_ned_m,
        // Recovering, the trajectory's point is kept within the recovery's lead of the
        // helicopter, at its own height. A roll ends with the point on the helicopter, but
        // the helicopter well below the trim speed and drifting with the air; the point,
        // carried at the trim velocity, runs ahead. Beyond the lead that distance is given
        // up (the line moves with the helicopter); within it, it is made up at no more than
        // the hover's position gain times the lead. (In 8 m/s of crosswind the point ran
        // 5 m ahead and 6 m upwind within a second; chased, the speed overshot the trim by
        // 3 m/s, and the next roll began that far out of trim. Kept at the helicopter, with
        // no lead at all, the velocity's own error was never made up: 1.2 m/s fast after
        // each roll in calm air.)
        RollStage::Recover { .. } => {
            target.pos_ned_m = within_lead(target.pos_ned_m, est.pos_ned_m, g.recover_lead_m);
        }
        _ => {}
    }
    (
        RollStep::Fly(Phase::Maneuver {
            target,
            stage,
            rolls_done,
        }),
        None,
    )
}
