//! The model against the published reference numbers (H15, heli-model.md §5–7), through the
//! same actuators the simulator flies with.

use heli_model::actuators::{Actuators, ServoParams, control_inputs};
use heli_model::analysis::trimmed_helicopter;
use heli_model::model::Environment;
use heli_model::params::{Airframe, Atmosphere};
use heli_proto::scb::Controls;
use nalgebra::Vector3;

#[test]
fn full_lateral_cyclic_from_hover_rolls_at_about_193_deg_per_second() {
    let airframe = Airframe::default();
    let (mut heli, trim) = trimmed_helicopter(&airframe, 0.0).unwrap_or_else(|| panic!("no trim"));
    let env = Environment {
        wind_ned_mps: Vector3::zeros(),
        atmosphere: Atmosphere::default(),
    };
    let trim_servo = Controls {
        aileron: trim.lat_rad / airframe.cyclic_max_rad,
        elevator: trim.lon_rad / airframe.cyclic_max_rad,
        rudder: trim.tail_rad / airframe.tail_max_rad,
        collective: trim.col_rad / airframe.collective_max_rad,
        throttle: 0.8,
    };
    let mut servos = Actuators::settled(ServoParams::default(), &trim_servo);
    let command = Controls {
        aileron: 1.0,
        ..trim_servo
    };
    let dt = 0.002;
    let mut rates = Vec::new();
    let mut speed_at_window_end = 0.0;
    for k in 0..=300 {
        let u = control_inputs(&airframe, &servos.positions());
        heli.step(dt, &u, &env);
        servos.step(dt, &command);
        rates.push((k as f64 * dt, heli.state.rate_body_rps.x.to_degrees()));
        speed_at_window_end = heli.state.vel_ned_mps().xy().norm();
    }
    // The roll rate settles within a few flapping time constants (0.12 s) and the servo lag;
    // average it over 0.3–0.6 s, before the bank has turned thrust into side speed.
    let window: Vec<f64> = rates
        .iter()
        .filter(|(t, _)| *t >= 0.3 && *t <= 0.6)
        .map(|(_, p)| *p)
        .collect();
    let steady = window.iter().sum::<f64>() / window.len() as f64;
    assert!(
        (steady / 193.0 - 1.0).abs() <= 0.15,
        "steady roll rate {steady:.1} deg/s"
    );
    // Still slow at the end of the window: horizontal speed, which sets the advance ratio
    // that the speed derivatives of the flapping act on, is small (μ below 0.03). The
    // helicopter does sink, with its thrust turned sideways.
    assert!(
        speed_at_window_end < 4.0,
        "speed had built up: {speed_at_window_end} m/s"
    );
    println!("steady roll rate {steady:.1} deg/s, speed {speed_at_window_end:.2} m/s");
}
