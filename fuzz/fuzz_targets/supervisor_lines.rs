//! The bootstrap ↔ flight-process protocol (`heli_vehicle::supervisor`): arbitrary bytes,
//! split into lines, read as the flight process reads the bootstrap's lines and as the
//! bootstrap reads the flight process's. Asserts: no panic; a line that parses prints as a
//! line that parses to the same message (what one end writes, the other reads back).
#![no_main]

use heli_vehicle::supervisor::{FromFlight, ToFlight};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    for line in text.split('\n') {
        if let Ok(message) = ToFlight::parse(line) {
            let again = ToFlight::parse(&message.to_string())
                .unwrap_or_else(|e| panic!("{message} does not parse back: {e}"));
            assert_eq!(again.to_string(), message.to_string());
        }
        if let Ok(message) = FromFlight::parse(line) {
            let printed = message.to_string();
            let again = FromFlight::parse(&printed)
                .unwrap_or_else(|e| panic!("{printed} does not parse back: {e}"));
            assert_eq!(again.to_string(), printed);
        }
    }
});
