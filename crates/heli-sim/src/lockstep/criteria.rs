//! The end of a run: the scenario's criteria judged on what was measured, and the summary.

use super::*;

impl Simulation {
    pub(super) fn summarise(self, wall_s: f64) -> Summary {
        let m = &self.metrics;
        let sim_time_s = self.now_us as f64 * 1e-6;
        let stats = self.computer.core().stats();
        let nav = self.computer.core().navigator().stats();
        let hold_duration = m.hold_time_s;
        let limits = self.scenario.limits;
        let mut criteria = Vec::new();
        let mut at_most = |name: &str, value: Option<f64>, limit: Option<f64>| {
            if let Some(limit) = limit {
                criteria.push(Criterion::at_most(name, value, limit));
            }
        };
        // Faults timed from a phase that never began never acted: such a run judges
        // nothing of them, and fails for it.
        if self.scenario.faults.timed_from.is_some() {
            at_most(
                "fault_phase_began_s",
                self.fault_clock.began_us.map(|t| t as f64 * 1e-6),
                Some(self.scenario.duration_s),
            );
        }
        let held = |v: Option<f64>| v.filter(|_| m.hold_start_us.is_some());
        at_most(
            "hold_horizontal_rms_m",
            held(m.hold_horizontal.measured_rms()),
            limits.hold_horizontal_rms_m,
        );
        at_most(
            "hold_altitude_rms_m",
            held(m.hold_altitude.measured_rms()),
            limits.hold_altitude_rms_m,
        );
        at_most(
            "hold_true_max_m",
            held(m.hold_true.measured_max()),
            limits.hold_true_max_m,
        );
        let altitude_loss = m
            .maneuver_start_alt_m
            .map(|start| (start - m.maneuver_min_alt_m).max(0.0));
        // The roll criteria judge the rolls flown. A scenario that asks for no number of
        // rolls (`rolls_min` unset: a transmitter lost anywhere in the manoeuvre, its run-up
        // too, where the flight software rightly gives the rolls up) judges none when none
        // was flown; one that asks for rolls fails on them unmeasured.
        let rolled = |v: Option<f64>, limit: Option<f64>| {
            if v.is_none() && limits.rolls_min.is_none() {
                None
            } else {
                limit
            }
        };
        at_most(
            "altitude_loss_m",
            altitude_loss,
            rolled(altitude_loss, limits.altitude_loss_max_m),
        );
        at_most(
            "recovery_attitude_deg",
            m.recovery_attitude_deg,
            rolled(m.recovery_attitude_deg, limits.recovery_attitude_max_deg),
        );
        at_most(
            "recovery_speed_error_mps",
            m.recovery_speed_error_mps,
            rolled(m.recovery_speed_error_mps, limits.recovery_speed_max_mps),
        );
        at_most(
            "att_err_rms_deg",
            m.att.measured_rms(),
            limits.att_err_rms_max_deg,
        );
        at_most(
            "att_err_max_deg",
            m.att.measured_max(),
            limits.att_err_max_deg,
        );
        at_most(
            "pos_err_rms_m",
            m.pos.measured_rms(),
            limits.pos_err_rms_max_m,
        );
        let hover_after = match (m.rc_lost_at_us, m.rc_hover_at_us) {
            (Some(lost), Some(hover)) => Some(hover.saturating_sub(lost) as f64 * 1e-6),
            _ => None,
        };
        at_most(
            "rc_loss_hover_after_s",
            hover_after,
            limits.rc_loss_hover_within_s,
        );
        let drift = m.rc_hover_at_us.map(|_| m.rc_drift_max_m);
        at_most("rc_loss_drift_m", drift, limits.rc_loss_drift_max_m);
        let outage_err = m.gps_outage_pos_err.iter().copied().reduce(f64::max);
        at_most(
            "gps_outage_pos_err_m",
            outage_err,
            limits.gps_outage_pos_err_max_m,
        );
        at_most(
            "manual_yaw_rate_max_dps",
            m.manual_yaw_rate_max_dps,
            limits.manual_yaw_rate_max_dps,
        );
        at_most(
            "manual_distance_max_m",
            m.manual_distance_max_m,
            limits.manual_distance_max_m,
        );
        at_most(
            "velocity_tracking_max_mps",
            m.velocity_tracking_max_mps,
            limits.velocity_tracking_max_mps,
        );
        at_most(
            "yaw_rate_tracking_max_dps",
            m.yaw_rate_tracking_max_dps,
            limits.yaw_rate_tracking_max_dps,
        );
        let t = &m.truth;
        at_most("tilt_max_deg", t.tilt_max_deg, limits.tilt_max_deg);
        let touchdown = t.touchdown;
        at_most(
            "touchdown_distance_m",
            touchdown.and_then(|td| td.distance_m),
            limits.touchdown_distance_max_m,
        );
        at_most(
            "touchdown_sink_mps",
            touchdown.map(|td| td.sink_mps),
            limits.touchdown_sink_max_mps,
        );
        at_most(
            "touchdown_speed_mps",
            touchdown.map(|td| td.speed_mps),
            limits.touchdown_speed_max_mps,
        );
        at_most(
            "battery_time_left_err_pct",
            m.power.time_left_err_max_pct,
            limits.battery_time_left_err_max_pct,
        );
        at_most(
            "touchdown_tilt_deg",
            touchdown.map(|td| td.tilt_deg),
            limits.touchdown_tilt_max_deg,
        );
        at_most("hover_after_s", t.hover_after_s, limits.hover_within_s);
        at_most("ground_max_m", Some(m.max_alt_m), limits.ground_max_m);
        let mut at_least = |name: &str, value: Option<f64>, limit: Option<f64>| {
            if let Some(limit) = limit {
                criteria.push(Criterion::at_least(name, value, limit));
            }
        };
        at_least("height_min_m", t.height_min_m, limits.height_min_m);
        at_least("rotor_min_rpm", t.rotor_min_rpm, limits.rotor_min_rpm);
        at_least(
            "flight_battery_soc_min",
            m.power.flight_soc_min,
            limits.flight_battery_soc_min,
        );
        at_least(
            "sweep_roll_rate_rms_dps",
            m.sweep_roll_rate.measured_rms(),
            limits.sweep_roll_rate_rms_min_dps,
        );
        at_least("climb_m", Some(m.max_alt_m), limits.climb_min_m);
        at_least("hold_duration_s", Some(hold_duration), limits.hold_min_s);
        at_least(
            "rolls_completed",
            Some(f64::from(stats.rolls_completed)),
            limits.rolls_min,
        );
        if limits.plan_complete == Some(true) {
            let done = if self.computer.core().plan_complete() {
                1.0
            } else {
                0.0
            };
            criteria.push(Criterion::at_least("plan_complete", Some(done), 1.0));
        }
        for text in &self.scenario.expect_events {
            let raised = m.events.iter().any(|e| e.contains(text.as_str()));
            criteria.push(Criterion::at_least(
                &format!("event '{text}'"),
                Some(if raised { 1.0 } else { 0.0 }),
                1.0,
            ));
        }
        // Hardware in the loop: only the truth can be judged.
        if let Some(hil) = self.hil_criteria() {
            criteria = hil;
        }
        // A run judged on nothing has not passed: say so as a criterion of its own. The
        // invariants below judge every run alike, so they do not count as the scenario's.
        if criteria.is_empty() {
            criteria.push(Criterion::at_least("criteria_defined", Some(0.0), 1.0));
        }
        // Every run is judged on the flight core's invariants too: a broken one is a defect
        // whatever the flight looked like.
        let invariants = self.invariant_summary();
        if invariants.checked > 0 {
            criteria.push(Criterion::at_most(
                "invariant_violations",
                Some(invariants.violations as f64),
                0.0,
            ));
        }
        let outcome = if self.crash.is_some() {
            Outcome::Crash
        } else if criteria.iter().all(|c| c.pass) {
            Outcome::Pass
        } else {
            Outcome::Fail
        };
        let link = |s: heli_proto::framer::FramerStats| LinkSummary {
            frames: s.frames,
            checksum_errors: s.checksum_errors,
            framing_errors: s.framing_errors,
            discarded_bytes: s.discarded_bytes,
        };
        Summary {
            scenario: self.scenario.name.clone(),
            seed: self.scenario.seed,
            sim_time_s,
            wall_time_s: wall_s,
            realtime_factor: if wall_s > 0.0 {
                sim_time_s / wall_s
            } else {
                0.0
            },
            outcome,
            crash: self.crash.clone(),
            criteria,
            estimator: EstimatorSummary {
                att_err_rms_deg: m.att.measured_rms(),
                att_err_max_deg: m.att.measured_max(),
                pos_err_rms_m: m.pos.measured_rms(),
                vel_err_rms_mps: m.vel.measured_rms(),
                samples: m.att.count(),
                gps_fused: nav.gps_fused,
                gps_rejected: nav.gps_rejected,
                baro_fused: nav.baro_fused,
                compass_fused: nav.compass_fused,
                gps_test_ratio_max: m.gps_test_ratio_max,
                longest_without_gps_s: m.longest_without_gps_s,
            },
            loop_: LoopSummary {
                imu_samples: stats.imu_samples,
                imu_dropped: m.imu_dropped,
                watchdog_fires: stats.watchdog_fires,
                control_steps: stats.control_steps,
                step_time_max_us: m.step_time_max.as_secs_f64() * 1e6,
            },
            maneuvers: ManeuverSummary {
                rolls_completed: stats.rolls_completed,
                altitude_loss_m: altitude_loss,
                recovery_attitude_deg: m.recovery_attitude_deg,
                recovery_speed_error_mps: m.recovery_speed_error_mps,
            },
            hold: HoldSummary {
                start_s: m.hold_start_us.map(|t| t as f64 * 1e-6),
                duration_s: hold_duration,
                horizontal_rms_m: m.hold_horizontal.measured_rms(),
                altitude_rms_m: m.hold_altitude.measured_rms(),
                true_max_m: m.hold_true.measured_max(),
                mean_roll_deg: (m.hold_true.count() > 0)
                    .then(|| m.hold_roll_sum_deg / m.hold_true.count() as f64),
                mean_pitch_deg: (m.hold_true.count() > 0)
                    .then(|| m.hold_pitch_sum_deg / m.hold_true.count() as f64),
            },
            devices: DeviceSummary {
                imu: link(self.computer.drivers().imu.stats().framer),
                uplink: link(self.computer.drivers().uplink.stats().framer),
                servo: link(self.scb.stats()),
                gps: link(self.computer.drivers().gps.stats().framer),
                baro_readings: stats.baro_readings,
                baro_link: format!("{:?}", self.computer.drivers().baro.state()),
                battery_min_v: m.battery_min_v.is_finite().then_some(m.battery_min_v),
            },
            events: m.events.clone(),
            log: None,
            power: self.power_summary(),
            invariants,
            hil: None,
        }
    }

    /// The invariants' checks of every flight process of the run.
    fn invariant_summary(&self) -> InvariantSummary {
        let mut report = self.metrics.invariants_past;
        if let Some(now) = self.computer.invariant_report() {
            report.merge(now);
        }
        InvariantSummary {
            checked: report.checked,
            violations: report.violations,
            first: report
                .first
                .map(|(t_us, v)| format!("t={:.2} s: {v}", t_us as f64 * 1e-6)),
        }
    }
}
