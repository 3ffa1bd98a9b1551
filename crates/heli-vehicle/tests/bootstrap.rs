//! The bootstrap's supervision of the flight process, with a stand-in flight process (a
//! shell script speaking the same lines): a process that crashes in flight is started
//! again with `restart` and the same parameters, at most three times a minute; a fresh
//! warm-start record of a flying helicopter resumes the flight at power-on.

#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod common;

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::{Running, alive, crashing_child, status, wait_until};
use heli_vehicle::bootstrap::MAX_RESTARTS;

#[test]
fn a_process_crashing_in_flight_is_restarted_with_its_parameters_three_times_a_minute() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let boot = Running::start(dir.path(), crashing_child(&told), None);
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    let reply = boot.ctl("start-logging crash1 autonomous hover").unwrap();
    assert!(reply.starts_with("ok flying"), "{reply}");
    boot.wait_count("not restarting", 1, Duration::from_secs(10));
    assert_eq!(boot.count("CRASHED"), MAX_RESTARTS + 1);
    assert_eq!(boot.count("restarting the flight process"), MAX_RESTARTS);
    let told = std::fs::read_to_string(&told).unwrap();
    let expected: Vec<String> = std::iter::once("start crash1 autonomous hover".to_string())
        .chain((0..MAX_RESTARTS).map(|_| "restart crash1 autonomous hover".to_string()))
        .collect();
    assert_eq!(told.lines().collect::<Vec<_>>(), expected);
}

#[test]
fn a_crash_before_start_logging_is_not_restarted() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let script = "echo ready 4; sleep 0.2; exit 3".to_string();
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    boot.wait_count("CRASHED", 1, Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(boot.count("restarting"), 0);
    assert!(!told.exists());
}

/// A warm-start record in `dir` of the flight `bo1`, airborne or not.
fn warm_record(dir: &Path, airborne: bool) -> std::path::PathBuf {
    let warm = dir.join("warm-start");
    std::fs::write(
        &warm,
        format!("start = bo1 autonomous hover\nairborne = {airborne}\ngyro_bias_rps = 0 0 0\n"),
    )
    .unwrap();
    warm
}

#[test]
fn power_on_with_a_fresh_record_of_a_flying_helicopter_resumes_the_flight() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let warm = warm_record(dir.path(), true);
    let boot = Running::start(dir.path(), crashing_child(&told), Some(&warm));
    boot.wait_count("resuming the flight in the air", 1, Duration::from_secs(5));
    boot.wait_count("CRASHED", 1, Duration::from_secs(5));
    let text = std::fs::read_to_string(&told).unwrap();
    assert_eq!(text.lines().next(), Some("restart bo1 autonomous hover"));
    drop(boot);
    // A record of a helicopter on the ground is no reason to start anything.
    let dir = tempfile::tempdir().unwrap();
    let warm = warm_record(dir.path(), false);
    let boot = Running::start(dir.path(), crashing_child(&told), Some(&warm));
    boot.wait_count("not resuming", 1, Duration::from_secs(5));
    assert_eq!(boot.count("flight process started"), 0);
}

