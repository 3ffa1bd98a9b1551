//! What a run measures as it goes: estimate against truth, holds, the roll sequence, the
//! transmitter-loss hover, manual and augmented flight.

use super::*;

#[derive(Clone, Default)]
pub(super) struct Metrics {
    /// The invariants' checks of flight processes that a brown-out ended.
    pub(super) invariants_past: heli_fsw::invariants::InvariantReport,
    /// Serial bytes the scenario's byte loss took.
    pub(super) bytes_lost: u64,
    /// Transmissions and readings a device fault kept from the computer (off, slow).
    pub(super) fault_dropped: u64,
    /// Brown-outs of the flight computer so far.
    pub(super) brownouts: u32,
    /// The filter's health over the flight: the worst GPS test ratio, the longest time
    /// without a fused fix (s).
    pub(super) gps_test_ratio_max: Option<f64>,
    pub(super) longest_without_gps_s: Option<f64>,
    pub(super) att: Rms,
    pub(super) pos: Rms,
    pub(super) vel: Rms,
    pub(super) hold_horizontal: Rms,
    pub(super) hold_altitude: Rms,
    pub(super) hold_true: Rms,
    pub(super) hold_roll_sum_deg: f64,
    pub(super) hold_pitch_sum_deg: f64,
    pub(super) hold_start_us: Option<u64>,
    pub(super) hold_last_us: u64,
    pub(super) imu_dropped: u32,
    pub(super) gps_lost: u32,
    pub(super) target_key: Option<(f64, f64, f64)>,
    pub(super) maneuver_start_alt_m: Option<f64>,
    /// When the last roll of the sequence ended (its stage left), for the recovery time.
    pub(super) last_roll_end_us: Option<u64>,
    /// At the start of the roll sequence: roll and pitch (rad) and the velocity through the
    /// air (m/s, NED) — the trim the recovery must return to, relative to the air.
    pub(super) maneuver_entry: Option<(f64, f64, Vector3<f64>)>,
    pub(super) maneuver_min_alt_m: f64,
    pub(super) maneuver_done: bool,
    pub(super) recovery_attitude_deg: Option<f64>,
    pub(super) recovery_speed_error_mps: Option<f64>,
    pub(super) last_phase: Option<Phase>,
    pub(super) rc_lost_at_us: Option<u64>,
    pub(super) rc_hover_at_us: Option<u64>,
    pub(super) rc_hover_pos: Option<Vector3<f64>>,
    pub(super) rc_drift_max_m: f64,
    pub(super) gps_outage_pos_err: Vec<f64>,
    pub(super) manual_start: Option<Vector3<f64>>,
    pub(super) manual_yaw_rate_max_dps: Option<f64>,
    pub(super) manual_distance_max_m: Option<f64>,
    pub(super) sweep_roll_rate: Rms,
    pub(super) velocity_tracking_max_mps: Option<f64>,
    pub(super) yaw_rate_tracking_max_dps: Option<f64>,
    pub(super) rc_slow_since_us: Option<u64>,
    pub(super) start_alt_m: Option<f64>,
    pub(super) max_alt_m: f64,
    pub(super) hold_time_s: f64,
    pub(super) home_offset: Option<Vector3<f64>>,
    pub(super) target_offset: Vector3<f64>,
    pub(super) step_time_max: Duration,
    pub(super) battery_min_v: f64,
    /// The batteries against the flight software's gauges.
    pub(super) power: super::batteries::PowerMetrics,
    pub(super) events: Vec<String>,
    /// The truth at the physics rate: tilt, height, touchdowns.
    pub(super) truth: TruthMetrics,
}

/// What the physics steps measure of the truth, whatever the flight software thinks.
#[derive(Clone, Default)]
pub(super) struct TruthMetrics {
    /// Height above the start once the take-off climb is over (or, flown by hand, once it
    /// first exceeded 2 m), until the landing began.
    pub(super) height_min_m: Option<f64>,
    /// Largest tilt while airborne (deg).
    pub(super) tilt_max_deg: Option<f64>,
    /// Airborne now (no skid on the ground).
    pub(super) airborne: bool,
    /// Airborne for a whole second at least once since the last touchdown.
    pub(super) flew_since_us: Option<u64>,
    /// The last touchdown after a flight: (distance to the intended point, sink, speed).
    pub(super) touchdown: Option<Touchdown>,
    /// Time to hover after the first hold began (s).
    pub(super) hover_after_s: Option<f64>,
    pub(super) slow_since_us: Option<u64>,
    /// Whether the flight software has begun to land.
    pub(super) landing: bool,
    /// Least rotor speed (rpm) after an engine failure, until the touchdown, while more
    /// than [`ROTOR_WATCH_HEIGHT_M`] above the start.
    pub(super) rotor_min_rpm: Option<f64>,
}

