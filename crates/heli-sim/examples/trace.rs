//! Prints truth against estimate once a second for a scenario: a quick look at a flight.
//!
//! `cargo run --release -p heli-sim --example trace -- [scenario] [period_s]`

use heli_sim::lockstep::Simulation;

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "hover".into());
    let period_s: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1.0);
    let scenario = heli_scenario::load(&name).unwrap_or_else(|e| panic!("{e}"));
    let end_us = (scenario.duration_s * 1e6) as u64;
    let mut sim = Simulation::new(scenario).unwrap_or_else(|e| panic!("{e}"));
    let mut next = 0u64;
    let only_above_deg: f64 = std::env::var("TRACE_ATT_ABOVE_DEG")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(-1.0);
    println!(
        "t_s phase | true n e d | est n e d | true roll pitch yaw | est roll pitch yaw | servo ail ele rud col"
    );
    while sim.advance(end_us) {
        if sim.now_us() < next {
            continue;
        }
        next += (period_s * 1e6) as u64;
        let truth = sim.helicopter().state;
        let (tr, tp, ty) = truth.att.euler_angles();
        let Some(state) = sim.streams().state.latest() else {
            continue;
        };
        let est = state.value.nav;
        let (er, ep, ey) = est.att.euler_angles();
        let att_err_deg = (est.att.inverse() * truth.att).angle().to_degrees();
        if att_err_deg < only_above_deg {
            continue;
        }
        let servo = sim
            .streams()
            .servo
            .latest()
            .map(|s| s.value.controls)
            .unwrap_or_default();
        println!(
            "{:7.2} {:9} {:5.2} | {:7.2} {:7.2} {:7.2} | {:7.2} {:7.2} {:7.2} | {:6.1} {:6.1} {:6.1} | {:6.1} {:6.1} {:6.1} | {:5.2} {:5.2} {:5.2} {:5.2}",
            sim.now_us() as f64 * 1e-6,
            state.value.phase.name(),
            att_err_deg,
            truth.pos_ned_m.x,
            truth.pos_ned_m.y,
            truth.pos_ned_m.z,
            est.pos_ned_m.x,
            est.pos_ned_m.y,
            est.pos_ned_m.z,
            tr.to_degrees(),
            tp.to_degrees(),
            ty.to_degrees(),
            er.to_degrees(),
            ep.to_degrees(),
            ey.to_degrees(),
            servo.aileron,
            servo.elevator,
            servo.rudder,
            servo.collective
        );
    }
}