#[test]
fn power_on_with_a_record_dated_after_the_clock_says_so_and_does_not_resume() {
    // A computer without a battery-backed clock comes up with an older time: a record
    // written before the power failed is dated after "now", and its age is unknown.
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let warm = warm_record(dir.path(), true);
    std::fs::File::options()
        .write(true)
        .open(&warm)
        .unwrap()
        .set_modified(std::time::SystemTime::now() + Duration::from_secs(7200))
        .unwrap();
    let boot = Running::start(dir.path(), crashing_child(&told), Some(&warm));
    boot.wait_count("after this computer's clock", 1, Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(boot.count("resuming the flight in the air"), 0);
    assert_eq!(boot.count("flight process started"), 0);
    assert!(!told.exists());
}

/// A well-behaved flight process: says ready, records every line it is told in `told`,
/// answers `start` with a telemetry line and `started LOG`, and exits 0 on `stop`.
fn polite_child(told: &Path) -> Vec<std::ffi::OsString> {
    let script = format!(
        "echo ready 4; while read line; do echo \"$line\" >> {told}; case \"$line\" in \
         start*) echo 'telemetry {{\"t_us\":1}}'; echo started /logs/flight_a.mcap ;; \
         stop) echo bye >> {told}; exit 0 ;; esac; done",
        told = told.display()
    );
    vec!["sh".into(), "-c".into(), script.into()]
}

#[test]
fn a_line_of_the_flight_process_that_is_not_utf8_is_said_and_the_next_ones_read() {
    let dir = tempfile::tempdir().unwrap();
    let script = "echo ready 4; printf 'tele\\377metry\\n'; while read line; do case \"$line\" in \
                  start*) echo started /logs/flight_a.mcap ;; stop) exit 0 ;; esac; done";
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    boot.wait_count("not the protocol", 1, Duration::from_secs(5));
    let reply = boot.ctl("start-logging a autonomous hover").unwrap();
    assert_eq!(reply, "ok flying, logging to /logs/flight_a.mcap");
    assert_eq!(boot.ctl("stop").unwrap(), "ok stopped (exit code 0)");
}

#[test]
fn the_status_follows_the_flight_from_idle_to_flying_and_back() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let boot = Running::start(dir.path(), polite_child(&told), None);
    let s = status(&boot);
    assert_eq!(
        (s["state"].as_str(), s["pid"].is_null()),
        (Some("idle"), true)
    );
    let reply = boot.ctl("connect").unwrap();
    let s = status(&boot);
    assert_eq!(s["state"], "connected");
    let pid = s["pid"].as_u64().unwrap();
    assert_eq!(reply, format!("ok connected (pid {pid})"));
    let reply = boot.ctl("start-logging a autonomous hover").unwrap();
    assert_eq!(reply, "ok flying, logging to /logs/flight_a.mcap");
    let s = status(&boot);
    assert_eq!(s["state"], "flying");
    assert_eq!(s["log"], "/logs/flight_a.mcap");
    assert_eq!(s["telemetry"]["t_us"], 1);
    assert_eq!(boot.ctl("stop").unwrap(), "ok stopped (exit code 0)");
    let s = status(&boot);
    assert_eq!(
        (s["state"].as_str(), s["last_exit"].as_str()),
        (Some("idle"), Some("exit code 0"))
    );
    assert_eq!(boot.count("state stopping"), 1);
    assert_eq!(
        boot.count("flight process stopped cleanly (exit code 0)"),
        1
    );
    let told = std::fs::read_to_string(&told).unwrap();
    assert_eq!(
        told.lines().collect::<Vec<_>>(),
        ["start a autonomous hover", "stop", "bye"]
    );
    assert_eq!(boot.ctl("stop").unwrap(), "ok nothing to stop");
}

#[test]
fn exit_statuses_are_said_as_an_operator_reads_them() {
    use heli_vehicle::bootstrap::describe_exit;
    use std::os::unix::process::ExitStatusExt;
    use std::process::ExitStatus;
    assert_eq!(describe_exit(ExitStatus::from_raw(0)), "exit code 0");
    assert_eq!(describe_exit(ExitStatus::from_raw(3 << 8)), "exit code 3");
    assert_eq!(describe_exit(ExitStatus::from_raw(9)), "signal 9 (SIGKILL)");
    assert_eq!(
        describe_exit(ExitStatus::from_raw(11)),
        "signal 11 (SIGSEGV)"
    );
}

#[test]
fn a_flight_process_that_never_answers_is_timed_out_and_killed() {
    let dir = tempfile::tempdir().unwrap();
    let pid_file = dir.path().join("pid");
    let script = format!("echo $$ > {}; exec sleep 30", pid_file.display());
    let boot = Running::start_with(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
        |b| b.with_timeouts(Duration::from_millis(300), Duration::from_secs(20)),
    );
    assert_eq!(
        boot.ctl("connect").unwrap_err(),
        "timed out while connecting"
    );
    let pid: u64 = std::fs::read_to_string(&pid_file)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    wait_until("the silent process killed", Duration::from_secs(5), || {
        !alive(pid)
    });
    assert_eq!(status(&boot)["state"], "idle");
}

