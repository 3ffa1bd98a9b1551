//! The lab's attestation: the field flies what the lab tested (thesis §4.3: "the flight
//! system should remain a black box while on the field; the system should undergo thorough
//! laboratory testing after any modification").
//!
//! `heli certify` runs the regression library of recorded flights and the robustness suite
//! against a build of the flight software and a parameter set, and when they pass writes an
//! attestation: the build's SHA-256 (the program that runs the flight process), the
//! parameters' SHA-256 and values, and what was run, signed with HMAC-SHA256 under the link
//! key (`heli link keygen`), which the vehicle holds too (it lives here, beside the link's
//! signing, for the vehicle and `heli certify` alike). The vehicle judges its own
//! configuration against it ([`judge`]): lab-tested, or NOT lab-tested and what changed.
//! Augmented and autonomous flight on a configuration that is not lab-tested needs the
//! operator's explicit override, which the flight's log records.
//!
//! Reads the program file and the attestation file ([`file_sha256`], [`LabCheck`]); the rest
//! takes text and values. The format is JSON
//! (docs/security.md); the signature covers the body as this module writes it, so the
//! file's spacing may change but no value.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::params::ParamTable;
use crate::signing::Key;
use crate::status::{LAB_TESTED, NOT_LAB_TESTED, Tested};

/// The attestation's file name in a vehicle's log directory (its default place).
pub const FILE_NAME: &str = "attestation.json";
/// The attestation format this module writes and reads.
pub const FORMAT: u32 = 1;

/// What flies: the build and the parameters.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identity {
    /// SHA-256 of the program that runs the flight process (hex).
    pub build_sha256: String,
    /// SHA-256 of the parameters ([`params_sha256`], hex).
    pub params_sha256: String,
    /// Every parameter's value, as text that reads back to the same number.
    pub params: BTreeMap<String, String>,
}

impl Identity {
    /// The identity of `program` flying `table`.
    pub fn of(program: &Path, table: &ParamTable) -> std::io::Result<Self> {
        Ok(Self::new(file_sha256(program)?, table))
    }

    /// The identity of a build whose hash is `build_sha256`, flying `table`.
    pub fn new(build_sha256: String, table: &ParamTable) -> Self {
        let params: BTreeMap<String, String> = table
            .iter()
            .map(|(spec, value)| (spec.name.to_string(), value.to_string()))
            .collect();
        Self {
            build_sha256,
            params_sha256: params_sha256(&params),
            params,
        }
    }
}

/// SHA-256 of a file, in hex (an error names the file).
pub fn file_sha256(path: &Path) -> std::io::Result<String> {
    let named =
        |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    let mut file = std::fs::File::open(path).map_err(named)?;
    let mut hash = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf).map_err(named)?;
        let Some(read) = buf.get(..n).filter(|r| !r.is_empty()) else {
            break;
        };
        hash.update(read);
    }
    Ok(hex(&hash.finalize()))
}

/// SHA-256 of the parameters: one `NAME=VALUE` line each, in name order.
pub fn params_sha256(params: &BTreeMap<String, String>) -> String {
    let mut hash = Sha256::new();
    for (name, value) in params {
        hash.update(format!("{name}={value}\n"));
    }
    hex(&hash.finalize())
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// One recorded flight of the regression library, replayed to the build under test.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReplayEvidence {
    /// The recorded flight's file name.
    pub flight: String,
    /// Its SHA-256.
    pub flight_sha256: String,
    /// Recorded servo commands.
    pub recorded: u64,
    /// Of them, answered by the build under test.
    pub paired: u64,
    /// Answered with a different command (beyond the tolerance).
    pub out_of_tolerance: u64,
    /// The largest difference on any channel (µs of pulse width).
    pub largest_difference_us: u64,
    /// Whether the flight process ran it through without crashing or being restarted.
    pub ran_through: bool,
}

impl ReplayEvidence {
    /// The thesis's certification by replay: "the system still accepts these already-tested
    /// inputs": every recorded input answered, the flight process never lost.
    pub fn accepted(&self) -> bool {
        self.ran_through && self.recorded > 0 && self.paired == self.recorded
    }
}

/// The robustness suite's result.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteEvidence {
    /// The suite's directory, as given.
    pub dir: String,
    /// Flights flown.
    pub flights: u64,
    /// Passed.
    pub pass: u64,
    /// Crashed.
    pub crash: u64,
    /// Could not be flown.
    pub error: u64,
    /// The pass rate required, in tenths of a percent.
    pub min_pass_permille: u64,
}

impl SuiteEvidence {
    /// No crash, nothing unflown, and the pass rate reached.
    pub fn passed(&self) -> bool {
        self.crash == 0
            && self.error == 0
            && self.flights > 0
            && self.pass.saturating_mul(1000) >= self.min_pass_permille.saturating_mul(self.flights)
    }
}