/// Below this height (m) the rotor's speed is the cushion's to spend.
const ROTOR_WATCH_HEIGHT_M: f64 = 3.0;
/// The touchdown's sink is the largest over this long after the skids first touch (µs):
/// a skid that touches first and the other that slams down after it are one landing.
const TOUCHDOWN_WINDOW_US: u64 = 500_000;

/// A touchdown after a flight.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Touchdown {
    pub(super) distance_m: Option<f64>,
    pub(super) sink_mps: f64,
    pub(super) speed_mps: f64,
    /// Tilt from level when the skids first touched (deg).
    pub(super) tilt_deg: f64,
    /// When the skids first touched (µs).
    pub(super) at_us: u64,
}

impl Simulation {
    /// True position expressed in the flight software's frame (its origin is its first GPS
    /// fix, not the simulator's origin), so that estimate and truth compare like for like.
    pub(super) fn truth_in_nav_frame(&self) -> Vector3<f64> {
        let p = self.heli.state.pos_ned_m;
        match self.computer.core().navigator().origin() {
            Some(origin) => {
                let (lat, lon, alt) = FIELD_ORIGIN.to_geodetic([p.x, p.y, p.z]);
                Vector3::from(origin.to_ned(lat, lon, alt))
            }
            None => p,
        }
    }

    pub(super) fn measure(&mut self, s: &StateRecord) {
        let truth = self.heli.state;
        let truth_pos = self.truth_in_nav_frame();
        let est = &s.nav;
        self.metrics
            .att
            .add((est.att.inverse() * truth.att).angle().to_degrees());
        // Relative navigation, as the thesis judges its GPS: position is measured from where
        // the estimate started (the take-off point), so the GPS error the estimate inherited
        // at that moment is common to both and only what it has drifted since counts.
        let home_offset = *self
            .metrics
            .home_offset
            .get_or_insert(est.pos_ned_m - truth_pos);
        let pos_err = (est.pos_ned_m - truth_pos - home_offset).norm();
        self.metrics.pos.add(pos_err);
        let health = self.computer.core().navigator().health(self.now_us);
        let worst = |m: Option<f64>, v: Option<f64>| match (m, v) {
            (Some(m), Some(v)) => Some(m.max(v)),
            (m, v) => m.or(v),
        };
        self.metrics.gps_test_ratio_max = worst(
            self.metrics.gps_test_ratio_max,
            Some(health.gps_test_ratio).filter(|r| r.is_finite()),
        );
        self.metrics.longest_without_gps_s =
            worst(self.metrics.longest_without_gps_s, health.since_gps_s);
        self.measure_gps_outages(pos_err);
        self.measure_maneuver(s);
        self.measure_rc_loss();
        self.measure_pilot();
        self.metrics
            .vel
            .add((est.vel_ned_mps - truth.vel_ned_mps()).norm());
        // Where the target truly is: the flight software set it in its own frame, which is
        // off from the truth by its estimate error when the target was set. Held against the
        // true position of that moment, the target is a true place, and the distance to it
        // measures what the helicopter really did (drift of the GPS error included).
        if let Some(target) = s.target {
            let key = (target.pos_ned_m.x, target.pos_ned_m.y, target.pos_ned_m.z);
            if self.metrics.target_key != Some(key) {
                self.metrics.target_key = Some(key);
                self.metrics.target_offset = est.pos_ned_m - truth_pos;
            }
        }
        if let (Phase::Holding { since_us, .. }, Some(target)) = (s.phase, s.target) {
            self.metrics.hold_start_us.get_or_insert(since_us);
            if matches!(self.metrics.last_phase, Some(Phase::Holding { .. })) {
                self.metrics.hold_time_s +=
                    self.now_us.saturating_sub(self.metrics.hold_last_us) as f64 * 1e-6;
            }
            self.metrics.hold_last_us = self.now_us;
            let err = est.pos_ned_m - target.pos_ned_m;
            self.metrics.hold_horizontal.add(err.xy().norm());
            self.metrics.hold_altitude.add(err.z);
            let true_target = target.pos_ned_m - self.metrics.target_offset;
            self.metrics.hold_true.add((truth_pos - true_target).norm());
            let (roll, pitch, _) = truth.att.euler_angles();
            self.metrics.hold_roll_sum_deg += roll.to_degrees();
            self.metrics.hold_pitch_sum_deg += pitch.to_degrees();
        }
        self.metrics.last_phase = Some(s.phase);
    }

