//! The mission sequencer: which phase comes next, from the pilot's switches, the
//! transmitter's state and the flight plan's legs.

use super::*;

/// A GPS fix fused this recently (s) lets the landing judge the horizontal speed too.
const GPS_FRESH_FOR_LANDING_S: f64 = 3.0;

impl FlightCore {
    pub(super) fn next_phase(
        &mut self,
        estimate: Option<&NavState>,
        now_us: u64,
        dt_s: f64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let pilot = self.pilot;
        // The board's line going silent is transmitter loss too.
        let signal_lost = self.uplink_lost || pilot.is_some_and(|p| p.signal_lost());
        let Some(est) = estimate else {
            if self.alignment.is_some() {
                // Restarted in the air and aligning: the pilot flies if the switch is off,
                // otherwise the blind failsafe holds on until the estimate starts.
                let pilot_flies = !signal_lost && pilot.is_some_and(|p| !p.auto_mode || p.bypass);
                return if pilot_flies {
                    Phase::Manual
                } else {
                    Phase::BlindDescent
                };
            }
            if self.estimate_valid {
                self.refuse_while_calibrating(now_us, out);
                return Phase::Calibrating;
            }
            // The estimate is gone: the pilot flies if there is one; otherwise the blind
            // failsafe in the air, the safest thing left without attitude, and idle on a
            // helicopter that never left the ground.
            return if pilot.is_some() && !signal_lost {
                Phase::Manual
            } else if self.airborne_once {
                Phase::BlindDescent
            } else {
                Phase::GroundFailsafe
            };
        };
        let auto_switch = pilot.is_some_and(|p| p.auto_mode);
        let (_, _, yaw) = est.euler_rad();
        // Where the helicopter can stop: ahead by v²/2a at the braking deceleration, so that
        // a hold begun in motion does not fly back to where it began.
        let horizontal_vel = Vector3::new(est.vel_ned_mps.x, est.vel_ned_mps.y, 0.0);
        let stop = horizontal_vel * (0.5 * horizontal_vel.norm() / brake::BRAKE_DECEL_MPS2);
        let here = Target::hold(est.pos_ned_m + stop, yaw);
        let on_ground = self.height_above_home(est) < self.config.airborne_height_m;
        let bypass = !self.uplink_lost && pilot.is_some_and(|p| p.bypass);
        let wants_auto =
            !bypass && (signal_lost || (self.params.mode != FlightMode::Manual && auto_switch));
        // A roll under way is finished, upright, before the pilot's switch or a lost
        // transmitter takes over: handing over an inverted helicopter costs metres of height
        // and seconds of recovery. (The emergency bypass acts at once: the board gives the
        // servos to the pilot in hardware.)
        if !bypass
            && (signal_lost || !wants_auto)
            && let Phase::Maneuver {
                target,
                stage: stage @ RollStage::Rolling { .. },
                rolls_done,
            } = self.phase
        {
            let next = self.maneuver(est, now_us, dt_s, target, stage, rolls_done, out);
            if matches!(
                next,
                Phase::Maneuver {
                    stage: RollStage::Rolling { .. },
                    ..
                }
            ) {
                return next;
            }
            // Upright again: the rules below take over from the maneuver.
        }
        if !wants_auto {
            // The emergency bypass: the board drives the servos from the pilot; the computer
            // still supplies the tail with yaw damping.
            self.clear_refusal();
            return Phase::Manual;
        }
        // The engine failed: the computer autorotates whatever it was flying.
        if let Some(phase) = self.autorotate(est, on_ground, signal_lost, now_us) {
            return phase;
        }
        // The pilot's switch asks for a mode: the safety rule may refuse it (a transmitter
        // loss asks for nothing: its failsafe is never refused).
        if !signal_lost && self.refuse_mode(on_ground, now_us, out) {
            return Phase::Manual;
        }
        if let (FlightMode::Augmented(mode), false) = (self.params.mode, signal_lost) {
            return Phase::Augmented(mode);
        }
        if signal_lost {
            return match self.phase {
                // The transmitter lost on the ground is no order to take off (nor to finish
                // one): everything idles.
                _ if on_ground && !matches!(self.phase, Phase::Holding { .. }) => {
                    Phase::GroundFailsafe
                }
                // A hold already in place (the plan's, or the loss's) is kept; the plan is
                // given up either way.
                Phase::Holding { target, since_us } => {
                    self.plan_abandoned = true;
                    Phase::Holding {
                        target: self.braking_target(target, now_us, est),
                        since_us,
                    }
                }
                // In the air: the thesis's "all channels zero" is a command to hover here. The
                // plan is abandoned; the pilot takes over again when the signal returns.
                _ => {
                    self.plan_abandoned = true;
                    self.braking = brake::Brake::begin(now_us, est);
                    Phase::Holding {
                        target: here,
                        since_us: now_us,
                    }
                }
            };
        }
        if let Some(landing) = self.land_if_degraded(est, now_us, out) {
            return landing;
        }
        if let Some(back) = self.battery_failsafe(est, now_us, out) {
            return back;
        }
        match self.phase {
            // Refused stays refused until the pilot takes the auto switch off (above).
            Phase::TakeoffRefused => Phase::TakeoffRefused,
            Phase::PreflightCheck { since_us } => match self.preflight(now_us) {
                None => {
                    self.leg = 0;
                    self.start_leg(est, now_us, out)
                }
                Some(refusal) if seconds_between(since_us, now_us) >= preflight::CHECK_WAIT_S => {
                    out.push(Action::Event(Stamped::new(
                        now_us,
                        CoreEvent::TakeoffRefused(refusal),
                    )));
                    Phase::TakeoffRefused
                }
                Some(_) => Phase::PreflightCheck { since_us },
            },
            Phase::Calibrating
            | Phase::Manual
            | Phase::GroundFailsafe
            | Phase::BlindDescent
            | Phase::Augmented(_) => {
                if on_ground && !self.plan_done && !self.plan_abandoned {
                    self.leg = 0;
                    // Pre-flight checks before the helicopter leaves the ground on its own.
                    if self.preflight(now_us).is_some() {
                        return Phase::PreflightCheck { since_us: now_us };
                    }
                    self.start_leg(est, now_us, out)
                } else if on_ground {
                    // Nothing left to fly: stay on the skids.
                    Phase::Landed
                } else {
                    // Auto switch on in the air: hover here, once stopped.
                    self.braking = brake::Brake::begin(now_us, est);
                    Phase::Holding {
                        target: here,
                        since_us: now_us,
                    }
                }
            }
            Phase::Landed => Phase::Landed,
            // Only `autorotate` above leaves it (on the ground).
            Phase::Autorotation { .. } => self.phase,
            Phase::TakingOff { target } => {
                if (est.pos_ned_m.z - target.pos_ned_m.z).abs() < self.config.takeoff_tolerance_m {
                    self.next_leg(est, now_us, out)
                } else {
                    self.phase
                }
            }
            Phase::Holding { target, since_us } => match self.plan_leg() {
                Some(Leg::Hold { seconds })
                    if !self.plan_done
                        && !self.plan_abandoned
                        && seconds_between(since_us, now_us) >= seconds =>
                {
                    self.next_leg(est, now_us, out)
                }
                _ => {
                    let target = self.braking_target(target, now_us, est);
                    Phase::Holding {
                        target: weathervane::weathervane(
                            target,
                            self.hover.trim_accel_ned_mps2(),
                            dt_s,
                        ),
                        since_us,
                    }
                }
            },
            Phase::Flying { target, to_ned_m } => {
                let speed = target.vel_ned_mps.norm();
                let remaining = to_ned_m - target.pos_ned_m;
                let step = speed * dt_s;
                let target = if remaining.norm() <= step || speed <= 0.0 {
                    Target {
                        pos_ned_m: to_ned_m,
                        vel_ned_mps: Vector3::zeros(),
                        ..target
                    }
                } else {
                    Target {
                        pos_ned_m: target.pos_ned_m + remaining.normalize() * step,
                        ..target
                    }
                };
                let arrived = target.vel_ned_mps.norm() == 0.0
                    && (est.pos_ned_m - to_ned_m).norm() < 1.5
                    && est.vel_ned_mps.norm() < 1.0;
                if arrived {
                    self.next_leg(est, now_us, out)
                } else {
                    Phase::Flying { target, to_ned_m }
                }
            }
            Phase::Maneuver {
                target,
                stage,
                rolls_done,
            } => self.maneuver(est, now_us, dt_s, target, stage, rolls_done, out),
            Phase::Landing {
                target,
                settled_since_us,
            } => {
                // The target descends at its rate but never more than a metre below the
                // helicopter; when the skids stop the descent the helicopter no longer follows
                // it. Touchdown is judged against the target, not against home: the landing
                // spot need not be at the take-off height, and the altimeter drifts.
                let z =
                    (target.pos_ned_m.z + target.vel_ned_mps.z * dt_s).min(est.pos_ned_m.z + 1.0);
                let target = Target {
                    pos_ned_m: Vector3::new(target.pos_ned_m.x, target.pos_ned_m.y, z),
                    ..target
                };
                // Stopped: the skids hold the helicopter up and it no longer moves. Without
                // GPS (a degraded estimate's landing) the horizontal velocity coasts on the
                // IMU and drifts; only the vertical one, which the altimeter keeps, is judged.
                let gps_fused = self
                    .nav
                    .health(now_us)
                    .since_gps_s
                    .is_some_and(|s| s < GPS_FRESH_FOR_LANDING_S);
                let speed = if gps_fused {
                    est.vel_ned_mps.norm()
                } else {
                    est.vel_ned_mps.z.abs()
                };
                let stopped = z - est.pos_ned_m.z > 0.5 && speed < 0.3;
                let settled_since_us = if stopped {
                    Some(settled_since_us.unwrap_or(now_us))
                } else {
                    None
                };
                if settled_since_us.is_some_and(|t| seconds_between(t, now_us) >= 1.0) {
                    self.plan_done = true;
                    // A landing the plan did not ask for (a degraded estimate's) lands; it
                    // does not complete the plan.
                    if !self.plan_abandoned {
                        out.push(Action::Event(Stamped::new(now_us, CoreEvent::PlanComplete)));
                    }
                    Phase::Landed
                } else {
                    Phase::Landing {
                        target,
                        settled_since_us,
                    }
                }
            }
        }
    }

