//! The link's shared state, its pieces, and the link thread on loopback.

use super::*;

/// What the bootstrap reports of a line it printed.
fn said(line: &str) -> Said {
    if let Some(rest) = line.strip_prefix("flight: ") {
        return Said::Flight(FromFlight::parse(rest).unwrap());
    }
    let text = line.strip_prefix("bootstrap: ").unwrap().to_string();
    let severity = if text.contains("CRASHED") {
        Severity::Fatal
    } else if text.starts_with("error") {
        Severity::WarningHi
    } else {
        Severity::ActivityLo
    };
    Said::Bootstrap { severity, text }
}

fn severity_of(line: &str) -> MavSeverity {
    mav_severity(&said(line))
}

#[test]
fn lines_get_the_severity_of_their_events() {
    assert_eq!(
        severity_of("flight: event fatal t=1.00 s imu silent"),
        MavSeverity::MAV_SEVERITY_CRITICAL
    );
    assert_eq!(
        severity_of("flight: event warning-hi t=1.00 s GPS lost"),
        MavSeverity::MAV_SEVERITY_WARNING
    );
    assert_eq!(
        severity_of("bootstrap: flight process CRASHED: signal 9 (SIGKILL)"),
        MavSeverity::MAV_SEVERITY_CRITICAL
    );
    assert_eq!(
        severity_of("bootstrap: state idle"),
        MavSeverity::MAV_SEVERITY_INFO
    );
}

#[test]
fn the_heartbeat_knows_the_mode_of_the_flight_under_way() {
    let shared = LinkShared::default();
    shared.set_state(State::Flying, FlightMode::from_name("velocity"));
    let s = shared.lock().status;
    assert_eq!((s.state, s.mode), (BootstrapState::Flying, 5));
}

#[test]
fn telemetry_of_a_flight_process_gone_is_not_kept() {
    let shared = LinkShared::default();
    shared.set_state(State::Flying, Some(FlightMode::Autonomous));
    shared.set_telemetry(&serde_json::to_value(Telemetry::default()).unwrap());
    assert!(shared.lock().telemetry.is_some());
    shared.set_state(State::Idle, None);
    assert!(shared.lock().telemetry.is_none());
}

/// Starts a link thread without a key on loopback; returns its address, what it said,
/// and the stop flag.
fn open_link(dir: &std::path::Path) -> (SocketAddr, Arc<Mutex<Vec<String>>>, Arc<AtomicBool>) {
    let config = crate::bootstrap::BootstrapConfig {
        socket: dir.join("ctl.sock"),
        child: Vec::new(),
        warm_files: Vec::new(),
        adopt_socket: None,
    };
    let bootstrap = crate::bootstrap::Bootstrap::new(config, Box::new(|_: &Said| {}));
    let probe = UdpSocket::bind("127.0.0.1:0").unwrap();
    let addr = probe.local_addr().unwrap();
    drop(probe);
    let said = Arc::new(Mutex::new(Vec::new()));
    let said_to = Arc::clone(&said);
    let stop = Arc::new(AtomicBool::new(false));
    spawn(
        addr,
        None,
        (dir.to_path_buf(), None),
        Arc::new(LinkShared::default()),
        bootstrap.requests(),
        Arc::new(move |l: &Said| said_to.lock().unwrap().push(l.to_string())),
        Arc::clone(&stop),
    )
    .unwrap();
    (addr, said, stop)
}