    /// Tilt, height and touchdowns from the truth, every physics step.
    pub(super) fn measure_truth(&mut self) {
        let now = self.now_us;
        let s = self.heli.state;
        let out = self.heli.outputs;
        let start_alt = *self.metrics.start_alt_m.get_or_insert(-s.pos_ned_m.z);
        let height = -s.pos_ned_m.z - start_alt;
        let landing = matches!(
            self.metrics.last_phase,
            Some(Phase::Landing { .. } | Phase::Landed)
        );
        // When the engine failed (its power first cut), if it has.
        let failed_at_us = self
            .scenario
            .faults
            .engine
            .iter()
            .filter(|f| f.power < 1.0)
            .map(|f| (f.start_s * 1e6) as u64)
            .min()
            .unwrap_or(u64::MAX);
        let t = &mut self.metrics.truth;
        t.landing |= landing;
        let on_ground = out.contact_points > 0;
        let up = s.att * Vector3::new(0.0, 0.0, -1.0);
        let tilt = (-up.z).clamp(-1.0, 1.0).acos().to_degrees();
        let before_touchdown = t.touchdown.is_none_or(|td| td.at_us < failed_at_us);
        if now >= failed_at_us && before_touchdown && height > ROTOR_WATCH_HEIGHT_M {
            let rpm = s.rotor_rps * 30.0 / std::f64::consts::PI;
            t.rotor_min_rpm = Some(t.rotor_min_rpm.map_or(rpm, |m| m.min(rpm)));
        }
        if !on_ground {
            t.tilt_max_deg = Some(t.tilt_max_deg.map_or(tilt, |m| m.max(tilt)));
            if !t.airborne {
                t.flew_since_us = Some(now);
            }
        }
        let climbing = matches!(
            self.metrics.last_phase,
            None | Some(
                Phase::Calibrating | Phase::PreflightCheck { .. } | Phase::TakingOff { .. }
            )
        );
        if ((height > 2.0 && !climbing) || t.height_min_m.is_some()) && !t.landing {
            t.height_min_m = Some(t.height_min_m.map_or(height, |m| m.min(height)));
        }
        let flew = t
            .flew_since_us
            .is_some_and(|since| now >= since + 1_000_000);
        let touching_down = on_ground && t.airborne;
        if touching_down {
            t.flew_since_us = None;
        }
        // A touchdown after a flight (a second airborne at least): where, how fast.
        if touching_down && flew {
            let distance_m = self.metrics.target_key.map(|(n, e, d)| {
                let true_target = Vector3::new(n, e, d) - self.metrics.target_offset;
                (self.truth_in_nav_frame() - true_target).xy().norm()
            });
            self.metrics.truth.touchdown = Some(Touchdown {
                distance_m,
                sink_mps: out.contact_sink_mps,
                speed_mps: s.vel_ned_mps().xy().norm(),
                tilt_deg: tilt,
                at_us: now,
            });
        } else if on_ground
            && let Some(td) = self.metrics.truth.touchdown.as_mut()
            && now < td.at_us + TOUCHDOWN_WINDOW_US
        {
            td.sink_mps = td.sink_mps.max(out.contact_sink_mps);
        }
        let t = &mut self.metrics.truth;
        t.airborne = !on_ground;
        // Time to hover from the start of the first hold.
        if let (Some(start), None) = (self.metrics.hold_start_us, t.hover_after_s) {
            if s.vel_ned_mps().xy().norm() < 0.5 {
                let since = *t.slow_since_us.get_or_insert(now.max(start));
                if now >= since + 1_000_000 {
                    t.hover_after_s = Some(since.saturating_sub(start) as f64 * 1e-6);
                }
            } else {
                t.slow_since_us = None;
            }
        }
    }