#[test]
fn a_second_connect_kills_the_first_process_and_hears_only_the_new_one() {
    // The first process leaves a helper holding its output, which says a telemetry line
    // after the process is gone: an old generation's line, not to be taken as the new
    // process's.
    let dir = tempfile::tempdir().unwrap();
    let marker = dir.path().join("second");
    let script = format!(
        "if [ -e {m} ]; then echo ready 4; echo 'telemetry {{\"from\":\"new\"}}'; exec sleep 30; fi; \
         touch {m}; echo ready 4; (sleep 1.5; echo 'telemetry {{\"from\":\"old\"}}'; echo 'started /old') & \
         exec sleep 30",
        m = marker.display()
    );
    // The processes do not listen for 'stop': the quit at the end kills them after 0.5 s.
    let boot = Running::start_with(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
        |b| b.with_timeouts(Duration::from_secs(5), Duration::from_millis(500)),
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    let first = status(&boot)["pid"].as_u64().unwrap();
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    let second = status(&boot)["pid"].as_u64().unwrap();
    assert_ne!(first, second);
    wait_until("the first process killed", Duration::from_secs(5), || {
        !alive(first)
    });
    assert!(alive(second));
    wait_until("the old line heard", Duration::from_secs(5), || {
        boot.count("flight: started /old") == 1
    });
    std::thread::sleep(Duration::from_millis(100));
    let s = status(&boot);
    assert_eq!(s["telemetry"]["from"], "new");
    assert_eq!(
        s["state"], "connected",
        "an old process's 'started' moves nothing"
    );
    assert_eq!(s["log"], serde_json::Value::Null);
}

#[test]
fn lines_out_of_turn_move_nothing() {
    // A process that says 'started' before it was asked and 'ready' again in flight.
    let dir = tempfile::tempdir().unwrap();
    let script = "echo ready 4; echo started /too/early; while read line; do \
         case \"$line\" in start*) echo started /logs/b.mcap; echo ready 4 ;; stop) exit 0 ;; \
         esac; done";
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    wait_until("the early line", Duration::from_secs(5), || {
        boot.count("flight: started /too/early") == 1
    });
    let s = status(&boot);
    assert_eq!(
        (s["state"].as_str(), s["log"].is_null()),
        (Some("connected"), true)
    );
    assert_eq!(
        boot.ctl("start-logging b autonomous hover").unwrap(),
        "ok flying, logging to /logs/b.mcap"
    );
    wait_until("the second ready", Duration::from_secs(5), || {
        boot.count("flight: ready") == 2
    });
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(status(&boot)["state"], "flying");
}

#[test]
fn a_flight_process_of_another_protocol_version_is_refused_and_killed() {
    let dir = tempfile::tempdir().unwrap();
    let script = "echo ready 99; sleep 30";
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    let reply = boot.ctl("connect").unwrap_err();
    assert!(
        reply.contains("protocol version 99") && reply.contains("this bootstrap"),
        "{reply}"
    );
    boot.wait_count("restart the bootstrap", 1, Duration::from_secs(5));
    let s = status(&boot);
    assert_eq!(s["state"], "idle", "{s}");
    assert!(s["pid"].is_null(), "killed: {s}");
}

#[test]
fn a_start_the_flight_process_refuses_is_the_reply_and_is_not_restarted() {
    // As the real flight process does with a plan it does not know: 'error ...', exit 1.
    // That is a refused start, not a crash in flight: nothing is started again.
    let dir = tempfile::tempdir().unwrap();
    let script = "echo ready 4; read line; echo error no such plan: nowhere; exit 1";
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    assert_eq!(
        boot.ctl("start-logging b autonomous nowhere").unwrap_err(),
        "no such plan: nowhere"
    );
    wait_until("the exit", Duration::from_secs(5), || {
        boot.count("exit code 1") == 1
    });
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(boot.count("restarting"), 0);
    assert_eq!(status(&boot)["state"], "idle");
}

#[test]
fn quitting_stops_the_flight_process_cleanly_first() {
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let mut boot = Running::start_with(dir.path(), polite_child(&told), None, |b| {
        b.with_timeouts(Duration::from_secs(5), Duration::from_secs(30))
    });
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    assert!(
        boot.ctl("start-logging q manual")
            .unwrap()
            .starts_with("ok flying")
    );
    let started = Instant::now();
    assert_eq!(boot.ctl("quit").unwrap(), "ok quitting");
    // Not the 30 s stop timeout: the process's exit ends the wait.
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "{:?}",
        started.elapsed()
    );
    boot.thread.take().unwrap().join().unwrap();
    assert_eq!(
        boot.count("flight process stopped cleanly (exit code 0)"),
        1
    );
    let told = std::fs::read_to_string(&told).unwrap();
    assert_eq!(
        told.lines().collect::<Vec<_>>(),
        ["start q manual", "stop", "bye"]
    );
}

