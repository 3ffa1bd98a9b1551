//! Control dispatch: the 50 Hz step propagates the estimate, lets the sequencer choose the
//! phase, and runs the controller that phase calls for.

use super::*;

impl FlightCore {
    /// The 50 Hz step: propagate, choose the phase, control, publish.
    pub(super) fn control_step(
        &mut self,
        previous: ImuRepr,
        current: ImuRepr,
        now_us: u64,
        out: &mut Vec<Action>,
    ) {
        self.stats.control_steps = self.stats.control_steps.saturating_add(1);
        let dt_s = self
            .last_control_us
            .map_or(0.02, |t| seconds_between(t, now_us));
        self.last_control_us = Some(now_us);
        self.nav.propagate(now_us, &previous, &current);

        // An estimate declared invalid (the IMU went silent) is never flown on again.
        let estimate = self.nav.state().copied().filter(|_| self.estimate_valid);
        let gps_lost = self.nav.gps_outage(now_us);
        if gps_lost != self.gps_lost && estimate.is_some() {
            self.gps_lost = gps_lost;
            let event = if gps_lost {
                CoreEvent::GpsLost
            } else {
                CoreEvent::GpsRegained
            };
            out.push(Action::Event(Stamped::new(now_us, event)));
        }
        if let Some(est) = estimate.as_ref() {
            self.watch_aids(now_us, out);
            self.watch_engine(est, now_us, out);
        }
        if let Some(est) = estimate.as_ref() {
            self.airborne_once |= self.height_above_home(est) > self.config.airborne_height_m;
        }
        let previous_phase = self.phase;
        let next_phase = self.next_phase(estimate.as_ref(), now_us, dt_s, out);
        self.phase = next_phase;
        if !next_phase.same_kind(&previous_phase) {
            // The trim-trajectory controller keeps its integrators through a climb, a path
            // and a maneuver; it starts afresh after the pilot or the ground had control.
            if matches!(
                previous_phase,
                Phase::Calibrating
                    | Phase::Manual
                    | Phase::GroundFailsafe
                    | Phase::BlindDescent
                    | Phase::TakeoffRefused
                    | Phase::PreflightCheck { .. }
                    | Phase::Landed
                    | Phase::Augmented(_)
            ) {
                self.hover.reset();
            }
            out.push(Action::Event(Stamped::new(
                now_us,
                CoreEvent::PhaseChanged(next_phase),
            )));
        }

        let controls = self.phase_controls(estimate, &current, dt_s);
        if self.averages_trim() {
            self.average_trim(&controls, dt_s);
        }
        let rotor_rpm = self.pilot.map_or(0, |p| p.rotor_rpm);
        out.push(Action::Servo(Stamped::new(now_us, controls)));
        out.push(Action::Publish(Record::Servo(Stamped::new(
            now_us,
            ServoRecord {
                controls,
                rotor_rpm,
            },
        ))));
        if let Some(nav) = estimate {
            out.push(Action::Publish(Record::State(Stamped::new(
                now_us,
                StateRecord {
                    nav,
                    phase: self.phase,
                    target: self.phase.target(),
                },
            ))));
        }
    }

    /// The servo command the phase calls for: the dispatch from phase to controller.
    pub(super) fn phase_controls(
        &mut self,
        estimate: Option<NavState>,
        current: &ImuRepr,
        dt_s: f64,
    ) -> Controls {
        // A silent uplink's last sticks are stale: they count as no sticks at all.
        let pilot_sticks = self
            .pilot
            .filter(|_| !self.uplink_lost)
            .and_then(|p| p.sticks())
            .unwrap_or_default();
        // Without a valid estimate the last IMU sample is a stale copy: no yaw damping.
        let yaw_rate = match (estimate, self.estimate_valid) {
            (Some(s), _) => s.rate_body_rps.z,
            (None, true) => current.rate_rps[2],
            (None, false) => 0.0,
        };
        match (self.phase, estimate) {
            (
                Phase::Maneuver {
                    stage: RollStage::Rolling { angle_rad, .. },
                    ..
                },
                Some(est),
            ) => rolling_controls(&est, angle_rad, &self.config.roll),
            (
                Phase::TakingOff { target }
                | Phase::Holding { target, .. }
                | Phase::Flying { target, .. }
                | Phase::Maneuver { target, .. }
                | Phase::Landing { target, .. },
                Some(est),
            ) => {
                let airborne = self.height_above_home(&est) > self.config.airborne_height_m;
                self.hover.update(&est, &target, dt_s, airborne)
            }
            (Phase::Autorotation { .. }, Some(est)) => self.autorotation_controls(&est, dt_s),
            (Phase::Augmented(mode), Some(est)) => {
                let airborne = self.height_above_home(&est) > self.config.airborne_height_m;
                // Once it has flown, a low pass near the ground is flight, not ground idle.
                self.has_flown |= self.height_above_home(&est) > 1.0;
                if !self.has_flown
                    && mode == AugmentedMode::Velocity
                    && pilot_sticks.collective <= 0.1
                {
                    // On the skids with the climb stick centred: ground idle, rotor governed.
                    Controls {
                        throttle: heli_control::GOVERNED_THROTTLE,
                        ..Controls::default()
                    }
                } else {
                    augmented_controls(
                        mode,
                        &pilot_sticks,
                        &est,
                        &self.config.sticks,
                        &mut self.hover,
                        dt_s,
                        airborne,
                    )
                }
            }
            (Phase::Landed | Phase::TakeoffRefused | Phase::PreflightCheck { .. }, _) => Controls {
                collective: -0.1,
                throttle: heli_control::GOVERNED_THROTTLE,
                ..Controls::default()
            },
            (Phase::GroundFailsafe, _) => Controls::default(),
            (Phase::BlindDescent, _) if self.alignment.is_some() => self
                .aligning_controls(current.rate_rps[2])
                .unwrap_or_default(),
            (Phase::BlindDescent, _) => Controls {
                collective: self.config.hover.hover_collective - BLIND_DESCENT_COLLECTIVE_MARGIN,
                rudder: self.config.yaw_damper.trim,
                throttle: heli_control::GOVERNED_THROTTLE,
                ..Controls::default()
            },
            _ => manual_with_yaw_damping(&pilot_sticks, yaw_rate, &self.config.yaw_damper),
        }
    }

    /// Whether this step's command goes into the trim a restarted process aligns on: in
    /// autonomous flight that holds or flies a target, once the helicopter has been up.
    pub(super) fn averages_trim(&self) -> bool {
        self.airborne_once
            && matches!(
                self.phase,
                Phase::Holding { .. } | Phase::Flying { .. } | Phase::TakingOff { .. }
            )
    }

    pub(super) fn height_above_home(&self, est: &NavState) -> f64 {
        self.home_ned_m.map_or(0.0, |home| home.z - est.pos_ned_m.z)
    }
}
