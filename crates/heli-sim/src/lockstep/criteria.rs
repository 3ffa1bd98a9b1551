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
        let mut at_most = |name: &str, value: f64, limit: Option<f64>| {
            if let Some(limit) = limit {
                criteria.push(Criterion::at_most(name, value, limit));
            }
        };
        at_most(
            "hold_horizontal_rms_m",
            m.hold_horizontal.rms(),
            limits
                .hold_horizontal_rms_m
                .filter(|_| m.hold_start_us.is_some()),
        );
        at_most(
            "hold_altitude_rms_m",
            m.hold_altitude.rms(),
            limits
                .hold_altitude_rms_m
                .filter(|_| m.hold_start_us.is_some()),
        );
        at_most(
            "hold_true_max_m",
            m.hold_true.max(),
            limits.hold_true_max_m.filter(|_| m.hold_start_us.is_some()),
        );
        let altitude_loss = m.maneuver_start_alt_m.map_or(f64::INFINITY, |start| {
            (start - m.maneuver_min_alt_m).max(0.0)
        });
        at_most("altitude_loss_m", altitude_loss, limits.altitude_loss_max_m);
        at_most(
            "recovery_attitude_deg",
            m.recovery_attitude_deg.unwrap_or(f64::INFINITY),
            limits.recovery_attitude_max_deg,
        );
        at_most(
            "recovery_speed_error_mps",
            m.recovery_speed_error_mps.unwrap_or(f64::INFINITY),
            limits.recovery_speed_max_mps,
        );
        at_most("att_err_rms_deg", m.att.rms(), limits.att_err_rms_max_deg);
        at_most("att_err_max_deg", m.att.max(), limits.att_err_max_deg);
        at_most("pos_err_rms_m", m.pos.rms(), limits.pos_err_rms_max_m);
        let hover_after = match (m.rc_lost_at_us, m.rc_hover_at_us) {
            (Some(lost), Some(hover)) => hover.saturating_sub(lost) as f64 * 1e-6,
            _ => f64::INFINITY,
        };
        at_most(
            "rc_loss_hover_after_s",
            hover_after,
            limits.rc_loss_hover_within_s,
        );
        let drift = if m.rc_hover_at_us.is_some() {
            m.rc_drift_max_m
        } else {
            f64::INFINITY
        };
        at_most("rc_loss_drift_m", drift, limits.rc_loss_drift_max_m);
        let outage_err = if m.gps_outage_pos_err.is_empty() {
            f64::INFINITY
        } else {
            m.gps_outage_pos_err.iter().copied().fold(0.0, f64::max)
        };
        at_most(
            "gps_outage_pos_err_m",
            outage_err,
            limits.gps_outage_pos_err_max_m,
        );
        at_most(
            "manual_yaw_rate_max_dps",
            m.manual_yaw_rate_max_dps.unwrap_or(f64::INFINITY),
            limits.manual_yaw_rate_max_dps,
        );
        at_most(
            "manual_distance_max_m",
            m.manual_distance_max_m.unwrap_or(f64::INFINITY),
            limits.manual_distance_max_m,
        );
        at_most(
            "velocity_tracking_max_mps",
            m.velocity_tracking_max_mps.unwrap_or(f64::INFINITY),
            limits.velocity_tracking_max_mps,
        );
        at_most(
            "yaw_rate_tracking_max_dps",
            m.yaw_rate_tracking_max_dps.unwrap_or(f64::INFINITY),
            limits.yaw_rate_tracking_max_dps,
        );
        if let Some(min) = limits.sweep_roll_rate_rms_min_dps {
            criteria.push(Criterion::at_least(
                "sweep_roll_rate_rms_dps",
                m.sweep_roll_rate.rms(),
                min,
            ));
        }
        if let Some(max) = limits.ground_max_m {
            criteria.push(Criterion::at_most("ground_max_m", m.max_alt_m, max));
        }
        if let Some(min) = limits.climb_min_m {
            criteria.push(Criterion::at_least("climb_m", m.max_alt_m, min));
        }
        if let Some(min) = limits.hold_min_s {
            criteria.push(Criterion::at_least("hold_duration_s", hold_duration, min));
        }
        if let Some(min) = limits.rolls_min {
            criteria.push(Criterion::at_least(
                "rolls_completed",
                f64::from(stats.rolls_completed),
                min,
            ));
        }
        if limits.plan_complete == Some(true) {
            let done = if self.computer.core().plan_complete() {
                1.0
            } else {
                0.0
            };
            criteria.push(Criterion::at_least("plan_complete", done, 1.0));
        }
        for text in &self.scenario.expect_events {
            let raised = m.events.iter().any(|e| e.contains(text.as_str()));
            criteria.push(Criterion::at_least(
                &format!("event '{text}'"),
                if raised { 1.0 } else { 0.0 },
                1.0,
            ));
        }
        // Hardware in the loop: only the truth can be judged.
        if let Some(hil) = self.hil_criteria() {
            criteria = hil;
        }
        // A run judged on nothing has not passed: say so as a criterion of its own.
        if criteria.is_empty() {
            criteria.push(Criterion::at_least("criteria_defined", 0.0, 1.0));
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
                att_err_rms_deg: m.att.rms(),
                att_err_max_deg: m.att.max(),
                pos_err_rms_m: m.pos.rms(),
                vel_err_rms_mps: m.vel.rms(),
                samples: m.att.count(),
                gps_fused: nav.gps_fused,
                gps_rejected: nav.gps_rejected,
                baro_fused: nav.baro_fused,
                compass_fused: nav.compass_fused,
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
                altitude_loss_m: if altitude_loss.is_finite() {
                    altitude_loss
                } else {
                    0.0
                },
                recovery_attitude_deg: m.recovery_attitude_deg,
                recovery_speed_error_mps: m.recovery_speed_error_mps,
            },
            hold: HoldSummary {
                start_s: m.hold_start_us.map(|t| t as f64 * 1e-6),
                duration_s: hold_duration,
                horizontal_rms_m: m.hold_horizontal.rms(),
                altitude_rms_m: m.hold_altitude.rms(),
                true_max_m: m.hold_true.max(),
                mean_roll_deg: m.hold_roll_sum_deg / m.hold_true.count().max(1) as f64,
                mean_pitch_deg: m.hold_pitch_sum_deg / m.hold_true.count().max(1) as f64,
            },
            devices: DeviceSummary {
                imu: link(self.computer.drivers().imu.stats().framer),
                uplink: link(self.computer.drivers().uplink.stats().framer),
                servo: link(self.scb.stats()),
                gps: link(self.computer.drivers().gps.stats().framer),
                baro_readings: stats.baro_readings,
                baro_link: format!("{:?}", self.computer.drivers().baro.state()),
                battery_min_v: if m.battery_min_v.is_finite() {
                    m.battery_min_v
                } else {
                    0.0
                },
            },
            events: m.events.clone(),
            log: None,
            hil: None,
        }
    }
}
