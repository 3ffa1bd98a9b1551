//! The operator's display end to end: `heli hilsim`, `heli vehicle --link` and
//! `heli ground --http` as processes on loopback, the display driven in headless Chromium
//! (Debian's `chromium`, through playwright-core; `tests/ui/display.mjs` has the steps).
//! Screenshots of every step are saved under the test's target directory.
//!
//! Needs `chromium` and `npm ci --prefix tests/ui` (`.ci/run` installs both). Without them
//! the test says so and passes, unless `HELI_UI_REQUIRED=1` (set by `.ci/run`).

use std::path::{Path, PathBuf};
use std::process::Command;

use super::with_browser;
use crate::procs::{Display, Hilsim, Vehicle, free_udp_port, heli};

const CHROMIUM: &str = "/usr/bin/chromium";

/// For a browser test: the page scripts' directory and the machine to itself
/// ([`crate::with_browser`]), or `None` when the test cannot run here (said); panics when
/// it must and cannot.
pub(crate) fn browser_test() -> Option<(PathBuf, std::sync::RwLockWriteGuard<'static, ()>)> {
    let ui = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ui");
    if !browser_ready(&ui) {
        return None;
    }
    Some((ui, crate::with_browser()))
}

/// Whether the browser test can run here; panics when it must and cannot.
pub(crate) fn browser_ready(ui: &Path) -> bool {
    let missing: Vec<String> = [
        (Path::new(CHROMIUM).to_path_buf(), "Debian's chromium"),
        (
            ui.join("node_modules/playwright-core"),
            "playwright-core (npm ci --prefix tests/ui)",
        ),
    ]
    .into_iter()
    .filter(|(p, _)| !p.exists())
    .map(|(p, what)| format!("{what} at {}", p.display()))
    .collect();
    if missing.is_empty() {
        return true;
    }
    assert!(
        std::env::var("HELI_UI_REQUIRED").as_deref() != Ok("1"),
        "the browser test is required here, and these are missing: {}",
        missing.join(", ")
    );
    eprintln!("skipped: the browser test needs {}", missing.join(", "));
    false
}

#[test]
fn the_operator_flies_a_hover_from_the_display_in_headless_chromium() {
    crate::procs::void_if_starved(|| {
        let Some((ui, _one)) = browser_test() else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let key = dir.path().join("link.key");
        let out = heli(&["link", "keygen", "--out", &key.display().to_string()]);
        assert!(out.status.success());
        let link = format!("udp:127.0.0.1:{}", free_udp_port());
        let scenario = ui.join("display-flight.toml");
        let hil = Hilsim::start(dir.path(), &scenario.display().to_string(), 1.0, 150.0);
        let logs = dir.path().join("logs");
        std::fs::create_dir_all(&logs).unwrap();
        let vehicle = Vehicle::start_linked(&logs, &hil.dev, &link, Some(&key));
        let saved = dir.path().join("saved");
        let display = Display::start(&link, Some(&key), &saved);
        let (run, said, shots) = run_page_script(&ui, "display", "HELI_UI_URL", &display.url);
        let stopped = display.stop();
        let vehicle_said = vehicle.output();
        vehicle.quit();
        drop(hil);
        assert!(
            run.success(),
            "the browser test failed:\n{}\nthe vehicle said:\n{}",
            tail(&said, 30),
            tail(&vehicle_said, 30)
        );
        assert!(stopped, "heli ground did not stop cleanly on SIGTERM");
        for step in [
            "01-idle",
            "02-connected",
            "05-flying",
            "07-gps-stale",
            "08-battery-red",
            "09-stopped-log-saved",
        ] {
            assert!(
                shots.join(format!("{step}.png")).exists(),
                "no screenshot {step}"
            );
        }
        // The log the display saved by the final parameters is the vehicle's, byte for byte.
        let downloaded = std::fs::read(saved.join("ui/flight_mine.mcap")).unwrap();
        let onboard = std::fs::read(logs.join("flight_ui1.mcap")).unwrap();
        assert!(downloaded == onboard, "the saved log is not the vehicle's");
    });
}

/// Runs `tests/ui/NAME.mjs` with the page's URL in `url_var`; its screenshots go under the
/// test's target directory. Returns its exit status, what it said, and where the
/// screenshots are.
pub(crate) fn run_page_script(
    ui: &Path,
    name: &str,
    url_var: &str,
    url: &str,
) -> (std::process::ExitStatus, String, std::path::PathBuf) {
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("ui-artifacts/{name}"));
    let _ = std::fs::remove_dir_all(&shots);
    run_page_script_env(ui, name, url_var, url, &[])
}

