//! Cost of the X-Cell 60 model: one RK4 step (four derivative evaluations, each with the main-
//! and tail-rotor inflow iterations), one inflow solution, and one simulated second of the
//! whole lockstep system. `cargo bench -p heli-sim --bench model`; results in docs/BENCHMARKS.md.

use heli_model::analysis::trimmed_helicopter;
use heli_model::model::Environment;
use heli_model::params::{Airframe, Atmosphere};
use heli_sim::lockstep::Simulation;
use nalgebra::Vector3;

fn main() {
    divan::main();
}

fn still_air() -> Environment {
    Environment {
        wind_ned_mps: Vector3::zeros(),
        atmosphere: Atmosphere::default(),
    }
}

#[divan::bench]
fn model_step_rk4(bencher: divan::Bencher) {
    let airframe = Airframe::default();
    let (heli, u) = trimmed_helicopter(&airframe, 5.0).unwrap_or_else(|| panic!("no trim"));
    let env = still_air();
    bencher
        .with_inputs(|| heli.clone())
        .bench_local_refs(|h| h.step(0.005, &u, &env));
}

#[divan::bench]
fn main_rotor_inflow_solution() -> f64 {
    let disk = Airframe::default().main_disk();
    let mu_z = divan::black_box(0.01);
    disk.solve(1.225, 167.5, 0.05, mu_z, 0.1, 0.03).thrust_n
}

#[divan::bench(sample_count = 10)]
fn lockstep_one_simulated_second_in_hover(bencher: divan::Bencher) {
    // Start from a run that has calibrated and taken off (100 s in), then time one more second.
    let mut sim = Simulation::new(heli_scenario::hover()).unwrap_or_else(|e| panic!("{e}"));
    while sim.advance(100_000_000) {}
    bencher
        .with_inputs(|| sim.clone())
        .bench_local_values(|mut s| {
            let end = s.now_us() + 1_000_000;
            while s.advance(end) {}
            s.now_us()
        });
}