    /// The position error when each GPS outage ends.
    pub(super) fn measure_gps_outages(&mut self, pos_err: f64) {
        // The first fix after an outage arrives a latency after it ends; the estimate coasts
        // until then, so it is judged just before that fix.
        let t_s = self.now_us as f64 * 1e-6 - (self.gps.errors.latency_s - 0.05);
        let ended = self
            .scenario
            .faults
            .gps_outages
            .iter()
            .filter(|[_, end]| t_s >= *end)
            .count();
        // The fix that follows an outage arrives a latency after it; judge just before.
        while self.metrics.gps_outage_pos_err.len() < ended {
            self.metrics.gps_outage_pos_err.push(pos_err);
        }
    }

    /// Altitude loss over the roll sequence and the state at the end of its recovery.
    pub(super) fn measure_maneuver(&mut self, s: &StateRecord) {
        let alt = -self.heli.state.pos_ned_m.z;
        let in_maneuver = matches!(s.phase, Phase::Maneuver { .. });
        if self.metrics.maneuver_done {
            return;
        }
        if let Phase::Maneuver {
            stage: RollStage::PullUp { .. },
            ..
        } = s.phase
            && self.metrics.maneuver_start_alt_m.is_none()
        {
            self.metrics.maneuver_start_alt_m = Some(alt);
            self.metrics.maneuver_min_alt_m = alt;
            let (roll, pitch, _) = self.heli.state.att.euler_angles();
            self.metrics.maneuver_entry = Some((roll, pitch, self.air_velocity_ned_mps()));
        }
        let rolling = matches!(
            s.phase,
            Phase::Maneuver {
                stage: RollStage::Rolling { .. },
                ..
            }
        );
        if rolling {
            self.metrics.last_roll_end_us = None;
        } else if self.metrics.maneuver_start_alt_m.is_some() {
            self.metrics.last_roll_end_us.get_or_insert(self.now_us);
        }
        // The recovery ends when the sequence's own recovery does: the roll gains' recovery
        // time after the last roll, whether the sequence ran on to it or was cut short (by
        // transmitter loss, the auto switch) into a hold.
        let recover_us = (self.core_setup.0.roll.recover_s * 1e6) as u64;
        let recovered = !in_maneuver
            && self
                .metrics
                .last_roll_end_us
                .is_some_and(|end| self.now_us + 20_000 >= end + recover_us);
        if self.metrics.maneuver_start_alt_m.is_some() {
            self.metrics.maneuver_min_alt_m = self.metrics.maneuver_min_alt_m.min(alt);
            if recovered {
                self.metrics.maneuver_done = true;
                // Judged against the trim it rolled from, relative to the air: in wind the
                // trimmed helicopter is neither level nor at its ground speed.
                let (roll, pitch, _) = self.heli.state.att.euler_angles();
                let (roll0, pitch0, air0) =
                    self.metrics
                        .maneuver_entry
                        .unwrap_or((0.0, 0.0, Vector3::zeros()));
                let wrap = |a: f64| {
                    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI
                };
                self.metrics.recovery_attitude_deg = Some(
                    wrap(roll - roll0)
                        .abs()
                        .max(wrap(pitch - pitch0).abs())
                        .to_degrees(),
                );
                let air = self.air_velocity_ned_mps();
                self.metrics.recovery_speed_error_mps =
                    Some((air.xy().norm() - air0.xy().norm()).abs());
            }
        }
    }

    /// The helicopter's velocity through the air mass (m/s, NED): ground velocity less the
    /// wind of the moment and height without its turbulence (a helicopter rides the air
    /// mass; it cannot follow every gust).
    pub(super) fn air_velocity_ned_mps(&self) -> Vector3<f64> {
        let s = &self.heli.state;
        let height_m = -s.pos_ned_m.z - self.metrics.start_alt_m.unwrap_or(-s.pos_ned_m.z);
        s.vel_ned_mps() - self.scenario.wind_at(self.t_s(), height_m)
    }

