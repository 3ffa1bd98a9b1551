//! Flight logs of the heli avionics.
//!
//! What it will be: the crash-safe in-flight writer of the seven streams (the thesis's
//! chapter 4 recommendation: write to non-volatile memory during flight, so a crash loses at
//! most the last chunk), the reader, CSV export and plots. What it is today: the naming of
//! log files from the ground's final parameters ([`file_name`]), which both the vehicle and
//! the ground use.

/// The seven streams whose histories are logged, in the thesis's order.
pub const STREAMS: [&str; 7] = ["imu", "state", "servo", "uplink", "gps", "baro", "compass"];

/// Name of one stream's log file: `<stream>_<suffix>.<extension>`, as the thesis's cleanup
/// routine names one file per shared-memory buffer with the operator's suffix.
pub fn file_name(stream: &str, suffix: &str, extension: &str) -> String {
    format!("{stream}_{suffix}.{extension}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_per_stream_with_the_suffix() {
        let names: Vec<String> = STREAMS
            .iter()
            .map(|s| file_name(s, "nov18", "csv"))
            .collect();
        assert_eq!(names[0], "imu_nov18.csv");
        assert_eq!(names.len(), 7);
    }
}