/// Runs the view's page script `name` on `url` with `env` set as well; the screenshots of
/// earlier runs stay (a test's phases share the directory).
pub(crate) fn run_page_script_with(
    ui: &Path,
    name: &str,
    url: &str,
    env: &[(&str, &str)],
) -> (std::process::ExitStatus, String, std::path::PathBuf) {
    run_page_script_env(ui, name, "HELI_VIEW_URL", url, env)
}

pub(crate) fn run_page_script_env(
    ui: &Path,
    name: &str,
    url_var: &str,
    url: &str,
    env: &[(&str, &str)],
) -> (std::process::ExitStatus, String, std::path::PathBuf) {
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("ui-artifacts/{name}"));
    let run = Command::new("node")
        .arg(ui.join(format!("{name}.mjs")))
        .envs(env.iter().copied())
        .env(url_var, url)
        .env("HELI_UI_OUT", &shots)
        // Debian's chromium, niced: the flight's processes come first (the script says why).
        .env("HELI_CHROMIUM", ui.join("chromium-yielding"))
        .env("HELI_CHROMIUM_BINARY", CHROMIUM)
        .output()
        .expect("node");
    let said =
        String::from_utf8_lossy(&run.stdout).to_string() + &String::from_utf8_lossy(&run.stderr);
    // The whole of what the script said goes to a file beside its screenshots; only its end
    // is printed, so that a failing test's own message stays near the top of CI's excerpt.
    let _ = std::fs::create_dir_all(&shots);
    let file = shots.join(format!("{name}-said.txt"));
    let _ = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&file)
        .and_then(|mut f| std::io::Write::write_all(&mut f, said.as_bytes()));
    eprintln!(
        "{name}.mjs ({}) ended with:\n{}\nall it said: {}; screenshots in {}",
        run.status,
        tail(&said, 12),
        file.display(),
        shots.display()
    );
    (run.status, said, shots)
}

/// The last `lines` lines of `text`, for failure messages that must stay short.
pub(crate) fn tail(text: &str, lines: usize) -> String {
    let all: Vec<&str> = text.lines().collect();
    let skip = all.len().saturating_sub(lines);
    let mut out = String::new();
    if skip > 0 {
        out.push_str(&format!("[… {skip} lines before]\n"));
    }
    out.push_str(&all[skip..].join("\n"));
    out
}

/// The pid of a process whose command line mentions `needle`.
fn pid_of(needle: &str) -> Option<u32> {
    std::fs::read_dir("/proc")
        .ok()?
        .flatten()
        .find_map(|entry| {
            let pid: u32 = entry.file_name().to_str()?.parse().ok()?;
            let cmd = std::fs::read(entry.path().join("cmdline")).ok()?;
            String::from_utf8_lossy(&cmd)
                .replace('\0', " ")
                .contains(needle)
                .then_some(pid)
        })
}

/// Every process whose command line mentions `needle`.
fn processes_mentioning(needle: &str) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        if let Ok(cmd) = std::fs::read(entry.path().join("cmdline")) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            if cmd.contains(needle) {
                found.push(cmd);
            }
        }
    }
    found
}

