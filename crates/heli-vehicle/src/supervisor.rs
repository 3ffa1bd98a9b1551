//! The bootstrap ↔ flight-process protocol: one typed message per line on the flight
//! process's standard input and output, parsed and emitted here and nowhere else.
//!
//! The lines stay readable (the bootstrap prints the flight process's lines for the
//! operator), and each side works with the types only:
//!
//! | direction | line | message |
//! |---|---|---|
//! | bootstrap → flight | `start SUFFIX MODE [PLAN] [override-untested]` | [`ToFlight::Start`] (the last word: the operator's override of the lab-tested check) |
//! | | `restart SUFFIX MODE [PLAN]` | [`ToFlight::Restart`]: resume after a crash |
//! | | `link fresh` / `link lost` | [`ToFlight::Link`]: whether a ground is heard |
//! | | `stop` | [`ToFlight::Stop`]: end the flight on the ground (in the air: land first, or refused) |
//! | | `kill` | [`ToFlight::Kill`]: end the flight process now, in the air too |
//! | flight → bootstrap | `ready V` | [`FromFlight::Ready`]: up, speaking protocol version V |
//! | | `started LOG` | [`FromFlight::Started`] (`(no log)` without one) |
//! | | `error TEXT` | [`FromFlight::Refused`]: a start it cannot fly, a Stop refused in the air (or its landing given up), a line it does not understand |
//! | | `landing TEXT` | [`FromFlight::Landing`]: a Stop in the air, landing first; `stopped` follows on the ground |
//! | | `note TEXT` | [`FromFlight::Note`]: from the runtime |
//! | | `event SEVERITY TEXT` | [`FromFlight::Event`]: from the flight computer |
//! | | `telemetry JSON` | [`FromFlight::Telemetry`] |
//! | | `plan JSON` | [`FromFlight::Plan`]: the plan's legs, for the link's mission protocol |
//! | | `stopped JSON` | [`FromFlight::Stopped`]: the flight's counts |
//! | | `adopted PID SUFFIX MODE [PLAN]` | [`FromFlight::Adopted`]: a flight under way, taken back by a new bootstrap |
//!
//! **Adoption.** A flight process whose bootstrap is gone while it flies listens on its
//! adoption socket (`crate::adopt`); a bootstrap started again (by the init system) connects,
//! hears `ready V` and `adopted …`, and speaks the same protocol over that socket.
//!
//! **Versions.** The flight process says its protocol [`VERSION`] in `ready`; a bootstrap
//! refuses a flight process that speaks another (an always-on bootstrap of the old software
//! after the program on the flight computer was replaced) rather than misread it.
//!
//! Parsing never panics and refuses anything it does not know with the reason
//! ([`ProtocolError`]); the fuzz target `supervisor_lines` feeds it arbitrary lines.

use std::fmt;

use heli_fsw::core::Severity;
use heli_link::StartParameters;
use heli_types::Leg;
use serde_json::Value;

/// The protocol's version.
pub const VERSION: u16 = 4;

/// The longest line either side sends or takes (a telemetry snapshot is about 2 kB).
pub const MAX_LINE: usize = 64 * 1024;

/// What the bootstrap tells the flight process.
#[derive(Clone, Debug, PartialEq)]
pub enum ToFlight {
    /// Start Logging: fly with these parameters.
    Start(StartParameters),
    /// Started again after a crash in flight: resume with these parameters, from the
    /// warm-start record.
    Restart(StartParameters),
    /// Whether a ground is heard (on a vehicle with a link, on each change).
    Link {
        /// A ground heard in the last few seconds.
        fresh: bool,
    },
    /// Stop: end the flight on the ground. The flight computer answers: at once on the
    /// ground, landing first in the air when it flies ([`FromFlight::Landing`]), refused when
    /// the pilot flies ([`FromFlight::Refused`]).
    Stop,
    /// Kill: end the flight process now, in the air too (the operator confirmed it).
    Kill,
}

/// What the flight process tells the bootstrap.
#[derive(Clone, Debug, PartialEq)]
pub enum FromFlight {
    /// Up and waiting for the start.
    Ready {
        /// The protocol version it speaks.
        version: u16,
    },
    /// The log is open and the loop is about to start.
    Started {
        /// The log file, if any.
        log: Option<String>,
    },
    /// A start it cannot fly (a plan it does not know), or a line it did not understand.
    Refused(String),
    /// A note from the runtime (real-time settings, a port error, a restarted thread).
    Note(String),
    /// An event of the flight computer.
    Event {
        /// How much it matters.
        severity: Severity,
        /// What happened.
        text: String,
    },
    /// A telemetry snapshot (a JSON object).
    Telemetry(Value),
    /// The flight plan's legs.
    Plan(Vec<Leg>),
    /// A Stop in the air: the flight computer lands first (what it said); `stopped`
    /// follows on the ground.
    Landing(String),
    /// The flight is over: its counts (a JSON object).
    Stopped(Value),
    /// Said to a bootstrap that connected to the adoption socket: this process (`pid`) is
    /// flying `start` and now answers to it.
    Adopted {
        /// The flight process's id.
        pid: u32,
        /// The start it is flying.
        start: StartParameters,
    },
}

