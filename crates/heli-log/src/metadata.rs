//! What a log says about its flight: MCAP Metadata records, written by the log's owner with
//! [`crate::FlightLog::write_metadata`] and read back in [`crate::LogContents::metadata`].
//!
//! [`flight`] builds the usual record: the software that flew, when the flight started by the
//! wall clock (the vehicle clock in the messages starts at power-on), and the owner's flight
//! parameters (`heli sim` puts the whole scenario in, as TOML, so a logged flight can be flown
//! again).

use std::collections::BTreeMap;
use std::time::{SystemTime, UNIX_EPOCH};

/// Name of the record [`flight`] builds.
pub const FLIGHT: &str = "flight";

/// The `flight` record's entries: `software`, `log_format`, `wall_clock_start_utc`
/// (RFC 3339), `wall_clock_start_unix_ms`, then the owner's `parameters` (which may not
/// replace those four).
pub fn flight(
    software: &str,
    started: SystemTime,
    parameters: impl IntoIterator<Item = (String, String)>,
) -> BTreeMap<String, String> {
    let mut entries: BTreeMap<String, String> = parameters.into_iter().collect();
    let since_epoch = started.duration_since(UNIX_EPOCH).unwrap_or_default();
    entries.insert("software".into(), software.into());
    entries.insert(
        "log_format".into(),
        concat!("heli-log ", env!("CARGO_PKG_VERSION")).into(),
    );
    entries.insert(
        "wall_clock_start_utc".into(),
        rfc3339_utc(since_epoch.as_secs(), since_epoch.subsec_millis()),
    );
    entries.insert(
        "wall_clock_start_unix_ms".into(),
        since_epoch.as_millis().to_string(),
    );
    entries
}

/// `YYYY-MM-DDThh:mm:ss.sssZ` for a time `seconds` + `millis` after the Unix epoch.
pub fn rfc3339_utc(seconds: u64, millis: u32) -> String {
    let days = (seconds / 86_400) as i64;
    let of_day = seconds % 86_400;
    // Days to civil date (H. Hinnant, "chrono-Compatible Low-Level Date Algorithms").
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{millis:03}Z",
        of_day / 3600,
        of_day / 60 % 60,
        of_day % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn wall_clock_times_are_rfc3339() {
        assert_eq!(rfc3339_utc(0, 0), "1970-01-01T00:00:00.000Z");
        assert_eq!(rfc3339_utc(1_700_000_000, 5), "2023-11-14T22:13:20.005Z");
        assert_eq!(rfc3339_utc(951_782_400, 0), "2000-02-29T00:00:00.000Z");
        assert_eq!(rfc3339_utc(4_107_542_399, 999), "2100-02-28T23:59:59.999Z");
    }

    #[test]
    fn the_flight_record_has_the_software_the_start_and_the_parameters() {
        let started = UNIX_EPOCH + Duration::from_millis(1_700_000_000_250);
        let entries = flight(
            "heli 0.1.0",
            started,
            [
                ("scenario".to_string(), "hover".to_string()),
                ("software".to_string(), "not this".to_string()),
            ],
        );
        assert_eq!(entries["software"], "heli 0.1.0");
        assert_eq!(entries["scenario"], "hover");
        assert_eq!(entries["wall_clock_start_utc"], "2023-11-14T22:13:20.250Z");
        assert_eq!(entries["wall_clock_start_unix_ms"], "1700000000250");
        assert!(entries["log_format"].starts_with("heli-log "));
    }
}
