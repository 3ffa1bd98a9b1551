//! Every device fault of the catalog acts where the flight computer sees it: each test flies
//! the hover twice on one seed, with and without the fault, and decodes what the computer
//! received from the device over the fault's window.

use heli_fsw::RecordedInput;
use heli_proto::baro::{BaroReply, reply_framer};
use heli_proto::gps::{GpsFramer, GpsNav};
use heli_proto::imu::{ImuFramer, ImuRepr};
use heli_proto::scb::{PilotUplink, UplinkFramer};
use heli_scenario::faults::{Device, DeviceFault, DeviceFaultKind};
use heli_scenario::{self as scenario, Scenario};
use heli_sim::Simulation;
use heli_types::Port;

/// The fault window of every test (s): the hover is holding by then.
const START_S: f64 = 110.0;
const END_S: f64 = 116.0;

/// What the computer received from one device over the window, in order, with times (µs):
/// each decoded reading as numbers, and the raw frames.
#[derive(Debug, Default)]
struct Received {
    readings: Vec<(u64, Vec<f64>)>,
    frames: Vec<Vec<u8>>,
    bytes: usize,
}

fn fly(faults: Vec<DeviceFault>, until_s: f64) -> Simulation {
    let mut s: Scenario = scenario::hover();
    s.faults.devices = faults;
    let mut sim = Simulation::new(s).unwrap_or_else(|e| panic!("{e}"));
    sim.record_flight_software();
    while sim.advance((until_s * 1e6) as u64) {}
    sim
}

fn fault(device: Device, kind: DeviceFaultKind, value: f64, rate: f64) -> DeviceFault {
    DeviceFault {
        device,
        kind,
        start_s: START_S,
        end_s: END_S,
        value,
        rate,
        period_s: 0.0,
        duty: 1.0,
    }
}

