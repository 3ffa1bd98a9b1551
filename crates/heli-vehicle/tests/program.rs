//! The onboard program end to end: `heli-vehicle` (the bootstrap) started as a lab starts
//! it, with a devices file naming pseudo-terminals, driven through its control socket by
//! `heli-vehicle ctl`: connect, start logging, the flight process's lines and events, the
//! status, stop, quit — and the log it leaves, with the settings it was given.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::arithmetic_side_effects
)]

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use heli_proto::imu::ImuRepr;
use serialport::{SerialPort, TTYPort};

const PROGRAM: &str = env!("CARGO_BIN_EXE_heli-vehicle");

/// A running bootstrap and every line it printed.
struct Bootstrap {
    child: Child,
    lines: Arc<Mutex<Vec<String>>>,
    socket: PathBuf,
}

impl Bootstrap {
    fn start(dir: &Path, devices: &Path, extra: &[&str]) -> Self {
        let socket = dir.join("ctl.sock");
        let mut child = Command::new(PROGRAM)
            .arg("--devices")
            .arg(devices)
            .arg("--log-dir")
            .arg(dir)
            .arg("--socket")
            .arg(&socket)
            .args([
                "--calibration-s",
                "0.5",
                "--warm-up-s",
                "0.1",
                "--baro-rate",
                "4",
                "--fly-untested",
            ])
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&lines);
        let out = child.stdout.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                sink.lock().unwrap().push(line);
            }
        });
        let bootstrap = Self {
            child,
            lines,
            socket,
        };
        bootstrap.wait_for("bootstrap: listening", Duration::from_secs(10));
        bootstrap
    }

    fn wait_for(&self, needle: &str, timeout: Duration) -> String {
        wait_in(&self.lines, needle, timeout)
    }

    fn ctl(&self, words: &[&str]) -> (bool, String) {
        let out = Command::new(PROGRAM)
            .arg("ctl")
            .args(words)
            .arg("--socket")
            .arg(&self.socket)
            .output()
            .unwrap();
        let text = if out.status.success() {
            &out.stdout
        } else {
            &out.stderr
        };
        (
            out.status.success(),
            String::from_utf8_lossy(text).trim().to_string(),
        )
    }
}

