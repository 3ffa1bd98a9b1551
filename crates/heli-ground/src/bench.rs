//! `heli bench --link`: the MAVLink link on this machine's loopback. A vehicle end
//! (`heli_link::vehicle::VehicleLink` on a UDP socket, in a thread, serving an 8 MiB log
//! from memory) and a ground end (`heli_link::ground::GroundLink`) in this thread:
//!
//! - log download throughput: the whole log, signed, byte-checked, as `heli ground
//!   download` fetches it;
//! - command round trip: `MAV_CMD_SET_MESSAGE_INTERVAL` (answered by the link itself, so
//!   the figure is the link's and the sockets', not a flight process starting), 500 times.

use std::net::UdpSocket;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::client::unix_us;
use heli_link::ground::GroundLink;
use heli_link::logs::MemoryStore;
use heli_link::signing::Key;
use heli_link::vehicle::{VehicleLink, VehicleStatus};
use mavlink::dialects::common::{COMMAND_LONG_DATA, MavCmd, MavResult};
use serde::Serialize;
use std::io::{Error, Result};

/// Bytes of the benchmark's log.
const LOG_BYTES: usize = 8 << 20;
/// Command round trips timed.
const ROUND_TRIPS: usize = 500;

/// What `heli bench --link` measured.
#[derive(Serialize)]
pub struct LinkBench {
    /// Log size (bytes).
    pub log_bytes: usize,
    /// Download time (s).
    pub download_s: f64,
    /// Throughput (MB/s, 10⁶ bytes).
    pub download_mb_per_s: f64,
    /// Requests the ground sent (1 + asks for gaps).
    pub download_requests: u64,
    /// Command round trip (µs): p50, p99, max.
    pub command_rtt_us: [f64; 3],
}

/// Runs the benchmark.
pub fn measure() -> Result<LinkBench> {
    let key = Key::new([0x5a; 32]);
    let log: Vec<u8> = (0..LOG_BYTES).map(|i| (i * 131 % 251) as u8).collect();
    let store = MemoryStore {
        logs: vec![("bench.mcap".into(), log.clone())],
    };
    let vehicle_socket = UdpSocket::bind("127.0.0.1:0")
        .map_err(|e| Error::new(e.kind(), format!("binding the vehicle's socket: {e}")))?;
    let vehicle_addr = vehicle_socket.local_addr()?;
    vehicle_socket.set_read_timeout(Some(Duration::from_millis(10)))?;
    let stop = Arc::new(AtomicBool::new(false));
    let vehicle_stop = Arc::clone(&stop);
    let vehicle_key = key.clone();
    let vehicle = std::thread::spawn(move || {
        let mut link = VehicleLink::new(Some(vehicle_key), unix_us());
        let mut peer = None;
        let mut buf = [0u8; 2048];
        // The loop of `heli vehicle --link`'s thread (heli_vehicle::link).
        while !vehicle_stop.load(Ordering::Acquire) {
            let sending = link.sending_log();
            let _ = vehicle_socket.set_nonblocking(sending);
            while let Ok((n, from)) = vehicle_socket.recv_from(&mut buf) {
                peer = Some(from);
                let _ = link.receive(buf.get(..n).unwrap_or(&[]), unix_us(), &store);
                let _ = vehicle_socket.set_nonblocking(true);
            }
            let _ = link.tick(unix_us(), VehicleStatus::default(), None, &store);
            if let Some(peer) = peer {
                for d in link.take_outgoing() {
                    let _ = vehicle_socket.send_to(&d, peer);
                }
            }
            if sending {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    });
    let socket = UdpSocket::bind("127.0.0.1:0")?;
    socket.set_read_timeout(Some(Duration::from_millis(10)))?;
    let mut ground = GroundLink::new(Some(key));
    let mut buf = [0u8; 2048];
    // As `heli ground` does: wait for the first datagram, then take the rest at once.
    let mut pump = |ground: &mut GroundLink| {
        let _ = socket.set_nonblocking(false);
        while let Ok(n) = socket.recv(&mut buf) {
            ground.receive(buf.get(..n).unwrap_or(&[]), unix_us());
            let _ = socket.set_nonblocking(true);
        }
    };
    // Round trips.
    let mut rtts = Vec::with_capacity(ROUND_TRIPS);
    for i in 0..ROUND_TRIPS {
        let cmd = COMMAND_LONG_DATA {
            command: MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            param1: 30.0,
            param2: if i % 2 == 0 { 200_000.0 } else { 0.0 },
            ..Default::default()
        };
        let before = ground.acks.len();
        let t0 = Instant::now();
        let frame = ground.command_frame(cmd, unix_us());
        socket.send_to(&frame, vehicle_addr)?;
        while ground.acks.len() == before {
            if t0.elapsed() > Duration::from_secs(2) {
                return Err(Error::other("no acknowledgement in 2 s"));
            }
            pump(&mut ground);
        }
        if ground.acks.last().map(|a| a.1) != Some(MavResult::MAV_RESULT_ACCEPTED) {
            return Err(Error::other(format!(
                "command refused: {:?}",
                ground.acks.last()
            )));
        }
        rtts.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    rtts.sort_by(f64::total_cmp);
    let pct = |p: f64| {
        let i = ((rtts.len() as f64 - 1.0) * p).round() as usize;
        rtts.get(i).copied().unwrap_or(f64::NAN)
    };
    let command_rtt_us = [
        pct(0.5),
        pct(0.99),
        rtts.last().copied().unwrap_or(f64::NAN),
    ];
    // Download.
    let t0 = Instant::now();
    let req = ground.start_download(1, LOG_BYTES as u32, unix_us());
    socket.send_to(&req, vehicle_addr)?;
    loop {
        pump(&mut ground);
        if let Some(again) = ground.download_tick(unix_us()) {
            socket.send_to(&again, vehicle_addr)?;
        }
        if ground.download.as_ref().is_some_and(|d| d.complete()) {
            break;
        }
        if t0.elapsed() > Duration::from_secs(300) {
            return Err(Error::other("the download did not finish in 300 s"));
        }
    }
    let download_s = t0.elapsed().as_secs_f64();
    stop.store(true, Ordering::Release);
    let _ = vehicle.join();
    let dl = ground
        .download
        .take()
        .ok_or_else(|| Error::other("no download"))?;
    if dl.bytes != log {
        return Err(Error::other("the downloaded log differs"));
    }
    Ok(LinkBench {
        log_bytes: LOG_BYTES,
        download_s,
        download_mb_per_s: LOG_BYTES as f64 / download_s / 1e6,
        download_requests: dl.requests,
        command_rtt_us,
    })
}

/// Prints the measurement.
pub fn print(b: &LinkBench) {
    println!(
        "log download   {:.1} MiB in {:.2} s: {:.2} MB/s, signed, byte-exact ({} requests)",
        b.log_bytes as f64 / 1048576.0,
        b.download_s,
        b.download_mb_per_s,
        b.download_requests
    );
    println!(
        "command RTT    p50 {:.0} us, p99 {:.0} us, max {:.0} us ({ROUND_TRIPS} SET_MESSAGE_INTERVAL round trips)",
        b.command_rtt_us[0], b.command_rtt_us[1], b.command_rtt_us[2]
    );
}
