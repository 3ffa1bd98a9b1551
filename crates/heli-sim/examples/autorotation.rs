//! The autorotation's tuning bench: flies an engine-failure scenario with chosen
//! autorotation gains and prints the descent, or sweeps a grid of gains and prints the
//! softest touchdowns.
//!
//! ```text
//! cargo run --release -p heli-sim --example autorotation -- trace FILE [key=value ...]
//! cargo run --release -p heli-sim --example autorotation -- sweep FILE [key=v1,v2,... ...]
//! ```
//!
//! Keys are the fields of `AutorotationGains` (`glide_speed_mps=10`, ...).

use heli_control::autorotation::AutorotationGains;
use heli_fsw::core::CoreConfig;
use heli_scenario::Scenario;
use heli_sim::lockstep::Simulation;

/// The gain named `key`.
fn slot<'a>(g: &'a mut AutorotationGains, key: &str) -> &'a mut f64 {
    match key {
        "rotor_target_rpm" => &mut g.rotor_target_rpm,
        "glide_collective" => &mut g.glide_collective,
        "rotor_to_collective" => &mut g.rotor_to_collective,
        "rotor_integral" => &mut g.rotor_integral,
        "min_collective" => &mut g.min_collective,
        "glide_speed_mps" => &mut g.glide_speed_mps,
        "glide_max_tilt_rad" => &mut g.glide_max_tilt_rad,
        "glide_rotor_band_rpm" => &mut g.glide_rotor_band_rpm,
        "entry_pitch_rad" => &mut g.entry_pitch_rad,
        "flare_height_m" => &mut g.flare_height_m,
        "level_height_m" => &mut g.level_height_m,
        "flare_max_tilt_rad" => &mut g.flare_max_tilt_rad,
        "flare_decel_per_mps" => &mut g.flare_decel_per_mps,
        "cushion_decel_mps2" => &mut g.cushion_decel_mps2,
        "hover_auto_height_m" => &mut g.hover_auto_height_m,
        "hover_cushion_decel_mps2" => &mut g.hover_cushion_decel_mps2,
        "touchdown_sink_mps" => &mut g.touchdown_sink_mps,
        "touchdown_height_m" => &mut g.touchdown_height_m,
        "sink_to_collective" => &mut g.sink_to_collective,
        "cushion_collective" => &mut g.cushion_collective,
        "upset_collective" => &mut g.upset_collective,
        "upset_tilt_rad" => &mut g.upset_tilt_rad,
        "upset_rate_rps" => &mut g.upset_rate_rps,
        other => panic!("unknown gain {other}"),
    }
}

/// Touchdown sink, ground speed, tilt at contact, lowest rotor rpm after the failure, crash.
struct Outcome {
    sink_mps: f64,
    speed_mps: f64,
    tilt_deg: f64,
    min_rpm: f64,
    crash: Option<String>,
}

fn fly(s: &Scenario, gains: AutorotationGains, trace: bool) -> Outcome {
    let config = CoreConfig {
        autorotation: gains,
        ..CoreConfig::default()
    };
    let fail_us = s
        .faults
        .engine
        .first()
        .map_or(0, |f| (f.start_s * 1e6) as u64);
    let mut sim =
        Simulation::with_flight_software(s.clone(), config).unwrap_or_else(|e| panic!("{e}"));
    let end_us = (s.duration_s * 1e6) as u64;
    let mut next = fail_us.saturating_sub(500_000);
    let mut min_rpm = f64::INFINITY;
    let mut was_airborne = false;
    let mut first_contact_us: Option<u64> = None;
    let mut out = Outcome {
        sink_mps: f64::NAN,
        speed_mps: f64::NAN,
        tilt_deg: f64::NAN,
        min_rpm: f64::NAN,
        crash: None,
    };
    while sim.advance(end_us) {
        let h = sim.helicopter();
        let st = h.state;
        let rpm = st.rotor_rps * 30.0 / std::f64::consts::PI;
        let vel = st.vel_ned_mps();
        let up = st.att * nalgebra::Vector3::new(0.0, 0.0, -1.0);
        let tilt_deg = (-up.z).clamp(-1.0, 1.0).acos().to_degrees();
        if sim.now_us() >= fail_us {
            if first_contact_us.is_none() {
                min_rpm = min_rpm.min(rpm);
            }
            let on_ground = h.outputs.contact_points > 0;
            if on_ground && was_airborne && first_contact_us.is_none() {
                first_contact_us = Some(sim.now_us());
                out.speed_mps = vel.xy().norm();
                out.tilt_deg = tilt_deg;
                out.sink_mps = 0.0;
            }
            if let Some(t0) = first_contact_us
                && sim.now_us() < t0 + 500_000
                && on_ground
            {
                out.sink_mps = out.sink_mps.max(h.outputs.contact_sink_mps);
            }
            was_airborne |= !on_ground;
            if !out.sink_mps.is_nan() && sim.now_us() > fail_us + 30_000_000 {
                break;
            }
        }
        if trace && sim.now_us() >= next {
            next += 100_000;
            let (r, p, _) = st.att.euler_angles();
            let phase = sim
                .streams()
                .state
                .latest()
                .map(|s| s.value.phase.name())
                .unwrap_or("-");
            let c = sim.servo_positions();
            println!(
                "{:7.2} {:12} h {:6.2} vz {:6.2} vh {:6.2} rpm {:5.0} roll {:6.1} pitch {:6.1} col {:5.2} ele {:5.2} T {:5.1} Q {:5.1} lam {:6.3}",
                sim.now_us() as f64 * 1e-6,
                phase,
                -st.pos_ned_m.z,
                vel.z,
                vel.xy().norm(),
                rpm,
                r.to_degrees(),
                p.to_degrees(),
                c.collective,
                c.elevator,
                h.outputs.thrust_n,
                h.outputs.mr_torque_nm,
                h.outputs.inflow_ratio
            );
        }
    }
    out.min_rpm = min_rpm;
    out.crash = sim.crash().map(str::to_string);
    out
}