/// A line that is not a message of the protocol.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ProtocolError {
    /// Longer than [`MAX_LINE`].
    TooLong(usize),
    /// Nothing in it.
    Empty,
    /// A word no message starts with.
    Unknown(String),
    /// A known message whose arguments are wrong; the text says how.
    Malformed {
        /// The message's word.
        word: &'static str,
        /// What is wrong.
        why: String,
    },
}

impl fmt::Display for ProtocolError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ProtocolError::TooLong(n) => write!(f, "a line of {n} bytes (at most {MAX_LINE})"),
            ProtocolError::Empty => write!(f, "an empty line"),
            ProtocolError::Unknown(word) => write!(f, "unknown message '{word:.40}'"),
            ProtocolError::Malformed { word, why } => write!(f, "'{word}': {why}"),
        }
    }
}

impl std::error::Error for ProtocolError {}

/// The first word and the rest of a line, checked for length and emptiness.
fn split(line: &str) -> Result<(&str, &str), ProtocolError> {
    if line.len() > MAX_LINE {
        return Err(ProtocolError::TooLong(line.len()));
    }
    let line = line.trim_end_matches(['\n', '\r']);
    let (word, rest) = line.split_once(' ').unwrap_or((line, ""));
    if word.is_empty() {
        return Err(ProtocolError::Empty);
    }
    Ok((word, rest))
}

fn malformed(word: &'static str, why: impl Into<String>) -> ProtocolError {
    ProtocolError::Malformed {
        word,
        why: why.into(),
    }
}

/// The word that ends a start's words when the operator overrides the lab-tested check
/// (`heli_link::attest`): not a plan name.
pub const OVERRIDE_WORD: &str = "override-untested";

/// `SUFFIX MODE [PLAN] [override-untested]`, checked as the link checks Start Logging.
fn start_parameters(word: &'static str, rest: &str) -> Result<StartParameters, ProtocolError> {
    let mut words: Vec<&str> = rest.split(' ').collect();
    let override_untested = words.last() == Some(&OVERRIDE_WORD);
    if override_untested {
        words.pop();
    }
    match words.as_slice() {
        [suffix, mode, plan @ ..] if plan.len() <= 1 => {
            let mut p =
                StartParameters::new(suffix, mode).map_err(|e| malformed(word, e.to_string()))?;
            match plan.first() {
                Some(&"") => return Err(malformed(word, "an empty plan name")),
                Some(name) => p.plan = Some((*name).to_string()),
                None => {}
            }
            p.override_untested = override_untested;
            Ok(p)
        }
        _ => Err(malformed(
            word,
            "expected SUFFIX MODE [PLAN] [override-untested]",
        )),
    }
}

/// The parameters of a start as the words `SUFFIX MODE [PLAN] [override-untested]` (also how
/// the warm-start record keeps the flight it was flying).
pub fn start_words(p: &StartParameters) -> String {
    let mut words = format!("{} {}", p.file_suffix, p.controller.name());
    if let Some(plan) = &p.plan {
        words.push(' ');
        words.push_str(plan);
    }
    if p.override_untested {
        words.push(' ');
        words.push_str(OVERRIDE_WORD);
    }
    words
}

/// The parameters of the words `SUFFIX MODE [PLAN]` (see [`start_words`]).
pub fn parse_start_words(words: &str) -> Result<StartParameters, ProtocolError> {
    start_parameters("start", words)
}

/// A JSON object.
fn json(word: &'static str, rest: &str) -> Result<Value, ProtocolError> {
    let value: Value = serde_json::from_str(rest).map_err(|e| malformed(word, e.to_string()))?;
    match value {
        Value::Object(_) => Ok(value),
        _ => Err(malformed(word, "expected a JSON object")),
    }
}

/// One line of free text: no line break may hide a second message in it.
fn text(rest: &str) -> String {
    rest.replace(['\n', '\r'], " ")
}