#[test]
fn quitting_waits_for_the_current_process_not_an_old_one() {
    // The first process's helper keeps its output open for a second after it was killed,
    // so its exit is heard while the bootstrap waits for the second one, which takes two
    // seconds to stop cleanly.
    let dir = tempfile::tempdir().unwrap();
    let marker = dir.path().join("second");
    let told = dir.path().join("told");
    let script = format!(
        "if [ -e {m} ]; then echo ready 4; read line; echo \"$line\" >> {t}; sleep 2; \
         echo bye >> {t}; exit 0; fi; touch {m}; echo ready 4; (sleep 1) & exec sleep 30",
        m = marker.display(),
        t = told.display()
    );
    let mut boot = Running::start_with(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
        |b| b.with_timeouts(Duration::from_secs(5), Duration::from_secs(30)),
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    assert_eq!(boot.ctl("quit").unwrap(), "ok quitting");
    boot.thread.take().unwrap().join().unwrap();
    assert_eq!(
        boot.count("old flight process ended: signal 9 (SIGKILL)"),
        1
    );
    assert_eq!(
        boot.count("flight process stopped cleanly (exit code 0)"),
        1
    );
    let told = std::fs::read_to_string(&told).unwrap();
    assert_eq!(told.lines().collect::<Vec<_>>(), ["stop", "bye"]);
}

#[test]
fn the_flight_process_is_told_whether_a_ground_is_heard_when_that_changes() {
    use heli_vehicle::link::LinkShared;
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let shared = Arc::new(LinkShared::default());
    shared.set_ground_fresh(true);
    let link = Arc::clone(&shared);
    let boot = Running::start_with(dir.path(), polite_child(&told), None, move |b| {
        b.with_link(link)
    });
    let lines = || std::fs::read_to_string(&told).unwrap_or_default();
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    wait_until("told fresh", Duration::from_secs(5), || {
        lines() == "link fresh\n"
    });
    shared.set_ground_fresh(false);
    wait_until("told lost", Duration::from_secs(5), || {
        lines() == "link fresh\nlink lost\n"
    });
    // Told once per change, and a new process is told afresh.
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(lines(), "link fresh\nlink lost\n");
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    wait_until("the new process told", Duration::from_secs(5), || {
        lines() == "link fresh\nlink lost\nlink lost\n"
    });
    // Without a link nothing is told.
    let dir = tempfile::tempdir().unwrap();
    let quiet = dir.path().join("told");
    let boot = Running::start(dir.path(), polite_child(&quiet), None);
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    std::thread::sleep(Duration::from_millis(300));
    assert!(!quiet.exists());
}

#[test]
fn a_restarted_process_that_dies_before_it_is_ready_is_not_restarted_again() {
    // The first process crashes in flight; the one started again dies before 'ready'
    // (it cannot open its devices, say): that is no flight under way to resume.
    let dir = tempfile::tempdir().unwrap();
    let marker = dir.path().join("restarted");
    let script = format!(
        "if [ -e {m} ]; then exit 4; fi; touch {m}; echo ready 4; read line; \
         echo started /dev/null; sleep 0.3; exit 3",
        m = marker.display()
    );
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    assert!(
        boot.ctl("start-logging r autonomous hover")
            .unwrap()
            .starts_with("ok flying")
    );
    boot.wait_count("CRASHED: exit code 4", 1, Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(boot.count("restarting the flight process"), 1);
    assert_eq!(status(&boot)["state"], "idle");
}

#[test]
fn a_process_that_fails_while_stopping_is_reported_as_failed() {
    let dir = tempfile::tempdir().unwrap();
    let script = "echo ready 4; read line; echo started /dev/null; read line; exit 1";
    let boot = Running::start(
        dir.path(),
        vec!["sh".into(), "-c".into(), script.into()],
        None,
    );
    assert!(boot.ctl("connect").unwrap().starts_with("ok connected"));
    assert!(
        boot.ctl("start-logging f manual")
            .unwrap()
            .starts_with("ok flying")
    );
    assert_eq!(
        boot.ctl("stop").unwrap_err(),
        "the flight process ended: exit code 1"
    );
    assert_eq!(boot.count("flight process CRASHED: exit code 1"), 1);
    assert_eq!(boot.count("restarting"), 0, "stopping: not resumed");
}

/// A flight process in the air: `stop` is answered with `words` (a landing first, or a
/// refusal) and the process flies on; `kill` ends it.
fn airborne_child(words: &str) -> Vec<std::ffi::OsString> {
    let script = format!(
        "echo ready 4; while read line; do case \"$line\" in \
         start*) echo started /logs/flight_air.mcap ;; \
         stop) echo '{words}' ;; \
         kill) exit 0 ;; esac; done"
    );
    vec!["sh".into(), "-c".into(), script.into()]
}

#[test]
fn a_stop_in_the_air_is_answered_by_the_flight_and_the_bootstrap_does_not_quit_under_it() {
    for (words, reply, state) in [
        (
            "landing t=9.00 s stop in the air: landing where it is first",
            "ok landing first: the flight ends on the ground (t=9.00 s stop in the air",
            "landing",
        ),
        (
            "error t=9.00 s stop refused: in the air under the pilot, land then Stop",
            "t=9.00 s stop refused: in the air under the pilot, land then Stop",
            "flying",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let boot = Running::start(dir.path(), airborne_child(words), None);
        boot.ctl("connect").unwrap();
        boot.ctl("start-logging air autonomous hover").unwrap();
        let answer = boot.ctl("stop").unwrap_or_else(|e| e);
        assert!(answer.contains(reply), "{answer}");
        assert_eq!(status(&boot)["state"], state);
        // Quit asks the same Stop: in the air the bootstrap stays, and says why.
        let started = std::time::Instant::now();
        let answer = boot.ctl("quit").unwrap_or_else(|e| e);
        assert!(
            answer.contains("not quitting: the helicopter is in the air"),
            "{answer}"
        );
        assert!(
            started.elapsed() < Duration::from_secs(5),
            "answered, not timed out"
        );
        // A kill needs its confirmation, then ends the flight process.
        let answer = boot.ctl("kill").unwrap_or_else(|e| e);
        assert!(answer.contains("the helicopter falls"), "{answer}");
        assert_eq!(
            boot.ctl("kill confirmed").unwrap(),
            "ok stopped (exit code 0)"
        );
        assert_eq!(status(&boot)["state"], "idle");
    }
}

#[test]
fn the_bootstrap_states_whether_its_flight_software_is_lab_tested() {
    use heli_vehicle::bootstrap::LabStatement;
    use heli_vehicle::lab::Lab;
    let dir = tempfile::tempdir().unwrap();
    let told = dir.path().join("told");
    let program = dir.path().join("flight-software");
    std::fs::write(&program, b"a build").unwrap();
    let lab = Lab {
        check: heli_link::attest::LabCheck {
            attestation: dir.path().join("attestation.json"),
            key: None,
        },
        fly_untested: false,
    };
    let log_dir = dir.path().to_path_buf();
    let boot = Running::start_with(dir.path(), polite_child(&told), None, move |b| {
        b.with_lab(LabStatement::new(lab, &program, log_dir))
    });
    boot.wait_count(
        "bootstrap: NOT lab-tested: no key",
        1,
        Duration::from_secs(5),
    );
    let s = status(&boot);
    assert!(
        s["lab"]
            .as_str()
            .is_some_and(|l| l.starts_with("NOT lab-tested: no key to check")),
        "{s}"
    );
    // Said once, not at every judgement.
    std::thread::sleep(Duration::from_millis(2500));
    assert_eq!(boot.count("NOT lab-tested"), 1);
}
