//! The bootstrap's side of the flight process: starting it, hearing its lines and its exit,
//! killing it, and restarting it with its parameters when it crashes in flight or when the
//! vehicle powers on with a fresh record of a flight under way.

use super::*;
use crate::adopt::Adopted;
use crate::error::ChildProblem;

/// Reads a flight process's lines until their end, each parsed here, on the reader's
/// thread: the bootstrap's loop sees only messages. Whether it said `stopped`.
fn read_lines(from: impl BufRead, generation: u32, tx: &Sender<Msg>) -> bool {
    let mut said_stopped = false;
    // Bytes, not text: a line that is not UTF-8 is said as not the protocol, and the lines
    // after it are read (stopping here would leave the process's pipe to fill).
    for line in from.split(b'\n') {
        let Ok(bytes) = line else { break };
        let line = String::from_utf8_lossy(&bytes);
        let line = line.strip_suffix('\r').unwrap_or(&line).to_string();
        let said = match FromFlight::parse(&line) {
            Ok(message) => {
                said_stopped |= matches!(message, FromFlight::Stopped(_));
                Said::Flight(message)
            }
            Err(error) => Said::Unreadable { line, error },
        };
        if tx.send(Msg::FromChild(generation, said)).is_err() {
            break;
        }
    }
    said_stopped
}

/// Waits (up to [`STOP_TIMEOUT`]) for a process that is not this bootstrap's child to be
/// gone: its socket closed as it ended, and the init system reaps it.
fn wait_gone(pid: u32) {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(pid).unwrap_or(i32::MAX));
    let until = Instant::now().checked_add(STOP_TIMEOUT);
    while nix::sys::signal::kill(pid, None).is_ok() && until.is_some_and(|u| Instant::now() < u) {
        std::thread::sleep(Duration::from_millis(20));
    }
}

impl Bootstrap {
    pub(super) fn tell_child(&mut self, message: &ToFlight) -> bool {
        let Some(stdin) = self.child.as_mut().and_then(|c| c.stdin.as_mut()) else {
            return false;
        };
        writeln!(stdin, "{message}")
            .and_then(|()| stdin.flush())
            .is_ok()
    }

    pub(super) fn spawn_child(&mut self) -> Result<(), VehicleError> {
        let (program, args) = self
            .config
            .child
            .split_first()
            .ok_or(VehicleError::Child(ChildProblem::NoProgram))?;
        // Its own process group: a Ctrl-C or hang-up meant for the bootstrap's terminal must
        // not kill the flight.
        let mut child = Command::new(program)
            .process_group(0)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(|e| VehicleError::Child(ChildProblem::Spawn(e)))?;
        self.generation = self.generation.saturating_add(1);
        let generation = self.generation;
        let pid = child.id();
        let stdin = child.stdin.take();
        let stdout = child.stdout.take();
        let tx = self.tx.clone();
        std::thread::Builder::new()
            .name(format!("child-{generation}"))
            .spawn(move || {
                if let Some(out) = stdout {
                    read_lines(BufReader::new(out), generation, &tx);
                }
                if let Ok(status) = child.wait() {
                    let _ = tx.send(Msg::ChildExited(generation, Exit::Status(status)));
                }
            })
            .map_err(|e| VehicleError::Child(ChildProblem::Reader(e)))?;
        let stdin = stdin.map(|s| Box::new(s) as Box<dyn Write + Send>);
        self.child = Some(Child {
            generation,
            pid,
            stdin,
        });
        self.last_telemetry = None;
        self.say(
            Severity::ActivityLo,
            &format!("flight process started (pid {pid})"),
        );
        Ok(())
    }