impl ToFlight {
    /// The message of a line.
    pub fn parse(line: &str) -> Result<Self, ProtocolError> {
        let (word, rest) = split(line)?;
        match word {
            "start" => Ok(ToFlight::Start(start_parameters("start", rest)?)),
            "restart" => Ok(ToFlight::Restart(start_parameters("restart", rest)?)),
            "link" => match rest {
                "fresh" => Ok(ToFlight::Link { fresh: true }),
                "lost" => Ok(ToFlight::Link { fresh: false }),
                _ => Err(malformed("link", "expected fresh or lost")),
            },
            "stop" if rest.is_empty() => Ok(ToFlight::Stop),
            "stop" => Err(malformed("stop", "takes nothing")),
            "kill" if rest.is_empty() => Ok(ToFlight::Kill),
            "kill" => Err(malformed("kill", "takes nothing")),
            other => Err(ProtocolError::Unknown(other.to_string())),
        }
    }

    /// The message's line (without its line break).
    pub fn to_line(&self) -> String {
        match self {
            ToFlight::Start(p) => format!("start {}", start_words(p)),
            ToFlight::Restart(p) => format!("restart {}", start_words(p)),
            ToFlight::Link { fresh: true } => "link fresh".into(),
            ToFlight::Link { fresh: false } => "link lost".into(),
            ToFlight::Stop => "stop".into(),
            ToFlight::Kill => "kill".into(),
        }
    }
}

impl fmt::Display for ToFlight {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_line())
    }
}

/// What a flight process's `started` says when it keeps no log.
const NO_LOG: &str = "(no log)";

impl FromFlight {
    /// The message of a line.
    pub fn parse(line: &str) -> Result<Self, ProtocolError> {
        let (word, rest) = split(line)?;
        match word {
            "ready" => rest
                .parse::<u16>()
                .map(|version| FromFlight::Ready { version })
                .map_err(|_| malformed("ready", "expected the protocol version")),
            "started" if rest.is_empty() => Err(malformed("started", "expected the log")),
            "started" if rest == NO_LOG => Ok(FromFlight::Started { log: None }),
            "started" => Ok(FromFlight::Started {
                log: Some(rest.to_string()),
            }),
            "error" => Ok(FromFlight::Refused(rest.to_string())),
            "note" => Ok(FromFlight::Note(rest.to_string())),
            "landing" => Ok(FromFlight::Landing(rest.to_string())),
            "event" => {
                let (severity, text) = rest.split_once(' ').unwrap_or((rest, ""));
                let severity = Severity::from_name(severity)
                    .ok_or_else(|| malformed("event", format!("no severity '{severity:.20}'")))?;
                Ok(FromFlight::Event {
                    severity,
                    text: text.to_string(),
                })
            }
            "telemetry" => Ok(FromFlight::Telemetry(json("telemetry", rest)?)),
            "plan" => serde_json::from_str(rest)
                .map(FromFlight::Plan)
                .map_err(|e| malformed("plan", e.to_string())),
            "stopped" => Ok(FromFlight::Stopped(json("stopped", rest)?)),
            "adopted" => {
                let (pid, start) = rest.split_once(' ').unwrap_or((rest, ""));
                let pid = pid
                    .parse::<u32>()
                    .map_err(|_| malformed("adopted", "expected PID SUFFIX MODE [PLAN]"))?;
                Ok(FromFlight::Adopted {
                    pid,
                    start: start_parameters("adopted", start)?,
                })
            }
            other => Err(ProtocolError::Unknown(other.to_string())),
        }
    }

    /// The message's line (without its line break).
    pub fn to_line(&self) -> String {
        match self {
            FromFlight::Ready { version } => format!("ready {version}"),
            FromFlight::Started { log } => {
                format!("started {}", log.as_deref().map_or(NO_LOG.into(), text))
            }
            FromFlight::Refused(why) => format!("error {}", text(why)),
            FromFlight::Note(note) => format!("note {}", text(note)),
            FromFlight::Landing(what) => format!("landing {}", text(what)),
            FromFlight::Event { severity, text: t } => {
                format!("event {} {}", severity.name(), text(t))
            }
            FromFlight::Telemetry(v) => format!("telemetry {v}"),
            FromFlight::Plan(legs) => format!(
                "plan {}",
                serde_json::to_string(legs).unwrap_or_else(|_| "[]".into())
            ),
            FromFlight::Stopped(v) => format!("stopped {v}"),
            FromFlight::Adopted { pid, start } => format!("adopted {pid} {}", start_words(start)),
        }
    }
}

impl fmt::Display for FromFlight {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_line())
    }
}

#[cfg(test)]
mod tests;
