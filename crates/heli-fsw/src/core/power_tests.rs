//! Component tests of the power watch (`power.rs`): the gauges fed through the core's
//! inputs, the events raised, the hot-swap's times, and the battery failsafe's choice of
//! phase driven directly from a constructed state.

use super::power::Battery;
use super::*;
use heli_power::{Level, PowerSource};
use nalgebra::UnitQuaternion;

const S: u64 = 1_000_000;

fn core() -> FlightCore {
    FlightCore::new(CoreConfig::default(), FlightParams::default())
}

/// Feeds the flight battery at `volts` once a second from `from_s` for `seconds`, with a
/// channel's count of noise.
fn battery(core: &mut FlightCore, out: &mut Vec<Action>, from_s: u64, seconds: u64, volts: f64) {
    for k in 0..seconds {
        let noise_v = if (from_s + k).is_multiple_of(2) {
            0.0
        } else {
            0.004
        };
        core.handle(
            Input::Battery {
                volts: volts + noise_v,
            },
            (from_s + k) * S,
            out,
        );
    }
}

fn levels(out: &[Action]) -> Vec<(Battery, Level, u8, u16)> {
    out.iter()
        .filter_map(|a| match a {
            Action::Event(e) => match e.value {
                CoreEvent::BatteryLevel {
                    battery,
                    level,
                    percent,
                    minutes_left,
                } => Some((battery, level, percent, minutes_left)),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

#[test]
fn a_level_reached_is_raised_once_with_the_gauges_charge_and_time_left() {
    let mut core = core();
    let mut out = Vec::new();
    battery(&mut core, &mut out, 0, 30, 12.3);
    assert!(levels(&out).is_empty(), "a full pack is good");
    assert_eq!(core.power().worst(), Level::Good);
    // A pack at 11.3 V under load is at its warning level, then critical.
    let mut out = Vec::new();
    let mut from = 30;
    while levels(&out).is_empty() && from < 600 {
        battery(&mut core, &mut out, from, 1, 11.3);
        from += 1;
    }
    let raised = levels(&out);
    assert_eq!(raised.len(), 1, "one level raised by 600 s: {raised:?}");
    let (battery_, level, percent, minutes) = raised[0];
    assert_eq!(battery_, Battery::Flight);
    assert_eq!(level, Level::Warning);
    // The event carries what the gauge said of the reading that reached the level.
    let state = core.power().state(Battery::Flight).unwrap();
    assert_eq!(f64::from(percent), (state.soc * 100.0).round(), "{state:?}");
    assert_eq!(
        f64::from(minutes),
        (state.time_left_s / 60.0).round(),
        "{state:?}"
    );
    // The same level again is not raised again.
    let mut again = Vec::new();
    battery(&mut core, &mut again, from, 5, 11.3);
    assert!(levels(&again).iter().all(|(_, l, _, _)| *l > level));
}

#[test]
fn the_servo_boards_packs_are_read_from_the_uplink() {
    let mut core = core();
    let mut out = Vec::new();
    let mut pilot = super::tests::uplink(false, false);
    pilot.receiver_batt_v = 5.0;
    pilot.servo_batt_v = 4.9;
    core.handle(Input::Uplink(pilot), S, &mut out);
    assert!(core.power().state(Battery::Receiver).is_some());
    assert!(core.power().state(Battery::Servo).is_some());
    assert!(core.power().state(Battery::Flight).is_none());
    assert_eq!(Battery::Receiver.name(), "receiver battery");
    assert_eq!(Battery::Servo.name(), "servo battery");
    assert_eq!(Battery::Flight.name(), "flight battery");
}

#[test]
fn on_the_ground_battery_the_flight_pack_is_not_judged() {
    let mut core = core();
    let mut out = Vec::new();
    core.handle(Input::PowerSource(PowerSource::Ground), 0, &mut out);
    battery(&mut core, &mut out, 1, 5, 10.5);
    assert!(core.power().state(Battery::Flight).is_none());
    assert!(levels(&out).is_empty());
}

#[test]
fn the_hot_swap_logs_the_time_on_each_battery() {
    let mut core = core();
    let mut out = Vec::new();
    core.handle(Input::PowerSource(PowerSource::Ground), 0, &mut out);
    core.handle(Input::PowerSource(PowerSource::Ground), 30 * S, &mut out);
    battery(&mut core, &mut out, 40, 1, 12.0);
    out.clear();
    core.handle(Input::PowerSource(PowerSource::Flight), 60 * S, &mut out);
    let sources: Vec<_> = out
        .iter()
        .filter_map(|a| match a {
            Action::Event(e) => match e.value {
                CoreEvent::PowerSource {
                    source,
                    flight_s,
                    ground_s,
                } => Some((source, flight_s, ground_s)),
                _ => None,
            },
            _ => None,
        })
        .collect();
    assert_eq!(sources, vec![(PowerSource::Flight, 0.0, 60.0)]);
    assert_eq!(core.power().source(), Some(PowerSource::Flight));
    let (flight_s, ground_s) = core.power().times(90 * S);
    assert!((flight_s - 30.0).abs() < 1e-9 && (ground_s - 60.0).abs() < 1e-9);
    // The flight pack back on the bus: its gauge starts again from its voltage.
    battery(&mut core, &mut out, 61, 1, 12.0);
    assert!(core.power().state(Battery::Flight).is_some());
    core.handle(Input::PowerSource(PowerSource::Ground), 70 * S, &mut out);
    core.handle(Input::PowerSource(PowerSource::Flight), 80 * S, &mut out);
    assert!(core.power().state(Battery::Flight).is_none());
    // No change, no event.
    out.clear();
    core.handle(Input::PowerSource(PowerSource::Flight), 85 * S, &mut out);
    assert!(out.is_empty());
}

/// A core holding 30 m north of home and 12 m up in autonomous flight, its flight pack at
/// `level`.
fn holding_with(level: Level) -> (FlightCore, NavState) {
    let mut core = FlightCore::new(
        CoreConfig::default(),
        FlightParams {
            mode: FlightMode::Autonomous,
            plan: Plan::hover(12.0, 600.0),
        },
    );
    let est = NavState {
        t_us: 0,
        att: UnitQuaternion::from_euler_angles(0.0, 0.0, 0.5),
        vel_ned_mps: Vector3::zeros(),
        pos_ned_m: Vector3::new(30.0, 0.0, -12.0),
        rate_body_rps: Vector3::zeros(),
        accel_body_mps2: Vector3::zeros(),
        gyro_bias_rps: Vector3::zeros(),
        accel_bias_mps2: Vector3::zeros(),
    };
    core.seq.home_ned_m = Some(Vector3::zeros());
    core.seq.airborne_once = true;
    core.seq.phase = Phase::Holding {
        target: Target::hold(est.pos_ned_m, 0.5),
        since_us: 0,
    };
    let mut out = Vec::new();
    let volts = match level {
        Level::Good => 12.3,
        Level::Warning => 11.45,
        Level::Critical => 10.6,
    };
    let mut t = 0;
    while core.power().worst() < level && t < 900 {
        battery(&mut core, &mut out, t, 1, volts);
        t += 1;
    }
    assert_eq!(core.power().worst(), level);
    (core, est)
}

#[test]
fn at_the_warning_level_it_flies_home_at_this_height_and_lands_there() {
    let (mut core, est) = holding_with(Level::Warning);
    let mut out = Vec::new();
    let phase = core.battery_failsafe(&est, 1000 * S, &mut out);
    match phase {
        Some(Phase::Flying { to_ned_m, target }) => {
            assert!((to_ned_m - Vector3::new(0.0, 0.0, -12.0)).norm() < 1e-9);
            assert!((target.vel_ned_mps.norm() - 3.0).abs() < 1e-9);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(core.seq.params.plan.get(1), Some(Leg::Land));
    assert!(core.seq.plan_abandoned);
    // Acted on once.
    assert_eq!(core.battery_failsafe(&est, 1001 * S, &mut out), None);
}

#[test]
fn at_the_critical_level_it_lands_where_it_is() {
    let (mut core, est) = holding_with(Level::Critical);
    let mut out = Vec::new();
    match core.battery_failsafe(&est, 1000 * S, &mut out) {
        Some(Phase::Landing { target, .. }) => {
            assert_eq!(target.pos_ned_m, est.pos_ned_m);
            assert!((target.yaw_rad - 0.5).abs() < 1e-9);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn without_a_take_off_point_the_warning_lands_where_it_is() {
    let (mut core, est) = holding_with(Level::Warning);
    core.seq.home_ned_m = None;
    let mut out = Vec::new();
    assert!(matches!(
        core.battery_failsafe(&est, 1000 * S, &mut out),
        Some(Phase::Landing { .. })
    ));
}

#[test]
fn the_failsafe_waits_for_a_roll_and_leaves_the_pilot_and_the_ground_alone() {
    let (mut core, est) = holding_with(Level::Warning);
    let mut out = Vec::new();
    // A good pack: nothing.
    let (mut good, _) = holding_with(Level::Good);
    assert_eq!(good.battery_failsafe(&est, 1000 * S, &mut out), None);
    // Rolling: finished first.
    let target = Target::hold(est.pos_ned_m, 0.5);
    core.seq.phase = Phase::Maneuver {
        target,
        stage: RollStage::Rolling {
            angle_rad: 1.0,
            since_us: 0,
        },
        rolls_done: 0,
    };
    assert_eq!(core.battery_failsafe(&est, 1000 * S, &mut out), None);
    // Out of the roll (recovering): acted on.
    core.seq.phase = Phase::Maneuver {
        target,
        stage: RollStage::Recover { since_us: 0 },
        rolls_done: 1,
    };
    assert!(core.battery_failsafe(&est, 1000 * S, &mut out).is_some());
    // The pilot flies: told, not acted on.
    let (mut core, est) = holding_with(Level::Warning);
    core.seq.phase = Phase::Manual;
    assert_eq!(core.battery_failsafe(&est, 1000 * S, &mut out), None);
    // Never airborne: not acted on.
    let (mut core, est) = holding_with(Level::Warning);
    core.seq.airborne_once = false;
    assert_eq!(core.battery_failsafe(&est, 1000 * S, &mut out), None);
    // Already landing: goes on, and the level counts as acted on.
    let (mut core, est) = holding_with(Level::Critical);
    core.seq.phase = degraded::land_where_it_is(&est);
    assert_eq!(core.battery_failsafe(&est, 1000 * S, &mut out), None);
    core.seq.phase = Phase::Holding {
        target,
        since_us: 0,
    };
    assert_eq!(core.battery_failsafe(&est, 1001 * S, &mut out), None);
}

#[test]
fn the_first_hot_swap_reading_on_the_flight_pack_keeps_its_gauge() {
    // Only a pack coming back on the bus (ground to flight) starts its gauge again: the
    // line read for the first time, already high, is no swap.
    let mut core = core();
    let mut out = Vec::new();
    battery(&mut core, &mut out, 0, 5, 12.2);
    core.handle(Input::PowerSource(PowerSource::Flight), 6 * S, &mut out);
    assert!(core.power().state(Battery::Flight).is_some());
}

#[test]
fn a_pack_draining_abnormally_is_raised_once() {
    let mut core = core();
    let mut out = Vec::new();
    // A minute as expected, then the voltage falls far faster than the count allows.
    battery(&mut core, &mut out, 0, 70, 12.4);
    battery(&mut core, &mut out, 70, 120, 11.2);
    let drains = out
        .iter()
        .filter(|a| {
            matches!(a, Action::Event(e) if e.value
                == CoreEvent::BatteryDrainingAbnormally { battery: Battery::Flight })
        })
        .count();
    assert_eq!(drains, 1);
    assert!(
        core.power()
            .state(Battery::Flight)
            .is_some_and(|s| s.draining_abnormally)
    );
}

#[test]
fn the_flight_batterys_channel_is_judged_and_watched_by_the_core() {
    let mut core = core();
    let mut out = Vec::new();
    battery(&mut core, &mut out, 0, 5, 12.4);
    // A garbled reading of the flight battery is refused, not the pack's.
    core.handle(Input::Battery { volts: 3.0 }, 5 * S, &mut out);
    assert_eq!(core.power().channel().refused(), 1);
    let raised = |out: &[Action], fault: fn(&ReadingFault) -> bool| {
        out.iter().any(|a| {
            matches!(a, Action::Event(e) if matches!(&e.value, CoreEvent::BatteryReading { battery: Battery::Flight, fault: f } if fault(f)))
        })
    };
    assert!(raised(&out, |f| matches!(f, ReadingFault::Garbled { .. })));
    // The receiver's readings (the uplink's) are not the channel's.
    let mut pilot = super::tests::uplink(false, false);
    for k in 0..5u64 {
        pilot.receiver_batt_v = if k % 2 == 0 { 5.1 } else { 3.0 };
        core.handle(Input::Uplink(pilot), (6 + k) * S, &mut out);
    }
    assert_eq!(core.power().channel().refused(), 1);
    // No reading for more than 3 s, at the control steps: late.
    let mut out = Vec::new();
    for k in 0..500u64 {
        core.handle(
            Input::Imu(super::tests::still()),
            11 * S + k * 10_000,
            &mut out,
        );
    }
    assert!(
        raised(&out, |f| matches!(f, ReadingFault::Late { .. })),
        "{out:?}"
    );
}

#[test]
fn on_the_ground_battery_the_channel_is_read_on_time_not_late() {
    // The flight pack's readings, then the ground battery plugged in: its readings are not
    // judged, but they come once a second, and the channel is not said to be late.
    let mut core = core();
    let mut out = Vec::new();
    battery(&mut core, &mut out, 0, 5, 12.4);
    core.handle(Input::PowerSource(PowerSource::Ground), 5 * S, &mut out);
    let mut out = Vec::new();
    for k in 0..1000u64 {
        let now_us = 6 * S + k * 10_000;
        core.handle(Input::Imu(super::tests::still()), now_us, &mut out);
        if k % 100 == 0 {
            core.handle(Input::Battery { volts: 12.9 }, now_us, &mut out);
        }
    }
    assert!(
        !out.iter().any(|a| matches!(
            a,
            Action::Event(e) if matches!(e.value, CoreEvent::BatteryReading { .. })
        )),
        "{out:?}"
    );
}