    pub(super) fn kill_child(&mut self) {
        let Some(child) = self.child.take() else {
            return;
        };
        let pid = nix::unistd::Pid::from_raw(i32::try_from(child.pid).unwrap_or(i32::MAX));
        let _ = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGKILL);
        // Its exit arrives as a message of an old generation and is reported then.
        self.child = None;
        self.set_state(State::Idle);
    }

    pub(super) fn current(&self, generation: u32) -> bool {
        self.child
            .as_ref()
            .is_some_and(|c| c.generation == generation)
    }

    pub(super) fn heard(&mut self, generation: u32, said: Said) {
        let current = self.current(generation);
        let message = match said {
            Said::Flight(FromFlight::Telemetry(values)) => {
                if current {
                    if let Some(link) = &self.link {
                        link.set_telemetry(&values);
                    }
                    self.last_telemetry = Some(values);
                }
                return;
            }
            Said::Flight(FromFlight::Plan(legs)) => {
                if current && let Some(link) = &self.link {
                    link.set_plan(&legs);
                }
                return;
            }
            Said::Flight(message) => {
                (self.report)(&Said::Flight(message.clone()));
                message
            }
            other => {
                (self.report)(&other);
                return;
            }
        };
        if !current {
            return;
        }
        match message {
            FromFlight::Ready { version } if version != VERSION => {
                self.say(
                    Severity::WarningHi,
                    &format!(
                        "the flight process speaks protocol version {version}, this bootstrap {VERSION}: restart the bootstrap (was the program replaced under it?)"
                    ),
                );
                if self.state == State::Connecting {
                    self.answer(Reply::refused(format!(
                        "the flight process speaks protocol version {version}, this bootstrap {VERSION}"
                    )));
                }
                self.kill_child();
            }
            FromFlight::Ready { .. } if self.state == State::Connecting && self.restarting => {
                self.restarting = false;
                let told = match self.flying.clone() {
                    Some(p) => self.tell_child(&ToFlight::Restart(p)),
                    None => false,
                };
                if told {
                    self.set_state(State::Starting);
                } else {
                    self.say(
                        Severity::WarningHi,
                        "the restarted flight process is not listening",
                    );
                }
            }
            FromFlight::Ready { .. } if self.state == State::Connecting => {
                let pid = self.child.as_ref().map_or(0, |c| c.pid);
                self.set_state(State::Connected);
                self.answer(Reply::Connected { pid });
            }
            FromFlight::Started { log } if self.state == State::Starting => {
                let log = log.unwrap_or_else(|| "(no log)".into());
                self.log = Some(log.clone());
                self.set_state(State::Flying);
                self.answer(Reply::Flying { log });
            }
            FromFlight::Refused(why) => {
                // A start refused (a plan it does not know): the flight did not begin, so
                // the process's exit that follows is no crash in flight to restart.
                if self.state == State::Starting {
                    self.flying = None;
                    self.set_state(State::Connected);
                }
                // A Stop refused in the air, or its landing given up: the flight goes on.
                if matches!(self.state, State::Stopping | State::Landing) {
                    self.set_state(State::Flying);
                }
                self.answer(Reply::Refused(why));
            }
            FromFlight::Landing(what) => {
                if matches!(self.state, State::Stopping | State::Flying) {
                    self.set_state(State::Landing);
                }
                self.answer(Reply::Landing(what));
            }
            _ => {}
        }
    }

    pub(super) fn child_exited(&mut self, generation: u32, status: Exit) {
        let how = status.describe();
        self.last_exit = Some(how.clone());
        if !self.current(generation) {
            self.say(
                Severity::ActivityLo,
                &format!("old flight process ended: {how}"),
            );
            return;
        }
        let stopping = matches!(self.state, State::Stopping | State::Landing);
        let in_flight = matches!(self.state, State::Flying | State::Starting | State::Landing)
            && self.flying.is_some();
        let clean = stopping && status.success();
        self.child = None;
        if clean {
            self.flying = None;
            self.say(
                Severity::ActivityHi,
                &format!("flight process stopped cleanly ({how})"),
            );
            self.answer(Reply::Stopped { how });
        } else {
            self.say(Severity::Fatal, &format!("flight process CRASHED: {how}"));
            self.answer(Reply::refused(format!("the flight process ended: {how}")));
        }
        self.set_state(State::Idle);
        if in_flight && !clean {
            self.restart_in_flight();
        }
    }

    /// A flight process that crashed in flight is started again at once with the same
    /// parameters; it resumes from its predecessor's warm-start record (aligning in the air
    /// if the helicopter was flying). At most [`MAX_RESTARTS`] in [`RESTART_WINDOW`].
    pub(super) fn restart_in_flight(&mut self) {
        let now = Instant::now();
        self.restarts
            .retain(|t| now.saturating_duration_since(*t) < RESTART_WINDOW);
        if self.restarts.len() >= MAX_RESTARTS {
            self.flying = None;
            self.say(
                Severity::WarningHi,
                &format!(
                    "not restarting: {MAX_RESTARTS} restarts within {} s already",
                    RESTART_WINDOW.as_secs()
                ),
            );
            return;
        }
        self.restarts.push(now);
        match self.spawn_child() {
            Ok(()) => {
                self.restarting = true;
                self.say(
                    Severity::WarningHi,
                    "restarting the flight process to resume the flight",
                );
                self.set_state(State::Connecting);
            }
            Err(e) => {
                self.flying = None;
                self.say(
                    Severity::WarningHi,
                    &format!("could not restart the flight process: {e}"),
                );
            }
        }
    }

    /// At start: a flight process flying on since the last bootstrap died is taken back; a
    /// live one that cannot be is left alone (a second one would fight it for the devices);
    /// with none, a fresh record of a flight in the air resumes it.
    pub(super) fn take_back_or_resume(&mut self) {
        if let Some(path) = self.config.adopt_socket.clone() {
            match crate::adopt::take_back(&path, crate::adopt::ANSWER_WAIT) {
                Ok(Some(adopted)) => {
                    self.adopt(adopted);
                    return;
                }
                Ok(None) => {}
                Err(e) => {
                    self.say(
                        Severity::Fatal,
                        &format!(
                            "a flight process is running ({}) but could not be taken back: {e}; not starting another (it would fight it for the devices)",
                            path.display()
                        ),
                    );
                    return;
                }
            }
        }
        self.resume_after_power_on();
    }

    /// Takes back a flight process that flew on without a bootstrap: its lines are read as a
    /// child's; its end is known by its socket closing.
    fn adopt(&mut self, adopted: Adopted) {
        self.generation = self.generation.saturating_add(1);
        let generation = self.generation;
        let Adopted {
            pid,
            start,
            log,
            to_flight,
            from_flight,
        } = adopted;
        let tx = self.tx.clone();
        let reader = std::thread::Builder::new()
            .name(format!("child-{generation}"))
            .spawn(move || {
                let said_stopped = read_lines(from_flight, generation, &tx);
                wait_gone(pid);
                let _ = tx.send(Msg::ChildExited(generation, Exit::Adopted { said_stopped }));
            });
        if let Err(e) = reader {
            self.say(
                Severity::Fatal,
                &format!("could not take back the flight process (pid {pid}): {e}"),
            );
            return;
        }
        self.say(
            Severity::WarningHi,
            &format!(
                "took back the flight process (pid {pid}) flying {} since its bootstrap died; the flight goes on",
                crate::supervisor::start_words(&start)
            ),
        );
        self.child = Some(Child {
            generation,
            pid,
            stdin: Some(Box::new(to_flight)),
        });
        self.flying = Some(start);
        self.log = Some(log.unwrap_or_else(|| "(no log)".into()));
        self.last_telemetry = None;
        self.set_state(State::Flying);
    }

    /// At power-on (a brown-out of the whole computer): the freshest readable warm-start
    /// file, if it is fresh and says the helicopter was airborne, resumes the flight.
    /// A record whose age cannot be told (its time unreadable, or later than this
    /// computer's clock) is said, and not resumed from.
    pub(super) fn resume_after_power_on(&mut self) {
        let now = std::time::SystemTime::now();
        let mut records: Vec<(PathBuf, Duration)> = Vec::new();
        for path in self.config.warm_files.clone() {
            match record_age(&path, now) {
                Ok(Some(age)) => records.push((path, age)),
                Ok(None) => {}
                Err(why) => self.say(Severity::WarningHi, &why),
            }
        }
        records.sort_by_key(|(_, age)| *age);
        for (path, age) in records {
            match crate::warm::WarmFile::read(&path) {
                Ok(Some(file)) if age <= RESUME_AFTER_POWER_ON_MAX && file.warm.airborne => {
                    self.say(
                        Severity::WarningHi,
                        &format!(
                            "power-on with a fresh warm-start record ({}): resuming the flight in the air",
                            path.display()
                        ),
                    );
                    self.flying = Some(file.start);
                    self.restart_in_flight();
                    return;
                }
                Ok(Some(_)) => {
                    self.say(
                        Severity::ActivityLo,
                        &format!(
                            "an old or grounded warm-start record ({}): not resuming",
                            path.display()
                        ),
                    );
                    return;
                }
                Ok(None) => {}
                Err(e) => self.say(
                    Severity::WarningLo,
                    &format!("warm-start record unreadable, not resuming from it: {e}"),
                ),
            }
        }
    }
}

