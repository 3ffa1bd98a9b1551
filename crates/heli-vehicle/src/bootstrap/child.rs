//! The bootstrap's side of the flight process: starting it, hearing its lines and its exit,
//! killing it, and restarting it with its parameters when it crashes in flight or when the
//! vehicle powers on with a fresh record of a flight under way.

use super::*;
use crate::error::ChildProblem;

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
        // Each line read is parsed here, on the reader's thread: the bootstrap's loop sees
        // only messages.
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
                    for line in BufReader::new(out).lines() {
                        let Ok(line) = line else { break };
                        let said = match FromFlight::parse(&line) {
                            Ok(message) => Said::Flight(message),
                            Err(error) => Said::Unreadable { line, error },
                        };
                        if tx.send(Msg::FromChild(generation, said)).is_err() {
                            break;
                        }
                    }
                }
                if let Ok(status) = child.wait() {
                    let _ = tx.send(Msg::ChildExited(generation, status));
                }
            })
            .map_err(|e| VehicleError::Child(ChildProblem::Reader(e)))?;
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
                self.answer(Reply::Refused(why));
            }
            _ => {}
        }
    }

    pub(super) fn child_exited(&mut self, generation: u32, status: ExitStatus) {
        let how = describe_exit(status);
        self.last_exit = Some(how.clone());
        if !self.current(generation) {
            self.say(
                Severity::ActivityLo,
                &format!("old flight process ended: {how}"),
            );
            return;
        }
        let stopping = self.state == State::Stopping;
        let in_flight =
            matches!(self.state, State::Flying | State::Starting) && self.flying.is_some();
        self.child = None;
        if stopping && status.success() {
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
        if in_flight && !stopping {
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

    /// At power-on (a brown-out of the whole computer): a fresh warm-start file that says
    /// the helicopter was airborne resumes the flight it was flying.
    pub(super) fn resume_after_power_on(&mut self) {
        let Some(path) = self.config.warm_file.clone() else {
            return;
        };
        let fresh = std::fs::metadata(&path)
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age <= RESUME_AFTER_POWER_ON_MAX);
        match crate::warm::WarmFile::read(&path) {
            Ok(Some(file)) if fresh && file.warm.airborne => {
                self.say(
                    Severity::WarningHi,
                    &format!(
                        "power-on with a fresh warm-start record ({}): resuming the flight in the air",
                        path.display()
                    ),
                );
                self.flying = Some(file.start);
                self.restart_in_flight();
            }
            Ok(Some(_)) => self.say(
                Severity::ActivityLo,
                "an old or grounded warm-start record: not resuming",
            ),
            Ok(None) => {}
            Err(e) => self.say(
                Severity::WarningLo,
                &format!("warm-start record unreadable, not resuming: {e}"),
            ),
        }
    }
}