#[test]
fn without_a_key_the_link_says_it_is_unauthenticated_and_a_garbler_is_sent_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (addr, said, stop) = open_link(dir.path());
    assert!(
        said.lock().unwrap()[0].contains("UNAUTHENTICATED"),
        "{said:?}"
    );
    // A sender of garbage is not a peer: it gets nothing back.
    let garbler = UdpSocket::bind("127.0.0.1:0").unwrap();
    garbler
        .set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    garbler.send_to(&[0xFD, 1, 2, 3], addr).unwrap();
    let mut buf = [0u8; 512];
    assert!(garbler.recv(&mut buf).is_err(), "garbage earned an answer");
    // A ground's heartbeat makes it a peer, told the link is unauthenticated.
    let mut ground = heli_link::ground::GroundLink::new(None);
    let ground_socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    ground_socket
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    ground_socket
        .send_to(&ground.heartbeat_frame(unix_us()), addr)
        .unwrap();
    let end = Instant::now() + Duration::from_secs(3);
    while Instant::now() < end
        && !(ground.heartbeat.is_some()
            && ground
                .texts
                .iter()
                .any(|(_, t)| t.contains("unauthenticated")))
    {
        if let Ok(n) = ground_socket.recv(&mut buf) {
            ground.receive(&buf[..n], unix_us());
        }
    }
    // Said once, not at every tick (every 30 s).
    let end = Instant::now() + Duration::from_millis(500);
    while Instant::now() < end {
        if let Ok(n) = ground_socket.recv(&mut buf) {
            ground.receive(&buf[..n], unix_us());
        }
    }
    stop.store(true, Ordering::Release);
    assert_eq!(
        ground
            .texts
            .iter()
            .filter(|(_, t)| t.contains("link unauthenticated"))
            .count(),
        1,
        "{:?}",
        ground.texts
    );
    assert!(ground.heartbeat.is_some());
}

#[test]
fn a_directory_of_logs_is_listed_and_read() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flight_b.mcap"), vec![2u8; 300]).unwrap();
    std::fs::write(dir.path().join("flight_a.mcap"), vec![1u8; 100]).unwrap();
    std::fs::write(dir.path().join("warm-start"), "x").unwrap();
    let store = DirStore::new(vec![dir.path().to_path_buf()]);
    let listing = store.list();
    assert!(listing.problems.is_empty(), "{:?}", listing.problems);
    let list = listing.logs;
    assert_eq!(list.len(), 2);
    assert_eq!(
        (list[0].id, list[0].name.as_str(), list[0].size),
        (1, "flight_a.mcap", 100)
    );
    let mut buf = [0u8; 90];
    assert_eq!(store.read("flight_b.mcap", 250, &mut buf), Ok(50));
    assert_eq!(buf[0], 2);
    assert_eq!(store.read("flight_b.mcap", 300, &mut buf), Ok(0), "the end");
    // A log that is gone, and a name that is not a log's: said, not read as an end.
    assert_eq!(
        store.read("flight_c.mcap", 0, &mut buf),
        Err("flight_c.mcap: no longer in the log directories".into())
    );
    assert!(store.read("../warm-start", 0, &mut buf).is_err());
}

#[test]
fn what_the_log_directories_refuse_is_said_not_listed_as_no_logs() {
    let disk = tempfile::tempdir().unwrap();
    let ram = tempfile::tempdir().unwrap();
    std::fs::write(ram.path().join("flight_b.mcap"), vec![2u8; 100]).unwrap();
    // A log directory that cannot be read (here: a file where the directory should be,
    // which even root cannot list).
    let not_a_dir = disk.path().join("logs");
    std::fs::write(&not_a_dir, "x").unwrap();
    let store = DirStore::new(vec![not_a_dir.clone(), ram.path().to_path_buf()]);
    let listing = store.list();
    assert_eq!(
        listing.logs.len(),
        1,
        "the readable directory's log is listed"
    );
    assert_eq!(listing.problems.len(), 1, "{:?}", listing.problems);
    assert!(
        listing.problems[0].starts_with(&format!("{}: ", not_a_dir.display()))
            && listing.problems[0].contains("directory"),
        "{:?}",
        listing.problems
    );
}