/// What the lab attests.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// [`FORMAT`].
    pub format: u32,
    /// The build and parameters tested.
    pub identity: Identity,
    /// When (Unix time, s).
    pub certified_unix_s: u64,
    /// The program that ran the tests (`heli 0.1.0`).
    pub certified_by: String,
    /// The regression library's flights.
    pub replays: Vec<ReplayEvidence>,
    /// The robustness suite.
    pub suite: SuiteEvidence,
}

impl Body {
    /// Whether everything it records passed.
    pub fn passed(&self) -> bool {
        self.suite.passed() && self.replays.iter().all(ReplayEvidence::accepted)
    }

    fn signed_bytes(&self) -> Result<Vec<u8>, serde_json::Error> {
        serde_json::to_vec(self)
    }
}

/// A signed attestation, as its file holds it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Attestation {
    /// What is attested.
    pub body: Body,
    /// HMAC-SHA256 of the body (as [`serde_json::to_vec`] writes it) under the link key.
    pub hmac_sha256: String,
}

/// Why an attestation cannot be taken.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AttestError {
    /// Not an attestation's JSON.
    Unreadable(String),
    /// Another format.
    Format(u32),
    /// The signature does not match the key.
    Signature,
}

impl std::fmt::Display for AttestError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AttestError::Unreadable(why) => write!(f, "not an attestation: {why}"),
            AttestError::Format(n) => write!(f, "format {n}, this vehicle reads {FORMAT}"),
            AttestError::Signature => write!(
                f,
                "its signature does not match this vehicle's key (signed with another key, or edited)"
            ),
        }
    }
}

impl std::error::Error for AttestError {}

/// `body` signed with `key`.
pub fn sign(body: Body, key: &Key) -> Result<Attestation, AttestError> {
    let bytes = body
        .signed_bytes()
        .map_err(|e| AttestError::Unreadable(e.to_string()))?;
    Ok(Attestation {
        hmac_sha256: hex(&key.hmac_sha256(&bytes)),
        body,
    })
}

/// The attestation's file text.
pub fn to_text(attestation: &Attestation) -> Result<String, AttestError> {
    serde_json::to_string_pretty(attestation)
        .map(|t| t + "\n")
        .map_err(|e| AttestError::Unreadable(e.to_string()))
}

/// The body of the attestation `text`, if its signature under `key` holds.
pub fn verify(text: &str, key: &Key) -> Result<Body, AttestError> {
    let attestation: Attestation =
        serde_json::from_str(text).map_err(|e| AttestError::Unreadable(e.to_string()))?;
    if attestation.body.format != FORMAT {
        return Err(AttestError::Format(attestation.body.format));
    }
    let bytes = attestation
        .body
        .signed_bytes()
        .map_err(|e| AttestError::Unreadable(e.to_string()))?;
    let expected = hex(&key.hmac_sha256(&bytes));
    // Compared whole, in constant time for equal lengths.
    let same = expected.len() == attestation.hmac_sha256.len()
        && expected
            .bytes()
            .zip(attestation.hmac_sha256.bytes())
            .fold(0u8, |acc, (a, b)| acc | (a ^ b))
            == 0;
    if !same {
        return Err(AttestError::Signature);
    }
    Ok(attestation.body)
}

/// What the vehicle makes of its configuration.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The build and parameters are the ones the lab tested.
    LabTested {
        /// The attestation's body.
        body: Box<Body>,
    },
    /// They are not, or no attestation can be checked: why, each reason a phrase.
    NotTested {
        /// What changed or is missing.
        why: Vec<String>,
    },
}

impl Verdict {
    /// As the heartbeat says it.
    pub fn tested(&self) -> Tested {
        match self {
            Verdict::LabTested { .. } => Tested::LabTested,
            Verdict::NotTested { .. } => Tested::NotTested,
        }
    }

    /// The statement the vehicle makes: `lab-tested: …` or `NOT lab-tested: …`.
    pub fn line(&self) -> String {
        match self {
            Verdict::LabTested { body } => format!(
                "{LAB_TESTED}: build {}, parameters {}, certified {} ({} recorded flight{} replayed, robustness suite {} of {} passed)",
                short(&body.identity.build_sha256),
                short(&body.identity.params_sha256),
                utc_text(body.certified_unix_s),
                body.replays.len(),
                if body.replays.len() == 1 { "" } else { "s" },
                body.suite.pass,
                body.suite.flights
            ),
            Verdict::NotTested { why } => format!("{NOT_LAB_TESTED}: {}", why.join("; ")),
        }
    }
}