/// Lower is better: the touchdown sink, a crash counted as 10 m/s more.
fn score(o: &Outcome) -> f64 {
    if o.sink_mps.is_nan() {
        99.0
    } else {
        o.sink_mps + if o.crash.is_some() { 10.0 } else { 0.0 }
    }
}

/// Flies seeds 1..=n with one gain set: crashes, soft landings (at most 1.5 m/s), the
/// sinks' median, 90th percentile and worst, the lowest rotor speed.
fn over_seeds(s: &Scenario, g: AutorotationGains, n: u64, label: &str) -> (f64, String) {
    let mut outs: Vec<Outcome> = (1..=n)
        .map(|seed| {
            let mut s = s.clone();
            s.seed = seed;
            fly(&s, g, false)
        })
        .collect();
    let crashes = outs.iter().filter(|o| o.crash.is_some()).count();
    let soft = outs
        .iter()
        .filter(|o| o.crash.is_none() && o.sink_mps <= 1.5)
        .count();
    outs.sort_by(|a, b| score(a).total_cmp(&score(b)));
    let at = |q: f64| score(&outs[((outs.len() - 1) as f64 * q).round() as usize]);
    let min_rpm = outs.iter().map(|o| o.min_rpm).fold(f64::INFINITY, f64::min);
    let line = format!(
        "soft {soft:3}/{n} crash {crashes:3} sink p50 {:5.2} p90 {:5.2} max {:5.2} min_rpm {min_rpm:5.0} | {label}",
        at(0.5),
        at(0.9),
        at(1.0)
    );
    (at(0.9) + (n as usize - soft) as f64 * 0.01, line)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let cmd = args.next().unwrap_or_else(|| "trace".into());
    let file = args.next().unwrap_or_else(|| panic!("scenario file"));
    let s = heli_scenario::load(&file).unwrap_or_else(|e| panic!("{e}"));
    let pairs: Vec<(String, Vec<f64>)> = args
        .map(|a| {
            let (k, v) = a
                .split_once('=')
                .unwrap_or_else(|| panic!("{a}: key=value"));
            let vals = v
                .split(',')
                .map(|x| x.parse().unwrap_or_else(|_| panic!("{x}")))
                .collect();
            (k.to_string(), vals)
        })
        .collect();
    let mut grid = vec![AutorotationGains::default()];
    for (k, vals) in &pairs {
        grid = grid
            .iter()
            .flat_map(|g| {
                vals.iter().map(move |v| {
                    let mut g = *g;
                    *slot(&mut g, k) = *v;
                    g
                })
            })
            .collect();
    }
    let trace = cmd == "trace";
    // SEEDS=N flies each gain set with seeds 1..=N and scores it on the worst touchdowns.
    let seeds: u64 = std::env::var("SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    let mut results: Vec<(f64, String)> = grid
        .iter()
        .map(|g| {
            let label: Vec<String> = pairs
                .iter()
                .map(|(k, _)| format!("{k}={}", *slot(&mut g.clone(), k)))
                .collect();
            if seeds > 0 {
                return over_seeds(&s, *g, seeds, &label.join(" "));
            }
            let o = fly(&s, *g, trace);
            let line = format!(
                "sink {:5.2} speed {:5.2} tilt {:5.1} min_rpm {:5.0} {} | {}",
                o.sink_mps,
                o.speed_mps,
                o.tilt_deg,
                o.min_rpm,
                o.crash.as_deref().unwrap_or(""),
                label.join(" ")
            );
            (score(&o), line)
        })
        .collect();
    results.sort_by(|a, b| a.0.total_cmp(&b.0));
    let top: usize = std::env::var("SWEEP_TOP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(25);
    for (_, line) in results.iter().take(top) {
        println!("{line}");
    }
}
