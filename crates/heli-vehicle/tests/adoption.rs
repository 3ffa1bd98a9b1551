//! A bootstrap started again takes back the flight process that flew on without it
//! (`heli_vehicle::adopt`), with a stand-in flight process: a thread of this test listening on
//! the adoption socket, introducing itself with the pid of a real process (`sleep`) that the
//! test ends when the stand-in "exits".

#![allow(clippy::unwrap_used, clippy::panic, clippy::indexing_slicing)]

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, Command};
use std::sync::mpsc::{Receiver, channel};
use std::time::Duration;

use common::{Running, crashing_child, status, wait_until};
use heli_vehicle::adopt;
use heli_vehicle::bootstrap::BootstrapConfig;

fn config(
    dir: &Path,
    child: Vec<std::ffi::OsString>,
    warm: Vec<std::path::PathBuf>,
) -> BootstrapConfig {
    let socket = dir.join("ctl.sock");
    BootstrapConfig {
        adopt_socket: Some(adopt::socket_for(&socket)),
        socket,
        child,
        warm_files: warm,
    }
}

/// A process standing for the flight process's pid.
fn stand_in_process() -> Child {
    Command::new("sleep").arg("60").spawn().unwrap()
}

/// A flight process flying on without a bootstrap: it introduces itself to the first that
/// connects, sends what it is given in `lines` first, then answers `stop` with `stopped`;
/// everything it was told comes back on the receiver. `crash` ends it without a word
/// after its introduction (the socket closes, the process dies).
fn flying_on(dir: &Path, pid: u32, crash: bool) -> Receiver<String> {
    let listener = adopt::listen(&adopt::socket_for(&dir.join("ctl.sock"))).unwrap();
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        write!(
            stream,
            "ready {}\nadopted {pid} t1 autonomous hover\nstarted /logs/flight_t1.mcap\ntelemetry {{\"t_us\":7}}\n",
            heli_vehicle::supervisor::VERSION
        )
        .unwrap();
        if crash {
            return;
        }
        for line in BufReader::new(stream.try_clone().unwrap()).lines() {
            let line = line.unwrap();
            let stop = line == "stop";
            let _ = tx.send(line);
            if stop {
                writeln!(stream, "stopped {{}}").unwrap();
                return;
            }
        }
    });
    rx
}

#[test]
fn a_flight_flying_on_is_taken_back_and_stopped_by_the_new_bootstrap() {
    let dir = tempfile::tempdir().unwrap();
    let mut process = stand_in_process();
    let told = flying_on(dir.path(), process.id(), false);
    let boot = Running::start_config(config(dir.path(), Vec::new(), Vec::new()), |b| b);
    boot.wait_count("took back the flight process", 1, Duration::from_secs(5));
    assert_eq!(
        boot.count(&format!(
            "took back the flight process (pid {}) flying t1 autonomous hover",
            process.id()
        )),
        1
    );
    let s = status(&boot);
    assert_eq!(s["state"], "flying", "{s}");
    assert_eq!(s["pid"].as_u64(), Some(u64::from(process.id())));
    assert_eq!(s["log"], "/logs/flight_t1.mcap");
    wait_until("telemetry heard", Duration::from_secs(5), || {
        status(&boot)["telemetry"]["t_us"] == 7
    });
    // Stop goes over the socket; the process ends after saying stopped.
    let stopping = std::thread::spawn(move || {
        let line = told.recv_timeout(Duration::from_secs(5)).unwrap();
        std::thread::sleep(Duration::from_millis(100));
        process.kill().unwrap();
        process.wait().unwrap();
        line
    });
    let reply = boot.ctl("stop").unwrap();
    assert_eq!(stopping.join().unwrap(), "stop");
    assert_eq!(
        reply,
        "ok stopped (ended after saying stopped; taken back, its exit status went to the init system)"
    );
    assert_eq!(status(&boot)["state"], "idle");
}

#[test]
fn a_taken_back_flight_process_that_crashes_is_restarted_with_its_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let mut process = stand_in_process();
    let pid = process.id();
    let _ = flying_on(dir.path(), pid, true);
    let boot = Running::start_config(config(dir.path(), crashing_child(&told), Vec::new()), |b| b);
    boot.wait_count("took back the flight process", 1, Duration::from_secs(5));
    // Its socket is closed, but the process still runs: it is still flying, and no second
    // one may be started beside it.
    std::thread::sleep(Duration::from_millis(700));
    assert_eq!(
        boot.count("CRASHED"),
        0,
        "{:#?}",
        boot.lines.lock().unwrap()
    );
    assert_eq!(boot.count("restarting"), 0);
    process.kill().unwrap();
    process.wait().unwrap();
    boot.wait_count(
        "CRASHED: ended without saying stopped",
        1,
        Duration::from_secs(5),
    );
    boot.wait_count("restarting the flight process", 1, Duration::from_secs(5));
    wait_until("the restart told", Duration::from_secs(5), || told.exists());
    let text = std::fs::read_to_string(&told).unwrap();
    assert_eq!(text.lines().next(), Some("restart t1 autonomous hover"));
}

#[test]
fn a_live_flight_process_that_cannot_be_taken_back_is_left_alone_and_none_is_started() {
    let dir = tempfile::tempdir().unwrap();
    // It answers the connection but never introduces itself.
    let listener = adopt::listen(&adopt::socket_for(&dir.path().join("ctl.sock"))).unwrap();
    let held = std::thread::spawn(move || {
        let (stream, _) = listener.accept().unwrap();
        std::thread::sleep(Duration::from_secs(5));
        drop(stream);
    });
    // Even with a fresh record of a helicopter in the air.
    let warm = dir.path().join("warm-start");
    std::fs::write(
        &warm,
        "start = t1 autonomous hover\nairborne = true\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    let told = dir.path().join("told");
    let boot = Running::start_config(config(dir.path(), crashing_child(&told), vec![warm]), |b| b);
    boot.wait_count("could not be taken back", 1, Duration::from_secs(10));
    assert_eq!(boot.count("not starting another"), 1);
    assert_eq!(boot.count("flight process started"), 0);
    assert_eq!(status(&boot)["state"], "idle");
    held.join().unwrap();
}

#[test]
fn with_no_flight_process_the_freshest_readable_warm_start_record_resumes_the_flight() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    // The log directory's record is old news (grounded); the fallback's, written later,
    // says airborne; a third, the freshest, is unreadable.
    let older = dir.path().join("warm-start");
    std::fs::write(
        &older,
        "start = t0 manual\nairborne = false\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(30));
    let fallback = dir.path().join("fallback-warm-start");
    std::fs::write(
        &fallback,
        "start = t2 autonomous rolls\nairborne = true\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(30));
    let broken = dir.path().join("broken-warm-start");
    std::fs::write(&broken, "start = \n").unwrap();
    // A stale adoption socket (its process died) is nothing to take back.
    drop(adopt::listen(&adopt::socket_for(&dir.path().join("ctl.sock"))).unwrap());
    let boot = Running::start_config(
        config(
            dir.path(),
            crashing_child(&told),
            vec![older, fallback.clone(), broken],
        ),
        |b| b,
    );
    boot.wait_count("resuming the flight in the air", 1, Duration::from_secs(5));
    assert_eq!(boot.count("warm-start record unreadable"), 1);
    assert_eq!(boot.count(&fallback.display().to_string()), 1);
    wait_until("the restart told", Duration::from_secs(5), || told.exists());
    let text = std::fs::read_to_string(&told).unwrap();
    assert_eq!(text.lines().next(), Some("restart t2 autonomous rolls"));
}