/// The first 8 hex digits of a hash.
pub fn short(hash: &str) -> &str {
    hash.get(..8).unwrap_or(hash)
}

/// Where the attestation is read from, and the key that checks it.
#[derive(Clone, Debug)]
pub struct LabCheck {
    /// The attestation file.
    pub attestation: PathBuf,
    /// The link key (none: nothing can be checked).
    pub key: Option<Key>,
}

impl LabCheck {
    /// The verdict on `identity`.
    pub fn judge(&self, identity: &Identity) -> Verdict {
        let text = match std::fs::read_to_string(&self.attestation) {
            Ok(text) => Ok(Some(text)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e.to_string()),
        };
        judge(
            identity,
            &self.attestation,
            text.as_ref().map(Option::as_deref).map_err(String::as_str),
            self.key.as_ref(),
        )
    }
}

/// The verdict on `identity` given the attestation file's `text` (read from `path`: none if
/// there is no file, or why it could not be read) and the vehicle's `key`.
pub fn judge(
    identity: &Identity,
    path: &Path,
    text: Result<Option<&str>, &str>,
    key: Option<&Key>,
) -> Verdict {
    let not = |why: String| Verdict::NotTested { why: vec![why] };
    let Some(key) = key else {
        return not(
            "no key to check a lab attestation with (start the vehicle with --key, the key the lab signed with)"
                .into(),
        );
    };
    let text = match text {
        Ok(Some(text)) => text,
        Ok(None) => {
            return not(format!(
                "no lab attestation at {} (heli certify writes one)",
                path.display()
            ));
        }
        Err(why) => {
            return not(format!(
                "the lab attestation {} cannot be read: {why}",
                path.display()
            ));
        }
    };
    let body = match verify(text, key) {
        Ok(body) => body,
        Err(e) => return not(format!("the lab attestation {}: {e}", path.display())),
    };
    let mut why = Vec::new();
    if !body.passed() {
        why.push("the attestation records tests that did not pass".to_string());
    }
    if body.identity.build_sha256 != identity.build_sha256 {
        why.push(format!(
            "the build changed (this flight software {}, the lab tested {})",
            short(&identity.build_sha256),
            short(&body.identity.build_sha256)
        ));
    }
    if body.identity.params_sha256 != identity.params_sha256 {
        why.push(format!(
            "parameters changed since the lab's tests: {}",
            changed_params(&body.identity.params, &identity.params)
        ));
    }
    if why.is_empty() {
        Verdict::LabTested {
            body: Box::new(body),
        }
    } else {
        Verdict::NotTested { why }
    }
}

/// `NAME now (tested was)` for each parameter that differs, comma-separated.
fn changed_params(tested: &BTreeMap<String, String>, now: &BTreeMap<String, String>) -> String {
    let names: std::collections::BTreeSet<&String> = tested.keys().chain(now.keys()).collect();
    let missing = "none".to_string();
    let changes: Vec<String> = names
        .into_iter()
        .filter_map(|name| {
            let was = tested.get(name).unwrap_or(&missing);
            let is = now.get(name).unwrap_or(&missing);
            (was != is).then(|| format!("{name} {is} (tested {was})"))
        })
        .collect();
    if changes.is_empty() {
        "their hash differs".into()
    } else {
        changes.join(", ")
    }
}

/// A Unix time as `YYYY-MM-DD HH:MM UTC`.
pub fn utc_text(unix_s: u64) -> String {
    let days = unix_s / 86_400;
    let secs = unix_s % 86_400;
    // Days to a civil date (H. Hinnant's algorithm), for dates after 1970: every step is
    // within u64 for any date, and saturating where a subtraction appears.
    let z = days.saturating_add(719_468);
    let era = z / 146_097;
    let doe = z % 146_097;
    let yoe = doe
        .saturating_sub(doe / 1460)
        .saturating_add(doe / 36_524)
        .saturating_sub(doe / 146_096)
        / 365;
    let doy = doe.saturating_sub(
        yoe.saturating_mul(365)
            .saturating_add(yoe / 4)
            .saturating_sub(yoe / 100),
    );
    let mp = doy.saturating_mul(5).saturating_add(2) / 153;
    let day = doy
        .saturating_sub(mp.saturating_mul(153).saturating_add(2) / 5)
        .saturating_add(1);
    let month = if mp < 10 {
        mp.saturating_add(3)
    } else {
        mp.saturating_sub(9)
    };
    let year = yoe
        .saturating_add(era.saturating_mul(400))
        .saturating_add(u64::from(month <= 2));
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        secs / 3600,
        (secs % 3600) / 60
    )
}

#[cfg(test)]
#[path = "attest_tests.rs"]
mod tests;