/// How old the warm-start record at `path` is at `now`: `None` where there is none, an
/// error (what to say) where its age cannot be told — its time unreadable, or later than
/// `now` (a clock set back at power-on: a computer without a battery-backed clock restores
/// an older time until GPS or the network sets it).
pub(crate) fn record_age(
    path: &std::path::Path,
    now: std::time::SystemTime,
) -> Result<Option<Duration>, String> {
    let modified = match std::fs::metadata(path).and_then(|m| m.modified()) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(format!(
                "warm-start record {}: its time cannot be read ({e}): not resuming from it",
                path.display()
            ));
        }
    };
    now.duration_since(modified).map(Some).map_err(|ahead| {
        format!(
            "warm-start record {} is dated {:.0} s after this computer's clock (a clock set back at power-on?): its age is unknown, not resuming from it",
            path.display(),
            ahead.duration().as_secs_f64()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::SystemTime;

    #[test]
    fn a_record_s_age_is_told_or_why_it_cannot_be() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("warm-start");
        let now = SystemTime::now();
        assert_eq!(
            record_age(&path, now),
            Ok(None),
            "no record, nothing to say"
        );
        // A record whose time cannot be read (here a path through a file: not a
        // directory, not a missing file) is said.
        let blocker = dir.path().join("a-file");
        std::fs::write(&blocker, "").unwrap();
        let unreadable = record_age(&blocker.join("warm-start"), now).unwrap_err();
        assert!(
            unreadable.contains("its time cannot be read") && unreadable.contains("a-file"),
            "{unreadable}"
        );
        std::fs::write(&path, "airborne = true\n").unwrap();
        let file = std::fs::File::options().write(true).open(&path).unwrap();
        file.set_modified(now - Duration::from_secs(5)).unwrap();
        assert_eq!(record_age(&path, now), Ok(Some(Duration::from_secs(5))));
        file.set_modified(now + Duration::from_secs(3600)).unwrap();
        let said = record_age(&path, now).unwrap_err();
        assert!(
            said.contains("is dated 3600 s after this computer's clock")
                && said.contains(&path.display().to_string())
                && said.ends_with("not resuming from it"),
            "{said}"
        );
    }
}
