//! A flight process started again in a roll (a brown-out of the flight computer as a roll
//! begins): the servo board held the last command, full lateral cyclic, for as long as
//! nobody was there, so the helicopter kept rolling unseen. Aligning on it at once would
//! level a rolling helicopter by accelerometers that measure the rotor's thrust, not
//! gravity. Instead the new process carries the roll on from the record its predecessor
//! left ([`RollRecord`], rewritten through a roll): the angle turned while unseen is
//! reckoned from the recorded rate, the first sample's rate and the time between
//! ([`roll::turned_unseen`]); the roll is then finished or stopped on the gyros as after an
//! IMU stall in a roll ([`roll::blind_step`]), and only then does the process align in the
//! air from the record. A record older than the board's hold ([`ROLL_UNSEEN_MAX_S`]) says
//! nothing of where the roll went: the process aligns at once, as after any restart.

use heli_control::Target;
use heli_nav::seconds_between;
use heli_proto::imu::ImuRepr;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::restart::{ROLL_UNSEEN_MAX_S, Restart, RollRecord, WarmStart};
use super::roll;
use super::{Action, CoreEvent, FlightCore, Stamped};
use crate::phase::{Phase, RollStage};

/// `t_us` on a signed clock (a record's time may be before the clock began).
fn signed(t_us: u64) -> i64 {
    i64::try_from(t_us).unwrap_or(i64::MAX)
}

impl FlightCore {
    /// Sets a core restarted from `warm` up to go on with the roll `roll` recorded in it.
    pub(super) fn restart_in_roll(&mut self, warm: WarmStart, roll: RollRecord) {
        self.restart = Restart::in_roll(warm, roll);
        // No estimate until the roll is over and the alignment done.
        self.main_loop.invalidate();
        let elapsed_us = signed(heli_nav::calibration::seconds_to_us(roll.elapsed_s));
        let began_us = roll.at_us.saturating_sub(elapsed_us).max(0);
        self.seq.phase = Phase::Maneuver {
            target: Target::hold(Vector3::from(roll.pos_ned_m), roll.yaw_rad),
            stage: RollStage::Rolling {
                angle_rad: roll.angle_rad,
                since_us: u64::try_from(began_us).unwrap_or(0),
            },
            rolls_done: roll.rolls_done,
        };
    }

    /// The first real sample of a process restarted in a roll: the angle turned unseen is
    /// added, or, unseen for too long, the roll is given up and the alignment begins now.
    pub(super) fn resume_unseen_roll(
        &mut self,
        sample: &ImuRepr,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        let Some(roll) = self.restart.take_unseen_roll() else {
            return;
        };
        let unseen_s = signed(now_us).saturating_sub(roll.at_us) as f64 * 1e-6;
        let bias = Vector3::from(self.restart.waiting_bias_rps().unwrap_or([0.0; 3]));
        let rate_now = Vector3::from(sample.rate_rps) - bias;
        let rate_then = Vector3::from(roll.rate_rps);
        let known = (0.0..=ROLL_UNSEEN_MAX_S).contains(&unseen_s);
        let turned_rad = match (known, self.seq.phase) {
            (
                true,
                Phase::Maneuver {
                    target,
                    stage:
                        RollStage::Rolling {
                            angle_rad,
                            since_us,
                        },
                    rolls_done,
                },
            ) => {
                let g = &self.config.roll;
                let turned = roll::turned_unseen(g, rate_then.x, rate_now.x, unseen_s);
                // The attitude, carried over the unseen time: the roll as reckoned, pitch and
                // yaw at the mean of the rates recorded and measured now.
                let mean = (rate_then + rate_now) * (0.5 * unseen_s);
                let turn = Vector3::new(turned * g.rate_cmd_rps.signum(), mean.y, mean.z);
                let [w, i, j, k] = roll.att;
                let att = UnitQuaternion::from_quaternion(Quaternion::new(w, i, j, k))
                    * UnitQuaternion::from_scaled_axis(turn);
                self.restart.carry_from(att, now_us);
                self.seq.phase = Phase::Maneuver {
                    target,
                    stage: RollStage::Rolling {
                        angle_rad: angle_rad + turned,
                        since_us,
                    },
                    rolls_done,
                };
                Some(angle_rad + turned)
            }
            _ => {
                self.seq.phase = Phase::BlindDescent;
                self.restart.align_after_roll();
                None
            }
        };
        out.push(Action::Event(Stamped::new(
            now_us,
            CoreEvent::RestartedInRoll {
                angle_rad: turned_rad,
                unseen_s,
            },
        )));
    }

    /// A real sample while a restart in a roll waits for its end: the carried attitude, if
    /// there is one, turns with it.
    pub(super) fn carry_through_roll(&mut self, sample: &ImuRepr, now_us: u64) {
        self.restart.carry(sample, now_us);
    }

    /// The roll under way, as a successor would need it, if one is.
    pub(super) fn roll_record(&self, pos_ned_m: &Vector3<f64>) -> Option<RollRecord> {
        // A roll flown blind (the estimate declared invalid) has no attitude to hand on.
        if !self.main_loop.estimate_valid() {
            return None;
        }
        let Phase::Maneuver {
            target,
            stage:
                RollStage::Rolling {
                    angle_rad,
                    since_us,
                },
            rolls_done,
        } = self.seq.phase
        else {
            return None;
        };
        // The angle is that of the last control step, at the rates measured then.
        let at_us = self.main_loop.last_step_us()?;
        let rate = self.gyro_rps?;
        let att = self.nav.state()?.att;
        Some(RollRecord {
            at_us: signed(at_us),
            angle_rad,
            rate_rps: [rate.x, rate.y, rate.z],
            att: [att.w, att.i, att.j, att.k],
            elapsed_s: seconds_between(since_us, at_us),
            rolls_done,
            pos_ned_m: [pos_ned_m.x, pos_ned_m.y, pos_ned_m.z],
            yaw_rad: target.yaw_rad,
        })
    }
}
