//! What the ground station says of its datagrams to and from the vehicle when the network
//! fails them: a send that fails (no route, the interface down) means the operator's
//! commands and the station's heartbeats are not going out; a receive that fails (the
//! vehicle's address refusing them: nothing listening there) means nothing comes back.
//! Each is a [`Spell`]: its first failure is said with the cause, the rest are counted, and
//! the first datagram through after them is said with the count. "Connection refused" is
//! the vehicle's address refusing (the ICMP answer to an earlier datagram, handed by the
//! system to whichever call on the socket comes next): the receiving side's failure, even
//! when a send is the call that gets it. Sans-I/O: the server
//! hands in the outcomes and puts what comes back in the message area.

use std::net::SocketAddr;

use heli_types::Spell;

/// A line for the message area: its severity and text.
pub type Said = (&'static str, String);

/// The two directions' spells, to and from the vehicle at one address.
#[derive(Clone, Debug)]
pub struct Datagrams {
    vehicle: SocketAddr,
    sending: Spell,
    receiving: Spell,
}

impl Datagrams {
    /// The datagrams to and from `vehicle`.
    pub fn new(vehicle: SocketAddr) -> Self {
        Self {
            vehicle,
            sending: Spell::default(),
            receiving: Spell::default(),
        }
    }

    /// The outcome of sending a frame: what to say, at a spell's beginning or end.
    pub fn sent(&mut self, outcome: &std::io::Result<usize>) -> Option<Said> {
        match outcome {
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => self.received(outcome),
            Err(e) => self.sending.failed().then(|| {
                (
                    "error",
                    format!(
                        "sending to the vehicle at {} failed ({e}): commands and heartbeats \
                         are not going out",
                        self.vehicle
                    ),
                )
            }),
            Ok(_) => self.sending.worked().map(|n| {
                (
                    "info",
                    format!(
                        "sending to the vehicle at {} again, after {n} frames were lost",
                        self.vehicle
                    ),
                )
            }),
        }
    }

    /// The outcome of a receive: what to say, at a spell's beginning or end.
    pub fn received(&mut self, outcome: &std::io::Result<usize>) -> Option<Said> {
        match outcome {
            Err(e) => self.receiving.failed().then(|| {
                (
                    "warning",
                    format!(
                        "no datagrams from the vehicle at {} ({e}): is heli vehicle running \
                         there, with its link on this address?",
                        self.vehicle
                    ),
                )
            }),
            Ok(_) => self.receiving.worked().map(|n| {
                (
                    "info",
                    format!(
                        "datagrams from the vehicle at {} again, after {n} failed receives",
                        self.vehicle
                    ),
                )
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused() -> Result<usize, std::io::Error> {
        Err(std::io::Error::from(std::io::ErrorKind::ConnectionRefused))
    }

    #[test]
    fn a_failing_send_is_said_once_with_its_cause_and_its_end_with_the_count() {
        let mut d = Datagrams::new("127.0.0.1:14550".parse().unwrap());
        assert_eq!(d.sent(&Ok(20)), None);
        let unreachable = Err(std::io::Error::other("network is unreachable"));
        let (severity, text) = d.sent(&unreachable).unwrap();
        assert_eq!(severity, "error");
        assert!(
            text.contains("127.0.0.1:14550") && text.contains("network is unreachable"),
            "{text}"
        );
        assert_eq!(d.sent(&unreachable), None, "counted, not said again");
        assert_eq!(d.sent(&unreachable), None);
        let (severity, text) = d.sent(&Ok(20)).unwrap();
        assert_eq!(severity, "info");
        assert!(text.contains("after 3 frames were lost"), "{text}");
        assert_eq!(d.sent(&Ok(20)), None);
    }

    #[test]
    fn a_refusing_vehicle_address_is_a_warning_until_a_datagram_comes() {
        let mut d = Datagrams::new("10.0.0.2:14550".parse().unwrap());
        let (severity, text) = d.received(&refused()).unwrap();
        assert_eq!(severity, "warning");
        assert!(text.contains("10.0.0.2:14550"), "{text}");
        assert_eq!(d.received(&refused()), None);
        let (_, text) = d.received(&Ok(100)).unwrap();
        assert!(text.contains("after 2 failed receives"), "{text}");
        // The two directions are separate spells.
        let unreachable = Err(std::io::Error::other("network is unreachable"));
        assert!(d.sent(&unreachable).is_some());
        assert!(d.received(&refused()).is_some());
    }

    #[test]
    fn a_refusal_handed_to_a_send_is_the_vehicle_not_listening_not_a_lost_send() {
        let mut d = Datagrams::new("127.0.0.1:14550".parse().unwrap());
        let (severity, text) = d.sent(&refused()).unwrap();
        assert_eq!(severity, "warning");
        assert!(text.starts_with("no datagrams from the vehicle"), "{text}");
        assert_eq!(d.received(&refused()), None, "the same spell");
        assert_eq!(d.sent(&Ok(20)), None, "no send was lost");
    }
}