#[test]
fn a_log_in_the_fallback_directory_is_listed_and_read_beside_the_log_directory_s() {
    let disk = tempfile::tempdir().unwrap();
    let ram = tempfile::tempdir().unwrap();
    std::fs::write(disk.path().join("flight_a.mcap"), vec![1u8; 100]).unwrap();
    std::fs::write(disk.path().join("flight_c.mcap"), vec![3u8; 30]).unwrap();
    // The disk refused flight_b's log: it is in RAM.
    std::fs::write(ram.path().join("flight_b.mcap"), vec![2u8; 200]).unwrap();
    // A name in both is the log directory's.
    std::fs::write(ram.path().join("flight_c.mcap"), vec![9u8; 10]).unwrap();
    let store = DirStore::new(vec![disk.path().to_path_buf(), ram.path().to_path_buf()]);
    let list: Vec<(u16, String, u32)> = store
        .list()
        .logs
        .into_iter()
        .map(|l| (l.id, l.name, l.size))
        .collect();
    assert_eq!(
        list,
        [
            (1, "flight_a.mcap".to_string(), 100),
            (2, "flight_b.mcap".to_string(), 200),
            (3, "flight_c.mcap".to_string(), 30)
        ]
    );
    let mut buf = [0u8; 90];
    assert_eq!(store.read("flight_b.mcap", 150, &mut buf), Ok(50));
    assert_eq!(buf[0], 2);
    assert_eq!(store.read("flight_c.mcap", 0, &mut buf), Ok(30));
    assert_eq!(buf[0], 3);
    assert_eq!(store.read("flight_a.mcap", 0, &mut buf), Ok(90));
    assert_eq!(buf[0], 1);
    // A directory that is not there (no RAM disk) lists nothing, and the other still does.
    let store = DirStore::new(vec![ram.path().join("gone"), disk.path().to_path_buf()]);
    let listing = store.list();
    assert_eq!(listing.logs.len(), 2);
    assert!(listing.problems.is_empty(), "{:?}", listing.problems);
}

#[test]
fn the_heartbeat_names_each_controller_by_its_mode_code() {
    let shared = LinkShared::default();
    for (name, code) in [
        ("manual", 1),
        ("autonomous", 2),
        ("rate", 3),
        ("attitude", 4),
        ("velocity", 5),
        ("loop", 0),
    ] {
        shared.set_state(State::Starting, FlightMode::from_name(name));
        assert_eq!(shared.lock().status.mode, code, "{name}");
    }
    shared.set_state(State::Idle, None);
    assert_eq!(shared.lock().status.mode, 0);
}

#[test]
fn every_line_gets_its_severity() {
    for (line, severity) in [
        (
            "flight: event warning-lo t=1.00 s GPS glitch",
            MavSeverity::MAV_SEVERITY_NOTICE,
        ),
        (
            "flight: event activity-hi t=1.00 s phase hold",
            MavSeverity::MAV_SEVERITY_INFO,
        ),
        (
            "bootstrap: error timed out while connecting",
            MavSeverity::MAV_SEVERITY_ERROR,
        ),
        (
            "flight: note an error of the runtime",
            MavSeverity::MAV_SEVERITY_INFO,
        ),
    ] {
        assert_eq!(severity_of(line), severity, "{line}");
    }
}

#[test]
fn the_texts_waiting_for_the_ground_are_bounded_oldest_first_out() {
    let shared = LinkShared::default();
    for k in 0..MAX_QUEUED_TEXTS + 50 {
        shared.said(&Said::Link {
            severity: Severity::ActivityLo,
            text: format!("line {k}"),
        });
    }
    let texts = &shared.lock().texts;
    assert_eq!(texts.len(), MAX_QUEUED_TEXTS);
    assert_eq!(
        texts.front().map(|(_, t)| t.as_str()),
        Some("link: line 50")
    );
}