    /// Manual flight, sweeps and augmented tracking, judged on the truth.
    pub(super) fn measure_pilot(&mut self) {
        // The scripted inputs' windows, on the script's clock (the pilot of an augmented
        // flight may have waited for the mode to engage).
        let t_s = self.script_t_s();
        let s = self.heli.state;
        let alt = -s.pos_ned_m.z;
        let start_alt = *self.metrics.start_alt_m.get_or_insert(alt);
        self.metrics.max_alt_m = self.metrics.max_alt_m.max(alt - start_alt);
        let pilot = self.pilot();
        let worst = |m: Option<f64>, v: f64| Some(m.map_or(v, |m| m.max(v)));
        if !pilot.auto_mode || pilot.bypass {
            let start = *self.metrics.manual_start.get_or_insert(s.pos_ned_m);
            self.metrics.manual_yaw_rate_max_dps = worst(
                self.metrics.manual_yaw_rate_max_dps,
                s.rate_body_rps.z.abs().to_degrees(),
            );
            self.metrics.manual_distance_max_m = worst(
                self.metrics.manual_distance_max_m,
                (s.pos_ned_m - start).xy().norm(),
            );
        }
        let inputs = &self.scenario.pilot.inputs;
        if inputs.iter().any(|i| {
            i.shape == heli_scenario::pilot::Shape::Sweep
                && (0.0..i.duration_s).contains(&(t_s - i.start_s))
        }) {
            self.metrics
                .sweep_roll_rate
                .add(s.rate_body_rps.x.to_degrees());
        }
        let settling = |channels: &[heli_scenario::pilot::Channel]| {
            inputs.iter().any(|i| {
                channels.contains(&i.channel)
                    && (i.duration_s - 1.0..i.duration_s).contains(&(t_s - i.start_s))
            })
        };
        let scales = heli_control::StickScales::default();
        let augmented = self.scenario.mode.is_augmented() && pilot.auto_mode;
        if augmented && settling(&[heli_scenario::pilot::Channel::Rudder]) {
            let cmd = pilot.sticks.rudder.clamp(-1.0, 1.0) * scales.yaw_rate_rps;
            let err = (s.rate_body_rps.z - cmd).abs().to_degrees();
            self.metrics.yaw_rate_tracking_max_dps =
                worst(self.metrics.yaw_rate_tracking_max_dps, err);
        }
        if augmented
            && self.scenario.mode == FlightMode::Augmented(AugmentedMode::Velocity)
            && settling(&[
                heli_scenario::pilot::Channel::Aileron,
                heli_scenario::pilot::Channel::Elevator,
            ])
        {
            let cmd = heli_control::augmented::commanded_velocity(&pilot.sticks, &scales);
            let (_, _, yaw) = s.att.euler_angles();
            let v = s.vel_ned_mps();
            let (sy, cy) = yaw.sin_cos();
            let fwd = cy * v.x + sy * v.y;
            let right = -sy * v.x + cy * v.y;
            let err = ((fwd - cmd.x).powi(2) + (right - cmd.y).powi(2)).sqrt();
            self.metrics.velocity_tracking_max_mps =
                worst(self.metrics.velocity_tracking_max_mps, err);
        }
    }

    /// How soon the helicopter hovers after the transmitter is lost, and how far it drifts.
    pub(super) fn measure_rc_loss(&mut self) {
        let now = self.now_us;
        if self.pilot().signal_lost || self.fault(|f| &f.uplink_silent) {
            self.metrics.rc_lost_at_us.get_or_insert(now);
        }
        if self.metrics.rc_lost_at_us.is_none() {
            return;
        }
        let p = self.heli.state.pos_ned_m;
        let v = self.heli.state.vel_ned_mps();
        // Hovering: slower than 0.5 m/s and staying so for a second; it counts from when
        // that second began.
        if self.metrics.rc_hover_at_us.is_none() {
            if v.xy().norm() < 0.5 {
                let since = *self.metrics.rc_slow_since_us.get_or_insert(now);
                if now.saturating_sub(since) >= 1_000_000 {
                    self.metrics.rc_hover_at_us = Some(since);
                    self.metrics.rc_hover_pos = Some(p);
                }
            } else {
                self.metrics.rc_slow_since_us = None;
            }
        }
        if let (Some(at), Some(pos)) = (self.metrics.rc_hover_at_us, self.metrics.rc_hover_pos)
            && now <= at + 20_000_000
        {
            self.metrics.rc_drift_max_m = self.metrics.rc_drift_max_m.max((p - pos).xy().norm());
        }
    }
}