/// Decodes what `device` delivered from `from_s` to `to_s` (a little after, for delays).
fn received(sim: &Simulation, device: Device, from_s: f64, to_s: f64) -> Received {
    let inputs = &sim.recording().unwrap_or_else(|| panic!("recorded")).inputs;
    let window = (from_s * 1e6) as u64..(to_s * 1e6) as u64;
    let mut out = Received::default();
    let mut imu = ImuFramer::new();
    let mut gps = GpsFramer::new();
    let mut uplink = UplinkFramer::new();
    let mut baro = reply_framer();
    for (t, input) in inputs {
        match (device, input) {
            (Device::Compass, RecordedInput::Compass(adc)) if window.contains(t) => {
                out.readings
                    .push((*t, adc.raw_field().field_gauss.to_vec()));
                out.frames
                    .push(adc.counts.iter().flat_map(|c| c.to_le_bytes()).collect());
            }
            (_, RecordedInput::Bytes(port, bytes)) => {
                let mine = matches!(
                    (device, port),
                    (Device::Imu, Port::Imu)
                        | (Device::Gps, Port::Gps)
                        | (Device::Baro, Port::Baro)
                        | (Device::Uplink, Port::Scb)
                );
                if !mine {
                    continue;
                }
                for &b in bytes {
                    let reading = match device {
                        Device::Imu => imu.push(b).map(|f| {
                            let r = ImuRepr::parse(f).ok();
                            (f.to_vec(), r.map(|r| r.rate_rps.to_vec()))
                        }),
                        Device::Gps => gps.push(b).map(|f| {
                            let r = GpsNav::parse(f).ok();
                            (f.to_vec(), r.map(|r| vec![r.lat_deg, r.lon_deg, r.alt_m]))
                        }),
                        Device::Uplink => uplink.push(b).map(|f| {
                            let r = PilotUplink::parse(f).ok();
                            (f.to_vec(), r.map(|r| vec![f64::from(r.rotor_rpm)]))
                        }),
                        Device::Baro => baro.push(b).map(|f| {
                            let r = match BaroReply::parse(f) {
                                Ok(BaroReply::Pressure { pressure_mbar }) => {
                                    Some(vec![pressure_mbar])
                                }
                                _ => None,
                            };
                            (f.to_vec(), r)
                        }),
                        _ => None,
                    };
                    if !window.contains(t) {
                        continue;
                    }
                    out.bytes += 1;
                    if let Some((frame, reading)) = reading {
                        out.frames.push(frame);
                        if let Some(r) = reading {
                            out.readings.push((*t, r));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    out
}

/// Over the window, from when the first transmission sent in it can arrive (a GPS fix
/// arrives a second after its epoch).
fn clean_and_faulted(f: DeviceFault) -> (Received, Received) {
    let until = f.end_s + 1.0;
    let clean = fly(Vec::new(), until);
    let faulted = fly(vec![f], until);
    let from_s = f.start_s + FIRST_ARRIVAL_S;
    (
        received(&clean, f.device, from_s, f.end_s),
        received(&faulted, f.device, from_s, f.end_s),
    )
}

/// The longest a transmission takes to arrive (the GPS's latency, with margin).
const FIRST_ARRIVAL_S: f64 = 1.1;

/// Mean of the first number of each reading.
fn mean(r: &Received, i: usize) -> f64 {
    r.readings.iter().map(|(_, v)| v[i]).sum::<f64>() / r.readings.len().max(1) as f64
}

const SERIAL: [Device; 4] = [Device::Imu, Device::Gps, Device::Baro, Device::Uplink];

#[test]
fn an_off_device_delivers_nothing() {
    for device in SERIAL.into_iter().chain([Device::Compass]) {
        let (clean, off) = clean_and_faulted(fault(device, DeviceFaultKind::Off, 0.0, 0.0));
        assert!(!clean.frames.is_empty(), "{device:?} sends when healthy");
        assert!(off.frames.is_empty(), "{device:?}: {:?}", off.frames.len());
    }
}

#[test]
fn a_stuck_device_repeats_itself() {
    for device in SERIAL.into_iter().chain([Device::Compass]) {
        let mut f = fault(device, DeviceFaultKind::Stuck, 0.0, 0.0);
        if device == Device::Baro {
            // In a steady hover the altimeter's 0.1 m steps hardly change: judge the climb.
            (f.start_s, f.end_s) = (88.0, 100.0);
        }
        let (clean, stuck) = clean_and_faulted(f);
        let distinct = |r: &Received| {
            let mut f = r.frames.clone();
            f.sort();
            f.dedup();
            f.len()
        };
        assert!(distinct(&clean) > 2, "{device:?} varies when healthy");
        assert_eq!(
            distinct(&stuck),
            1,
            "{device:?} {:?}",
            &stuck.frames[..3.min(stuck.frames.len())]
        );
        // Still sending (a stuck IMU may end the flight early: the estimate is blind).
        assert!(stuck.frames.len() >= 4, "{device:?} {}", stuck.frames.len());
    }
}

#[test]
fn garbage_bytes_break_the_frames() {
    for device in SERIAL {
        let (clean, garbled) = clean_and_faulted(fault(device, DeviceFaultKind::Garbage, 0.0, 0.2));
        assert!(
            garbled.readings.len() * 2 < clean.readings.len(),
            "{device:?}: {} of {} readings survive",
            garbled.readings.len(),
            clean.readings.len()
        );
        assert!(garbled.bytes > 0, "{device:?}: bytes still arrive");
    }
}

#[test]
fn a_slow_device_sends_one_in_n() {
    for device in SERIAL.into_iter().chain([Device::Compass]) {
        let (clean, slow) = clean_and_faulted(fault(device, DeviceFaultKind::Slow, 4.0, 0.0));
        let (n, m) = (clean.frames.len() as f64, slow.frames.len() as f64);
        assert!(
            (m - n / 4.0).abs() <= 2.0,
            "{device:?}: {m} frames against {n} healthy"
        );
    }
}

#[test]
fn a_delayed_device_arrives_late() {
    // The stream stops for the delay when the fault begins, then goes on late: the longest
    // gap between arrivals grows by the delay.
    let gap = |faults: Vec<DeviceFault>, device: Device| {
        let sim = fly(faults, END_S + 1.0);
        let r = received(&sim, device, START_S - 1.0, START_S + 2.5);
        r.readings
            .windows(2)
            .map(|w| w[1].0 - w[0].0)
            .max()
            .unwrap_or_default()
    };
    for device in SERIAL {
        let healthy = gap(Vec::new(), device);
        let delayed = gap(
            vec![fault(device, DeviceFaultKind::Delayed, 0.3, 0.0)],
            device,
        );
        assert!(
            delayed >= healthy + 250_000,
            "{device:?}: longest gap {delayed} us against {healthy} us"
        );
    }
}

#[test]
fn wrong_readings_are_biased_scaled_and_spiked() {
    // IMU: rates biased by 0.05 rad/s on every axis; judged over the first 50 ms, before
    // the yaw loop answers the rate it believes in.
    let imu_bias = fault(Device::Imu, DeviceFaultKind::Bias, 0.05, 0.0);
    let first_packets = |faults| {
        received(
            &fly(faults, START_S + 0.1),
            Device::Imu,
            START_S,
            START_S + 0.05,
        )
    };
    let (clean, biased) = (first_packets(Vec::new()), first_packets(vec![imu_bias]));
    let shift = mean(&biased, 2) - mean(&clean, 2);
    assert!((shift - 0.05).abs() < 0.01, "IMU bias {shift}");
    // Altimeter: 20 m of bias is about 2.4 mbar less.
    let (clean, biased) = clean_and_faulted(fault(Device::Baro, DeviceFaultKind::Bias, 20.0, 0.0));
    let shift = mean(&biased, 0) - mean(&clean, 0);
    assert!((shift + 2.4).abs() < 0.3, "baro bias {shift} mbar");
    // Uplink: the rotor speed reading scaled by a half.
    let (clean, scaled) =
        clean_and_faulted(fault(Device::Uplink, DeviceFaultKind::Scale, 0.5, 0.0));
    let ratio = mean(&scaled, 0) / mean(&clean, 0);
    assert!((ratio - 0.5).abs() < 0.01, "rpm scale {ratio}");
    // GPS: 50 m spikes on a third of the fixes (50 m is 0.00045 deg of latitude).
    let (clean, spiked) =
        clean_and_faulted(fault(Device::Gps, DeviceFaultKind::Spikes, 50.0, 0.35));
    let jumps = spiked
        .readings
        .iter()
        .zip(&clean.readings)
        .filter(|((_, a), (_, b))| (a[0] - b[0]).abs() > 0.0003 || (a[1] - b[1]).abs() > 0.0004)
        .count();
    assert!(
        jumps >= 1 && jumps < spiked.readings.len(),
        "{jumps} spiked fixes"
    );
    // Compass: a 0.2 gauss bias on every axis.
    let (clean, biased) =
        clean_and_faulted(fault(Device::Compass, DeviceFaultKind::Bias, 0.2, 0.0));
    let shift = mean(&biased, 0) - mean(&clean, 0);
    assert!((shift - 0.2).abs() < 0.02, "compass bias {shift}");
}

#[test]
fn an_intermittent_fault_comes_and_goes() {
    let mut f = fault(Device::Gps, DeviceFaultKind::Off, 0.0, 0.0);
    f.period_s = 2.0;
    f.duty = 0.5;
    let (clean, flicker) = clean_and_faulted(f);
    let (n, m) = (clean.frames.len(), flicker.frames.len());
    assert!(m > 0 && m < n, "{m} of {n} fixes");
    // The computer notices and says so.
    let sim = fly(vec![f], END_S + 1.0);
    assert!(
        sim.computer().core().navigator().stats().gps_fused > 0,
        "fixes still fused between the gaps"
    );
}

#[test]
fn battery_faults_act_on_its_voltage_readings() {
    let min_v = |faults: Vec<DeviceFault>| {
        let mut s = scenario::hover();
        s.duration_s = 30.0;
        s.faults.devices = faults;
        heli_sim::run(s)
            .unwrap_or_else(|e| panic!("{e}"))
            .devices
            .battery_min_v
    };
    let window = |kind, value| DeviceFault {
        start_s: 10.0,
        end_s: 20.0,
        ..fault(Device::Battery, kind, value, 0.0)
    };
    let healthy = min_v(Vec::new()).unwrap_or(f64::NAN);
    let biased = min_v(vec![window(DeviceFaultKind::Bias, -3.0)]).unwrap_or(f64::NAN);
    assert!(
        (healthy - biased - 3.0).abs() < 0.05,
        "{healthy} V, biased {biased} V"
    );
    let scaled = min_v(vec![window(DeviceFaultKind::Scale, 0.5)]).unwrap_or(f64::NAN);
    assert!((scaled / healthy - 0.5).abs() < 0.02, "{scaled} V");
    let never = DeviceFault {
        start_s: 0.0,
        end_s: 1000.0,
        ..fault(Device::Battery, DeviceFaultKind::Off, 0.0, 0.0)
    };
    assert_eq!(min_v(vec![never]), None, "never read: not measured");
}

#[test]
fn a_nearly_empty_or_small_battery_reads_low() {
    let min_v = |battery: heli_scenario::faults::Battery| {
        let mut s = scenario::hover();
        s.duration_s = 60.0;
        s.battery = battery;
        heli_sim::run(s)
            .unwrap_or_else(|e| panic!("{e}"))
            .devices
            .battery_min_v
            .unwrap_or(f64::NAN)
    };
    let full = min_v(heli_scenario::faults::Battery::default());
    let low = min_v(heli_scenario::faults::Battery {
        charge: 0.1,
        ..Default::default()
    });
    // A tenth of a small pack under load empties within the minute.
    let tiny = min_v(heli_scenario::faults::Battery {
        capacity_ah: 0.03,
        ..Default::default()
    });
    assert!(
        full > 12.0 && low < full - 0.4,
        "full {full} V, at 10 % {low} V"
    );
    assert!(tiny < low - 1.0, "a 30 mAh pack: {tiny} V");
}