#[test]
fn the_flight_plan_is_served_or_its_fault_said() {
    let shared = LinkShared::default();
    let FromFlight::Plan(legs) =
        FromFlight::parse(r#"plan [{"leg":"takeoff","alt_m":10.0},{"leg":"land"}]"#).unwrap()
    else {
        panic!("a plan line")
    };
    shared.set_plan(&legs);
    assert_eq!(shared.lock().mission.as_ref().map(Vec::len), Some(2));
    // A plan the flight process sent wrong is no message: the bootstrap reports it, and a
    // new flight process serves no plan until it sends one.
    let line = r#"plan [{"leg":"loop"}]"#;
    let error = FromFlight::parse(line).unwrap_err();
    shared.said(&Said::Unreadable {
        line: line.into(),
        error,
    });
    shared.set_state(State::Connecting, None);
    let s = shared.lock();
    assert_eq!(s.mission.as_ref().map(Vec::len), Some(0), "no plan served");
    assert!(
        s.texts
            .iter()
            .any(|(severity, t)| t.contains("not the protocol")
                && *severity == MavSeverity::MAV_SEVERITY_ERROR),
        "{:?}",
        s.texts
    );
}

#[test]
fn whether_a_ground_is_heard_is_kept_as_told() {
    let shared = LinkShared::default();
    assert!(!shared.ground_fresh());
    shared.set_ground_fresh(true);
    assert!(shared.ground_fresh());
    shared.set_ground_fresh(false);
    assert!(!shared.ground_fresh());
}

#[test]
fn only_a_plain_log_name_of_the_directory_is_read() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flight_a.mcap"), [1u8; 10]).unwrap();
    std::fs::write(dir.path().join("notes.txt"), [2u8; 10]).unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    std::fs::write(dir.path().join("sub").join("flight_b.mcap"), [3u8; 10]).unwrap();
    let store = DirStore::new(vec![dir.path().to_path_buf()]);
    let mut buf = [0u8; 4];
    for refused in ["notes.txt", "sub/flight_b.mcap", ""] {
        let e = store.read(refused, 0, &mut buf).unwrap_err();
        assert!(e.contains("is not a log's name"), "{refused}: {e}");
    }
    assert_eq!(store.read("flight_a.mcap", 8, &mut buf), Ok(2));
    assert_eq!(buf[..2], [1, 1]);
}

#[test]
fn a_repeated_line_is_due_again_once_its_period_has_passed() {
    let t = Instant::now();
    let second = Duration::from_secs(1);
    assert!(due_again(None, t, second));
    assert!(!due_again(Some(t), t + Duration::from_millis(999), second));
    assert!(due_again(Some(t), t + second, second));
    // A clock that went back is not due.
    assert!(!due_again(Some(t + second), t, second));
}

fn addr(port: u16) -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], port))
}

#[test]
fn peers_are_kept_while_heard_and_the_longest_silent_makes_room() {
    let t = Instant::now();
    let mut peers = Peers::default();
    for k in 0..MAX_PEERS {
        assert!(peers.heard(addr(1000 + k as u16), t + Duration::from_secs(k as u64)));
    }
    // Heard again: no new peer, nobody dropped.
    assert!(!peers.heard(addr(1000), t + Duration::from_secs(20)));
    assert_eq!(peers.addrs().count(), MAX_PEERS);
    // One more: the one heard longest ago (1001, at t + 1 s) makes room.
    assert!(peers.heard(addr(2000), t + Duration::from_secs(21)));
    assert_eq!(peers.addrs().count(), MAX_PEERS);
    assert!(!peers.addrs().any(|a| *a == addr(1001)));
    assert!(peers.addrs().any(|a| *a == addr(1000)));
    // Not heard for exactly the timeout: gone; heard since: kept.
    peers.expire(t + Duration::from_secs(20) + PEER_TIMEOUT - Duration::from_nanos(1));
    assert!(peers.addrs().any(|a| *a == addr(1000)));
    peers.expire(t + Duration::from_secs(20) + PEER_TIMEOUT);
    assert!(!peers.addrs().any(|a| *a == addr(1000)));
    assert!(peers.addrs().any(|a| *a == addr(2000)));
}

