//! The battery packs' logbook (thesis §4.2.2): the packs named in a file, and the time each
//! has spent powering the avionics, added up over every flight, which the ground operator
//! used to keep by hand.
//!
//! The packs file (`heli ground --http ADDR --packs FILE`):
//!
//! ```toml
//! [[pack]]
//! name = "F1"          # as written on the pack
//! role = "flight"      # flight, ground, receiver or servo
//! cycles = 120         # charge cycles so far
//! ```
//!
//! Start Logging names the flight pack installed (`pack`); at Stop, the flight's time on the
//! flight batteries (from the vehicle's hot-swap log) is added to that pack and its time on
//! the ground battery to the `ground` pack, and the totals are saved beside the packs file
//! (`FILE.times.json`). Sans-I/O: the station reads and writes nothing; the runtime loads the
//! file and saves what [`PackLog::totals_json`] gives.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

/// A pack's role.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// A flight pack (computer and sensors).
    Flight,
    /// The ground battery of the hot-swap.
    Ground,
    /// The servo board's receiver pack.
    Receiver,
    /// The servo pack.
    Servo,
}

/// One pack of the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pack {
    /// Its name.
    pub name: String,
    /// Its role.
    pub role: Role,
    /// Charge cycles so far.
    #[serde(default)]
    pub cycles: u32,
}

/// A pack's totals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Totals {
    /// Time powering the avionics, over every flight (s).
    pub seconds: f64,
    /// Flights it powered.
    pub flights: u32,
}

/// The packs file's contents.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
struct PacksFile {
    #[serde(default)]
    pack: Vec<Pack>,
}

/// The logbook.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackLog {
    packs: Vec<Pack>,
    totals: BTreeMap<String, Totals>,
    /// The flight pack of the flight under way.
    flying: Option<String>,
}

/// One pack on the display.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PackTotalsView {
    /// Name.
    pub name: String,
    /// Role.
    pub role: Role,
    /// Charge cycles.
    pub cycles: u32,
    /// Hours powering the avionics, over every flight.
    pub hours: f64,
    /// Flights.
    pub flights: u32,
    /// The flight pack of the flight under way.
    pub in_use: bool,
}

/// A packs file, its totals or a named pack that cannot be used.
#[derive(Debug)]
pub enum PacksError {
    /// The packs file is not TOML of packs.
    Toml(toml::de::Error),
    /// A pack's name is not 1-16 letters, digits, '-' or '_'.
    BadName(String),
    /// Two packs have this name.
    Twice(String),
    /// More than one pack has the role 'ground'.
    TwoGround,
    /// The saved totals are not the totals' JSON.
    Totals(serde_json::Error),
    /// Start Logging names a pack the file does not name as a flight pack.
    UnknownPack {
        /// The name given.
        name: String,
        /// The file's flight packs.
        flight_packs: Vec<String>,
    },
}

impl fmt::Display for PacksError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PacksError::Toml(e) => e.fmt(f),
            PacksError::BadName(name) => {
                write!(f, "pack name '{name}': 1-16 letters, digits, '-' or '_'")
            }
            PacksError::Twice(name) => write!(f, "pack '{name}' is named twice"),
            PacksError::TwoGround => {
                f.write_str("at most one pack has the role 'ground' (the hot-swap's)")
            }
            PacksError::Totals(e) => write!(f, "saved totals: {e}"),
            PacksError::UnknownPack { name, flight_packs } => write!(
                f,
                "unknown flight pack '{name}' (the packs file names {})",
                if flight_packs.is_empty() {
                    "none".to_string()
                } else {
                    flight_packs.join(", ")
                }
            ),
        }
    }
}

impl std::error::Error for PacksError {}

impl PackLog {
    /// The logbook of a packs file's text and the saved totals (empty if none yet); an
    /// error names what is wrong.
    pub fn parse(packs_toml: &str, totals_json: Option<&str>) -> Result<Self, PacksError> {
        let file: PacksFile = toml::from_str(packs_toml).map_err(PacksError::Toml)?;
        let mut seen = std::collections::BTreeSet::new();
        for p in &file.pack {
            let ok = !p.name.is_empty()
                && p.name.len() <= 16
                && p.name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
            if !ok {
                return Err(PacksError::BadName(p.name.clone()));
            }
            if !seen.insert(p.name.clone()) {
                return Err(PacksError::Twice(p.name.clone()));
            }
        }
        if file.pack.iter().filter(|p| p.role == Role::Ground).count() > 1 {
            return Err(PacksError::TwoGround);
        }
        let totals = match totals_json {
            Some(text) => serde_json::from_str(text).map_err(PacksError::Totals)?,
            None => BTreeMap::new(),
        };
        Ok(Self {
            packs: file.pack,
            totals,
            flying: None,
        })
    }

    /// Whether any pack is named.
    pub fn is_empty(&self) -> bool {
        self.packs.is_empty()
    }