    /// A hold begun in motion keeps its target on the predicted stopping point until the
    /// helicopter has actually stopped (under 0.3 m/s), then holds that spot.
    pub(super) fn plan_leg(&self) -> Option<Leg> {
        self.params.plan.get(self.leg)
    }

    pub(super) fn next_leg(&mut self, est: &NavState, now_us: u64, out: &mut Vec<Action>) -> Phase {
        self.leg = self.leg.saturating_add(1);
        self.start_leg(est, now_us, out)
    }

    /// The phase that flies the current leg, starting from where the helicopter is (or from
    /// the previous phase's target, so that a hold does not jump by the estimate's jitter).
    pub(super) fn start_leg(
        &mut self,
        est: &NavState,
        now_us: u64,
        out: &mut Vec<Action>,
    ) -> Phase {
        let (_, _, yaw) = est.euler_rad();
        let from = self.phase.target().map_or(est.pos_ned_m, |t| t.pos_ned_m);
        let home = self.home_ned_m.unwrap_or(est.pos_ned_m);
        match self.plan_leg() {
            Some(Leg::Takeoff { alt_m }) => Phase::TakingOff {
                target: Target::hold(home + Vector3::new(0.0, 0.0, -alt_m), yaw),
            },
            Some(Leg::Hold { .. }) => {
                // Begun in motion (after a path or a roll sequence): stop first.
                self.braking = brake::Brake::begin(now_us, est);
                Phase::Holding {
                    target: self.braking_target(Target::hold(from, yaw), now_us, est),
                    since_us: now_us,
                }
            }
            Some(Leg::Fly {
                north_m,
                east_m,
                alt_m,
                speed_mps,
            }) => {
                let to_ned_m = home + Vector3::new(north_m, east_m, -alt_m);
                let path = to_ned_m - from;
                let horizontal = Vector3::new(path.x, path.y, 0.0);
                let heading = if horizontal.norm() > 5.0 {
                    path.y.atan2(path.x)
                } else {
                    yaw
                };
                let vel = if path.norm() > 1e-6 {
                    path.normalize() * speed_mps
                } else {
                    Vector3::zeros()
                };
                Phase::Flying {
                    target: Target {
                        pos_ned_m: from,
                        vel_ned_mps: vel,
                        yaw_rad: heading,
                    },
                    to_ned_m,
                }
            }
            Some(Leg::Rolls { speed_mps, .. }) => {
                let dir = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
                Phase::Maneuver {
                    target: Target {
                        pos_ned_m: from,
                        vel_ned_mps: dir * speed_mps,
                        yaw_rad: yaw,
                    },
                    stage: RollStage::Accelerate { since_us: now_us },
                    rolls_done: 0,
                }
            }
            Some(Leg::Land) => Phase::Landing {
                settled_since_us: None,
                target: Target {
                    pos_ned_m: from,
                    vel_ned_mps: Vector3::new(0.0, 0.0, 0.5),
                    yaw_rad: yaw,
                },
            },
            None => {
                if !self.plan_done {
                    self.plan_done = true;
                    out.push(Action::Event(Stamped::new(now_us, CoreEvent::PlanComplete)));
                }
                Phase::Holding {
                    target: Target::hold(from, yaw),
                    since_us: now_us,
                }
            }
        }
    }
}