#[test]
fn a_signed_link_starts_and_says_commands_must_be_signed() {
    let dir = tempfile::tempdir().unwrap();
    let config = crate::bootstrap::BootstrapConfig {
        socket: dir.path().join("ctl.sock"),
        child: Vec::new(),
        warm_files: Vec::new(),
        adopt_socket: None,
    };
    let bootstrap = crate::bootstrap::Bootstrap::new(config, Box::new(|_: &Said| {}));
    let said = Arc::new(Mutex::new(Vec::new()));
    let said_to = Arc::clone(&said);
    let stop = Arc::new(AtomicBool::new(false));
    let key = heli_link::signing::Key::new([7u8; 32]);
    let thread = spawn(
        addr(0),
        Some(key),
        (dir.path().to_path_buf(), None),
        Arc::new(LinkShared::default()),
        bootstrap.requests(),
        Arc::new(move |l: &Said| said_to.lock().unwrap().push(l.to_string())),
        Arc::clone(&stop),
    )
    .unwrap();
    stop.store(true, Ordering::Release);
    thread.join().unwrap();
    let said = said.lock().unwrap();
    assert!(said[0].ends_with("commands must be signed"), "{said:?}");
}

#[test]
fn a_pass_takes_at_most_its_bound_of_datagrams_and_the_rest_wait_for_the_next() {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(std::time::Duration::from_millis(200)))
        .unwrap();
    let to = socket.local_addr().unwrap();
    let sender = UdpSocket::bind("127.0.0.1:0").unwrap();
    let sent = MAX_DATAGRAMS_PER_PASS + 36;
    for i in 0..sent {
        sender.send_to(&[(i % 251) as u8; 3], to).unwrap();
    }
    let mut buf = [0u8; 64];
    let mut seen = Vec::new();
    let first = receive_pass(&socket, &mut buf, false, |d, from| {
        assert_eq!(from, sender.local_addr().unwrap());
        seen.push(d.to_vec());
    });
    assert_eq!(first, MAX_DATAGRAMS_PER_PASS);
    let second = receive_pass(&socket, &mut buf, true, |d, _| seen.push(d.to_vec()));
    assert_eq!(second, 36);
    // Nothing left: a pass while a log goes out takes nothing and returns at once.
    let third = receive_pass(&socket, &mut buf, true, |d, _| seen.push(d.to_vec()));
    assert_eq!(third, 0);
    // Every datagram once, in order, whole.
    assert_eq!(seen.len(), sent);
    for (i, d) in seen.iter().enumerate() {
        assert_eq!(d, &vec![(i % 251) as u8; 3]);
    }
}

#[test]
fn a_pass_waits_for_its_first_datagram_only_and_not_while_a_log_goes_out() {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    // A long read timeout: a pass that waited where it should not would show it.
    socket
        .set_read_timeout(Some(std::time::Duration::from_secs(3)))
        .unwrap();
    let to = socket.local_addr().unwrap();
    let mut buf = [0u8; 16];
    // A datagram that comes while the pass waits is taken; the pass does not wait again.
    let late = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(100));
        let sender = UdpSocket::bind("127.0.0.1:0").unwrap();
        sender.send_to(b"one", to).unwrap();
    });
    let began = std::time::Instant::now();
    let taken = receive_pass(&socket, &mut buf, false, |d, _| assert_eq!(d, b"one"));
    late.join().unwrap();
    assert_eq!(taken, 1);
    assert!(
        began.elapsed() < std::time::Duration::from_millis(1500),
        "the pass waited {:?} after its datagram",
        began.elapsed()
    );
    // While a log goes out, a pass with nothing to take returns at once.
    let began = std::time::Instant::now();
    assert_eq!(receive_pass(&socket, &mut buf, true, |_, _| {}), 0);
    assert!(
        began.elapsed() < std::time::Duration::from_millis(1500),
        "a pass during a log download waited {:?}",
        began.elapsed()
    );
}