impl Drop for Bootstrap {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Waits until the bootstrap's status says `state`.
fn wait_state(bootstrap: &Bootstrap, state: &str) {
    let end = Instant::now() + Duration::from_secs(5);
    loop {
        let (_, status) = bootstrap.ctl(&["status"]);
        if status.contains(&format!("\"state\":\"{state}\"")) {
            return;
        }
        assert!(Instant::now() < end, "never {state}: {status}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Runs a command that should stop at once; one still running after 10 s (it took what it
/// should have refused) is killed and its exit code is `None`. Returns the code and what it
/// said on standard error.
fn refused_within(command: &mut Command) -> (Option<i32>, String) {
    let mut child = command
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let end = Instant::now() + Duration::from_secs(10);
    let code = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status.code();
        }
        if Instant::now() > end {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    let _ = std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr);
    (code, stderr)
}

/// Pseudo-terminals for the four serial devices and ADC files, named by a devices file.
struct FakeDevices {
    /// The IMU's side of its terminal.
    imu: TTYPort,
    /// The other terminals, held open.
    _held: Vec<TTYPort>,
    /// The devices file.
    file: PathBuf,
}

impl FakeDevices {
    fn new(dir: &Path) -> Self {
        let mut held = Vec::new();
        let mut pair = || {
            let (master, slave) = TTYPort::pair().unwrap();
            let path = PathBuf::from(slave.name().unwrap());
            held.push(slave);
            (master, path)
        };
        let (imu, imu_path) = pair();
        let (scb, scb_path) = pair();
        let (gps, gps_path) = pair();
        let (baro, baro_path) = pair();
        held.extend([scb, gps, baro]);
        let adc = dir.join("adc");
        std::fs::create_dir_all(&adc).unwrap();
        for (channel, counts) in [(0, 2048), (1, 2048), (2, 2048), (3, 3000)] {
            heli_vehicle::adc::write_channel(&adc, channel, counts).unwrap();
        }
        let file = dir.join("devices.toml");
        std::fs::write(
            &file,
            format!(
                "[ports]\nimu = {:?}\nscb = {:?}\ngps = {:?}\nbaro = {:?}\n[adc]\ndir = {:?}\ncompass = [0, 1, 2]\nbattery = 3\n",
                imu_path, scb_path, gps_path, baro_path, adc
            ),
        )
        .unwrap();
        Self {
            imu,
            _held: held,
            file,
        }
    }
}

/// The IMU at 100 Hz on its terminal, until stopped.
struct Feeder {
    feeding: Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<()>,
}

impl Feeder {
    fn start(mut imu: TTYPort) -> Self {
        let feeding = Arc::new(std::sync::atomic::AtomicBool::new(true));
        let on = Arc::clone(&feeding);
        let thread = std::thread::spawn(move || {
            while on.load(std::sync::atomic::Ordering::Acquire) {
                imu.write_all(&imu_frame()).unwrap();
                std::thread::sleep(Duration::from_millis(10));
            }
        });
        Self { feeding, thread }
    }

    fn stop(self) {
        self.feeding
            .store(false, std::sync::atomic::Ordering::Release);
        self.thread.join().unwrap();
    }
}

fn imu_frame() -> Vec<u8> {
    let mut buf = [0u8; heli_proto::imu::FRAME_LEN];
    let n = ImuRepr {
        rate_rps: [0.0; 3],
        accel_mps2: [0.0, 0.0, -9.81],
        temp_c: 30.0,
    }
    .emit(&mut buf)
    .unwrap();
    buf[..n].to_vec()
}

#[test]
fn the_onboard_program_connects_flies_logs_and_stops_on_its_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let FakeDevices {
        imu,
        _held: held,
        file: devices,
    } = FakeDevices::new(dir.path());
    let cal = dir.path().join("compass.toml");
    std::fs::write(
        &cal,
        "bias_gauss = [0.01, -0.02, 0.03]\nscale = [1.0, 1.1, 0.9]\n",
    )
    .unwrap();
    let cal_arg = cal.display().to_string();
    let bootstrap = Bootstrap::start(
        dir.path(),
        &devices,
        &["--compass-cal", &cal_arg, "--fallback-dir", "none"],
    );
    // A parameter file that cannot be used stops the start, with its reason: nobody chose
    // the values it would fly on otherwise.
    std::fs::write(dir.path().join("params"), "this is not a parameter\n").unwrap();
    let (ok, reply) = bootstrap.ctl(&["connect"]);
    assert!(ok && reply.starts_with("ok connected"), "{reply}");
    let (ok, reply) = bootstrap.ctl(&["start-logging", "refused", "manual"]);
    assert!(!ok && reply.contains("params"), "{reply}");
    std::fs::remove_file(dir.path().join("params")).unwrap();
    // A suffix the vehicle has a log of is refused up front, with its reason — no crash —
    // and the flight process waits, connected, for another start.
    std::fs::write(dir.path().join("flight_e1.mcap"), b"an older flight").unwrap();
    let (ok, reply) = bootstrap.ctl(&["start-logging", "e1", "manual"]);
    assert!(
        !ok && reply.contains("flight_e1.mcap exists already") && reply.contains("another suffix"),
        "{reply}"
    );
    wait_state(&bootstrap, "connected");
    assert!(
        !bootstrap
            .lines
            .lock()
            .unwrap()
            .iter()
            .any(|l| l.contains("CRASHED")),
        "a refused start is no crash"
    );
    assert_eq!(
        std::fs::read(dir.path().join("flight_e1.mcap")).unwrap(),
        b"an older flight"
    );
    let (ok, reply) = bootstrap.ctl(&["start-logging", "e2e", "manual"]);
    assert!(ok && reply.starts_with("ok flying"), "{reply}");
    // The IMU at 100 Hz: the short calibration the command line asked for ends at once.
    let feeder = Feeder::start(imu);
    bootstrap.wait_for("calibration done", Duration::from_secs(5));
    let (ok, status) = bootstrap.ctl(&["status"]);
    assert!(ok, "{status}");
    let status: serde_json::Value = serde_json::from_str(status.trim_start_matches("ok ")).unwrap();
    assert_eq!(status["state"], "flying", "{status}");
    let pid = status["pid"].as_u64().unwrap_or(0);
    assert!(pid > 0, "{status}");
    // The flight process crashes and the parameter file has meanwhile become unusable: the
    // restart flies on, on the defaults, and says so (a start on the ground would refuse).
    std::fs::write(dir.path().join("params"), "this is not a parameter\n").unwrap();
    let killed = Command::new("kill")
        .args(["-9", &pid.to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    bootstrap.wait_for("restarting the flight process", Duration::from_secs(5));
    bootstrap.wait_for(
        "resuming the flight on the default parameters",
        Duration::from_secs(5),
    );
    wait_state(&bootstrap, "flying");
    // It was on the ground: it calibrates again, and its estimate runs.
    let end = Instant::now() + Duration::from_secs(5);
    while bootstrap
        .lines
        .lock()
        .unwrap()
        .iter()
        .filter(|l| l.contains("calibration done"))
        .count()
        < 2
    {
        assert!(Instant::now() < end, "no second calibration");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    let (ok, reply) = bootstrap.ctl(&["stop"]);
    feeder.stop();
    assert!(
        ok && reply.starts_with("ok stopped (exit code 0)"),
        "{reply}"
    );
    let (ok, reply) = bootstrap.ctl(&["quit"]);
    assert!(ok, "{reply}");
    let said = bootstrap.lines.lock().unwrap().join("\n");
    assert!(!said.contains("report lines dropped"), "{said}");
    // The log: the flight's setup as the command line gave it.
    // The killed process's log reads to its last flush; the restarted one's is closed.
    drop(held);
    let resumed = heli_log::read(&std::fs::read(dir.path().join("flight_e2e_r1.mcap")).unwrap());
    assert!(resumed.closed, "{said}");
    let log = heli_log::read(&std::fs::read(dir.path().join("flight_e2e.mcap")).unwrap());
    assert!(log.stopped.is_none(), "{said}");
    let flight = &log
        .metadata
        .iter()
        .find(|m| m.name == "flight")
        .unwrap()
        .entries;
    for (key, value) in [
        ("calibration_s", "0.5"),
        ("warm_up_s", "0.1"),
        ("baro_rate_hz", "4"),
        ("mode", "manual"),
        ("suffix", "e2e"),
        ("compass_bias_gauss", "[0.01, -0.02, 0.03]"),
        ("compass_scale", "[1.0, 1.1, 0.9]"),
        // Under the real-time settings unless --no-realtime, not pinned unless --rt-cpu.
        ("realtime", "true"),
        ("rt_cpu", ""),
    ] {
        assert_eq!(
            flight.get(key).map(String::as_str),
            Some(value),
            "{key}: {flight:?}"
        );
    }
    assert!(
        log.messages
            .iter()
            .chain(&resumed.messages)
            .any(|m| m.topic == "state"),
        "the estimate ran"
    );
    // The flight software reads the compass through the calibration given.
    let calibration = heli_proto::compass::CompassCalibration {
        bias_gauss: [0.01, -0.02, 0.03],
        scale: [1.0, 1.1, 0.9],
    };
    let expected = calibration.apply(
        &heli_proto::compass::CompassAdc {
            counts: [2048, 2048, 2048],
        }
        .raw_field(),
    );
    let read = log
        .messages
        .iter()
        .chain(&resumed.messages)
        .rev()
        .find(|m| m.topic == "compass")
        .map(|m| m.value["field_gauss"].clone())
        .unwrap();
    assert_eq!(read, serde_json::json!(expected.field_gauss));
}

#[test]
fn bad_command_lines_are_refused_with_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let devices = dir.path().join("devices.toml");
    std::fs::write(
        &devices,
        "[ports]\nimu = \"/dev/null\"\nscb = \"/dev/zero\"\ngps = \"/dev/full\"\nbaro = \"/dev/tty\"\n[adc]\ndir = \"/tmp\"\ncompass = [0, 1, 2]\nbattery = 3\n",
    )
    .unwrap();
    let dir_s = dir.path().display().to_string();
    let dev_s = devices.display().to_string();
    for (args, says) in [
        (vec!["--baro-rate", "11"], "--baro-rate 11"),
        (vec!["--baro-rate", "0"], "--baro-rate 0"),
        (vec!["--calibration-s=-1"], "--calibration-s -1"),
        (vec!["--warm-up-s", "601"], "--warm-up-s 601"),
        (vec!["--calibration-s", "NaN"], "--calibration-s NaN"),
        (vec!["--clock-speed", "0"], "--clock-speed 0"),
        (vec!["--clock-speed", "101"], "--clock-speed 101"),
        (vec!["--log-dir", "/nonexistent/dir"], "not a directory"),
        (
            vec!["--compass-cal", "/nonexistent/cal.toml"],
            "/nonexistent/cal.toml",
        ),
    ] {
        let mut all = vec!["--devices", &dev_s];
        if !args.contains(&"--log-dir") {
            all.extend(["--log-dir", &dir_s]);
        }
        all.extend(args.iter().copied());
        let (code, stderr) = refused_within(Command::new(PROGRAM).args(&all));
        assert_eq!(code, Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
    // The edges of each range are taken (the program then runs until told to quit).
    for args in [
        vec!["--baro-rate", "1"],
        vec!["--baro-rate", "10"],
        vec!["--calibration-s", "0"],
        vec!["--warm-up-s", "600"],
        vec!["--clock-speed", "100"],
    ] {
        let socket = dir.path().join("edge.sock");
        let socket_s = socket.display().to_string();
        let mut all = vec![
            "--devices",
            &dev_s,
            "--log-dir",
            &dir_s,
            "--socket",
            &socket_s,
        ];
        all.extend(args.iter().copied());
        let mut child = Command::new(PROGRAM)
            .args(&all)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut first = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        let _ = child.kill();
        let _ = child.wait();
        assert!(first.contains("bootstrap: listening"), "{args:?}: {first}");
    }
}

#[test]
fn a_stand_alone_driver_reads_its_device_and_refuses_a_bad_rate() {
    let dir = tempfile::tempdir().unwrap();
    let adc = dir.path().join("adc");
    std::fs::create_dir_all(&adc).unwrap();
    heli_vehicle::adc::write_channel(&adc, 3, 3000).unwrap();
    let out = Command::new(PROGRAM)
        .args(["driver", "battery", "--count", "2", "--adc"])
        .arg(&adc)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{said}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(said.lines().count() >= 2, "{said}");
    for rate in ["0", "11"] {
        let (code, stderr) = refused_within(Command::new(PROGRAM).args([
            "driver",
            "baro",
            "--port",
            "/dev/null",
            "--rate",
            rate,
        ]));
        assert_eq!(code, Some(2), "{stderr}");
        assert!(stderr.contains(&format!("--rate {rate}")), "{stderr}");
    }
}

/// Reads `from`'s lines into `into` on a thread of its own.
fn collect(from: impl std::io::Read + Send + 'static) -> Arc<Mutex<Vec<String>>> {
    let lines = Arc::new(Mutex::new(Vec::new()));
    let sink = Arc::clone(&lines);
    std::thread::spawn(move || {
        for line in BufReader::new(from).lines().map_while(Result::ok) {
            sink.lock().unwrap().push(line);
        }
    });
    lines
}

/// Waits for a line containing `needle` in `lines`.
fn wait_in(lines: &Mutex<Vec<String>>, needle: &str, timeout: Duration) -> String {
    let end = Instant::now() + timeout;
    loop {
        if let Some(l) = lines.lock().unwrap().iter().find(|l| l.contains(needle)) {
            return l.clone();
        }
        assert!(
            Instant::now() < end,
            "no line with '{needle}' within {timeout:?}:\n{}",
            lines.lock().unwrap().join("\n")
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn a_flight_process_whose_bootstrap_is_gone_in_the_air_flies_on_and_is_taken_back() {
    let dir = tempfile::tempdir().unwrap();
    let FakeDevices {
        imu,
        _held: _held_open,
        file: devices,
    } = FakeDevices::new(dir.path());
    // A record of a helicopter in the air: the process restarted in flight aligns in the air.
    std::fs::write(
        dir.path().join("warm-start"),
        "start = up manual\nairborne = true\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    let adopt_socket = heli_vehicle::adopt::socket_for(&dir.path().join("ctl.sock"));
    let flight_process = |dir: &Path| {
        let mut command = Command::new(PROGRAM);
        command
            .arg("flight")
            .arg("--devices")
            .arg(&devices)
            .arg("--log-dir")
            .arg(dir)
            .arg("--fallback-dir")
            .arg(dir.join("ram"))
            .args(["--warm-up-s", "0.1"])
            .arg("--adopt-socket")
            .arg(&adopt_socket)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        command
    };
    let mut flight = flight_process(dir.path()).spawn().unwrap();
    let said = collect(flight.stdout.take().unwrap());
    wait_in(&said, "ready 4", Duration::from_secs(5));
    let mut to_flight = flight.stdin.take().unwrap();
    writeln!(to_flight, "restart up manual").unwrap();
    wait_in(&said, "started ", Duration::from_secs(5));
    let feeder = Feeder::start(imu);
    wait_in(&said, "aligned in the air", Duration::from_secs(10));
    // A second start in flight, and a line that is not the protocol, are answered, not flown.
    writeln!(to_flight, "start again manual").unwrap();
    wait_in(
        &said,
        "error already started: stop this flight first",
        Duration::from_secs(5),
    );
    writeln!(to_flight, "hello").unwrap();
    wait_in(
        &said,
        "error not understood: 'hello'",
        Duration::from_secs(5),
    );
    // A line that is not UTF-8 is answered too, and the lines after it are read: it is
    // not the bootstrap's end (which would end the flight on the ground, or fly on deaf).
    to_flight.write_all(b"st\xffop\n").unwrap();
    wait_in(&said, "error not understood: 'st", Duration::from_secs(5));
    writeln!(to_flight, "start again manual").unwrap();
    let end = Instant::now() + Duration::from_secs(5);
    while said
        .lock()
        .unwrap()
        .iter()
        .filter(|l| l.contains("error already started"))
        .count()
        < 2
    {
        assert!(Instant::now() < end, "the line after it was not read");
        std::thread::sleep(Duration::from_millis(10));
    }
    // While it lives, a second flight process on the same socket refuses to start.
    let second = dir.path().join("second");
    std::fs::create_dir_all(&second).unwrap();
    let (code, stderr) = refused_within(flight_process(&second).stdin(Stdio::null()));
    assert_eq!(code, Some(2), "a second flight process started: {stderr}");
    assert!(
        stderr.contains("another flight process is running"),
        "{stderr}"
    );
    // The bootstrap's line ends without a Stop: it flies on.
    drop(to_flight);
    wait_in(&said, "in the air: flying on", Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(500));
    assert!(flight.try_wait().unwrap().is_none(), "it ended");
    // A new bootstrap takes it back: who it is, what it flies, its log; then its lines.
    let adopted = heli_vehicle::adopt::take_back(&adopt_socket, Duration::from_secs(5))
        .unwrap()
        .expect("a flight process to take back");
    assert_eq!(adopted.pid, flight.id());
    assert_eq!(
        heli_vehicle::supervisor::start_words(&adopted.start),
        "up manual"
    );
    assert!(
        adopted
            .log
            .as_deref()
            .is_some_and(|l| l.ends_with("flight_up_r1.mcap")),
        "{:?}",
        adopted.log
    );
    let mut to_flight = adopted.to_flight;
    let heard = collect(adopted.from_flight);
    wait_in(
        &heard,
        "a bootstrap took the flight back",
        Duration::from_secs(5),
    );
    wait_in(&heard, "telemetry {", Duration::from_secs(5));
    writeln!(to_flight, "stop").unwrap();
    wait_in(&heard, "stopped {", Duration::from_secs(5));
    let status = flight.wait().unwrap();
    feeder.stop();
    assert!(status.success(), "{status}");
    // A clean end: the socket is gone, nothing is left to resume, and nothing in RAM.
    assert!(!adopt_socket.exists());
    assert!(!dir.path().join("ram").exists());
    assert!(!dir.path().join("warm-start").exists());
    let log = heli_log::read(&std::fs::read(dir.path().join("flight_up_r1.mcap")).unwrap());
    assert!(log.closed);
    let notes: Vec<&str> = log
        .messages
        .iter()
        .filter(|m| m.topic == "notes")
        .filter_map(|m| m.value["text"].as_str())
        .collect();
    assert!(
        notes.iter().any(|t| t.contains("flying on"))
            && notes.iter().any(|t| t.contains("took the flight back")),
        "{notes:?}"
    );
}

#[test]
fn on_an_untested_configuration_autonomous_needs_the_override_and_a_restart_flies_on() {
    // No key, no attestation, no bench override: nothing is lab-tested.
    let flight_process = |dir: &Path, devices: &Path| {
        let mut child = Command::new(PROGRAM)
            .arg("flight")
            .arg("--devices")
            .arg(devices)
            .arg("--log-dir")
            .arg(dir)
            .args(["--fallback-dir", "none", "--warm-up-s", "0.1"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let said = collect(child.stdout.take().unwrap());
        wait_in(&said, "ready 4", Duration::from_secs(5));
        let to_flight = child.stdin.take().unwrap();
        (child, said, to_flight)
    };
    let dir = tempfile::tempdir().unwrap();
    let devices = FakeDevices::new(dir.path());
    let (mut child, said, mut to_flight) = flight_process(dir.path(), &devices.file);
    writeln!(to_flight, "start a autonomous hover").unwrap();
    let refused = wait_in(&said, "error ", Duration::from_secs(5));
    assert!(
        refused.contains("NOT lab-tested: no key")
            && refused.contains("autonomous flight needs the operator's override"),
        "{refused}"
    );
    // Refused before anything was opened: the process waits for another start.
    writeln!(to_flight, "start a autonomous hover override-untested").unwrap();
    wait_in(&said, "started ", Duration::from_secs(5));
    let event = wait_in(&said, "by the operator's override", Duration::from_secs(5));
    assert!(event.starts_with("event warning-hi"), "{event}");
    writeln!(to_flight, "kill").unwrap();
    assert!(child.wait().is_ok());

    // Started again after a crash in the air: the flight flies on, whatever the lab said.
    let dir = tempfile::tempdir().unwrap();
    let devices = FakeDevices::new(dir.path());
    std::fs::write(
        dir.path().join("warm-start"),
        "start = r autonomous hover\nairborne = true\ngyro_bias_rps = 0 0 0\n",
    )
    .unwrap();
    let (mut child, said, mut to_flight) = flight_process(dir.path(), &devices.file);
    writeln!(to_flight, "restart r autonomous hover").unwrap();
    wait_in(&said, "started ", Duration::from_secs(5));
    assert!(
        !said.lock().unwrap().iter().any(|l| l.starts_with("error ")),
        "{:?}",
        said.lock().unwrap()
    );
    writeln!(to_flight, "kill").unwrap();
    assert!(child.wait().is_ok());
}