#[test]
fn heli_sim_ui_brings_up_the_whole_system_and_ctrl_c_stops_it() {
    crate::procs::void_if_starved(|| {
        use std::io::{BufRead, BufReader, Read, Write};
        let _one = with_browser();
        let mut child = Command::new(env!("CARGO_BIN_EXE_heli"))
            .args([
                "sim",
                "--ui",
                "--http",
                "127.0.0.1:0",
                "--calibration-s",
                "5",
            ])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::inherit())
            .spawn()
            .unwrap();
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut said = String::new();
        while !said.contains("Ctrl-C stops everything") {
            let mut line = String::new();
            assert!(
                out.read_line(&mut line).unwrap() > 0,
                "heli sim --ui ended:\n{said}"
            );
            said.push_str(&line);
        }
        let word_after = |key: &str| -> String {
            let rest = &said[said
                .find(key)
                .unwrap_or_else(|| panic!("no '{key}' in\n{said}"))
                + key.len()..];
            rest.split_whitespace()
                .next()
                .unwrap()
                .trim_end_matches(')')
                .to_string()
        };
        let url = word_after("the display is at ");
        // The observers' address: the same display, another key.
        let observers = word_after("observers (watch only, another key) at ");
        assert!(
            observers.starts_with("http://") && observers.contains("key=") && observers != url,
            "{said}"
        );
        let link = word_after("vehicle link ");
        let key = word_after("(key ");
        let dir = word_after("saved flights in ");
        let view = word_after("(not the estimate) is at ");
        // Each page with its key (exchanged for its cookie).
        let get = |url: &str| {
            let cookie = crate::web::login(url);
            let (addr, _) = crate::web::split_url(url);
            crate::web::get(&addr, "/", &cookie)
        };
        // The display answers, and the simulator's view of the truth.
        let page = get(&url);
        assert!(
            page.starts_with("HTTP/1.1 200") && page.contains("heli ground station"),
            "{page}"
        );
        let page = get(&view);
        assert!(
            page.starts_with("HTTP/1.1 200") && page.contains("TRUTH (simulator)"),
            "{page}"
        );
        let (addr, _) = crate::web::split_url(&url);
        let addr = addr.as_str();
        // A WebSocket opened by another site's page is refused.
        let mut ws = std::net::TcpStream::connect(addr).unwrap();
        write!(
        ws,
        "GET /ws HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://evil.example\r\nConnection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
    )
    .unwrap();
        let mut answer = [0u8; 64];
        let n = ws.read(&mut answer).unwrap();
        let answer = String::from_utf8_lossy(&answer[..n]).to_string();
        assert!(answer.starts_with("HTTP/1.1 403"), "{answer}");
        // The vehicle answers on the signed link.
        let (ok, status) = crate::procs::ground(
            &link,
            Some(Path::new(&key)),
            &["status", "--seconds", "1.5"],
        );
        assert!(ok && status.contains("bootstrap idle"), "{status}");
        assert_eq!(
            processes_mentioning(&dir).len(),
            3,
            "hilsim, vehicle and ground: {:?}",
            processes_mentioning(&dir)
        );
        // A flight (started on the vehicle's console), then the simulator ends under it (as when
        // its helicopter crashes): the session goes on. The flight is stopped, the ground station
        // saves its log by the flight's own suffix, and a new simulator stands ready.
        let ctl = |words: &[&str]| {
            let socket = format!("{dir}/ctl.sock");
            let mut args = vec!["vehicle", "ctl"];
            args.extend_from_slice(words);
            args.extend(["--socket", &socket]);
            let out = heli(&args);
            String::from_utf8_lossy(&out.stdout).to_string()
        };
        assert!(ctl(&["connect"]).starts_with("ok connected"));
        assert!(ctl(&["start-logging", "crash1", "manual", "hover"]).starts_with("ok flying"));
        std::thread::sleep(std::time::Duration::from_secs(3));
        let hilsim_pid = pid_of(&format!("hilsim --ptys {dir}")).expect("the hilsim's pid");
        let _ = Command::new("kill")
            .args(["-9", &hilsim_pid.to_string()])
            .status();
        while !said.contains("a new simulator is ready") {
            let mut line = String::new();
            assert!(
                out.read_line(&mut line).unwrap() > 0,
                "heli sim --ui ended when its simulator did:\n{said}"
            );
            said.push_str(&line);
        }
        assert!(said.contains("the simulator ended ("), "{said}");
        let saved = Path::new(&dir).join("flights/flight_crash1.mcap");
        let end = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while !saved.exists() {
            assert!(
                std::time::Instant::now() < end,
                "the flight's log was not saved: {}",
                std::fs::read_to_string(Path::new(&dir).join("ground.log")).unwrap_or_default()
            );
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
        assert!(pid_of(&format!("hilsim --ptys {dir}")).is_some_and(|p| p != hilsim_pid));
        assert!(
            get(&view).starts_with("HTTP/1.1 200"),
            "the view is served again"
        );
        // Ctrl-C: everything stops.
        let _ = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status();
        let mut rest = String::new();
        out.read_to_string(&mut rest).unwrap();
        let status = child.wait().unwrap();
        assert!(status.success(), "{status}: {rest}");
        assert!(rest.contains("heli sim --ui: stopped"), "{rest}");
        assert!(
            processes_mentioning(&dir).is_empty(),
            "left running: {:?}",
            processes_mentioning(&dir)
        );
        let vehicle_log = std::fs::read_to_string(Path::new(&dir).join("vehicle.log")).unwrap();
        assert!(vehicle_log.contains("bootstrap: quit"), "{vehicle_log}");
        let _ = std::fs::remove_dir_all(&dir);
    });
}