    /// A flight begins on flight pack `name` (`None`: not said): refused if the file does
    /// not name it as a flight pack.
    pub fn begin(&mut self, name: Option<&str>) -> Result<(), PacksError> {
        self.check(name)?;
        self.flying = name
            .map(str::trim)
            .filter(|n| !n.is_empty())
            .map(str::to_string);
        Ok(())
    }

    /// Whether [`PackLog::begin`] would take `name` (a flight pack of the file, or none).
    pub fn check(&self, name: Option<&str>) -> Result<(), PacksError> {
        let Some(name) = name.map(str::trim).filter(|n| !n.is_empty()) else {
            return Ok(());
        };
        let flight_packs: Vec<&str> = self
            .packs
            .iter()
            .filter(|p| p.role == Role::Flight)
            .map(|p| p.name.as_str())
            .collect();
        if !flight_packs.contains(&name) {
            return Err(PacksError::UnknownPack {
                name: name.to_string(),
                flight_packs: flight_packs.iter().map(|p| (*p).to_string()).collect(),
            });
        }
        Ok(())
    }

    /// The flight ended with `flight_s` on the flight batteries and `ground_s` on the
    /// ground battery: the times are added to the flight pack and the ground pack. Returns
    /// what was added, for the message area (`None`: nothing to add).
    pub fn end(&mut self, flight_s: Option<f64>, ground_s: Option<f64>) -> Option<String> {
        let mut added = Vec::new();
        if let (Some(name), Some(s)) = (self.flying.take(), flight_s.filter(|s| *s > 0.0)) {
            let t = self.totals.entry(name.clone()).or_default();
            t.seconds += s;
            t.flights = t.flights.saturating_add(1);
            added.push(format!("{name} +{s:.0} s"));
        }
        let ground = self.packs.iter().find(|p| p.role == Role::Ground);
        if let (Some(g), Some(s)) = (ground, ground_s.filter(|s| *s > 0.0)) {
            let t = self.totals.entry(g.name.clone()).or_default();
            t.seconds += s;
            t.flights = t.flights.saturating_add(1);
            added.push(format!("{} +{s:.0} s", g.name));
        }
        (!added.is_empty()).then(|| format!("pack times: {}", added.join(", ")))
    }

    /// The totals as JSON, to save.
    pub fn totals_json(&self) -> Vec<u8> {
        serde_json::to_vec_pretty(&self.totals).unwrap_or_default()
    }

    /// The packs for the display.
    pub fn view(&self) -> Vec<PackTotalsView> {
        self.packs
            .iter()
            .map(|p| {
                let t = self.totals.get(&p.name).copied().unwrap_or_default();
                PackTotalsView {
                    name: p.name.clone(),
                    role: p.role,
                    cycles: p.cycles,
                    hours: t.seconds / 3600.0,
                    flights: t.flights,
                    in_use: self.flying.as_deref() == Some(p.name.as_str()),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = r#"
[[pack]]
name = "F1"
role = "flight"
cycles = 120

[[pack]]
name = "F2"
role = "flight"

[[pack]]
name = "G"
role = "ground"
"#;

    #[test]
    fn a_flight_adds_its_times_to_its_flight_pack_and_the_ground_pack() {
        let mut log = PackLog::parse(FILE, None).unwrap();
        assert!(
            log.begin(Some("F3"))
                .unwrap_err()
                .to_string()
                .contains("F1, F2")
        );
        log.begin(Some("F1")).unwrap();
        assert!(log.view()[0].in_use);
        let added = log.end(Some(600.0), Some(90.0)).unwrap();
        assert_eq!(added, "pack times: F1 +600 s, G +90 s");
        log.begin(Some("F1")).unwrap();
        log.end(Some(300.0), None);
        let again =
            PackLog::parse(FILE, Some(&String::from_utf8(log.totals_json()).unwrap())).unwrap();
        let v = again.view();
        assert_eq!(
            (v[0].name.as_str(), v[0].flights, v[0].cycles),
            ("F1", 2, 120)
        );
        assert!((v[0].hours - 0.25).abs() < 1e-9);
        assert_eq!(v[1].flights, 0);
        assert_eq!(v[2].flights, 1);
        // A flight with no pack named adds nothing to a flight pack.
        let mut log = again;
        log.begin(None).unwrap();
        assert_eq!(log.end(Some(100.0), None), None);
    }

    #[test]
    fn a_bad_packs_file_is_refused_with_the_reason() {
        let twice = "[[pack]]\nname='A'\nrole='flight'\n[[pack]]\nname='A'\nrole='servo'\n";
        assert!(
            PackLog::parse(twice, None)
                .unwrap_err()
                .to_string()
                .contains("twice")
        );
        assert!(
            PackLog::parse("[[pack]]\nname='a b'\nrole='flight'\n", None)
                .unwrap_err()
                .to_string()
                .contains("letters")
        );
        assert!(PackLog::parse("[[pack]]\nname='A'\nrole='spare'\n", None).is_err());
        assert!(
            PackLog::parse("", Some("{"))
                .unwrap_err()
                .to_string()
                .contains("saved totals")
        );
    }
}
