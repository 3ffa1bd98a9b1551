//! The link's receive path: arbitrary datagrams to the vehicle's end (with and without a
//! signing key) and to the ground's end. Nothing may panic; a datagram never yields a
//! command unless its frames are valid and, with a key, signed.
#![no_main]

use heli_link::ground::GroundLink;
use heli_link::logs::MemoryStore;
use heli_link::signing::Key;
use heli_link::vehicle::{LinkEvent, VehicleLink};
use libfuzzer_sys::fuzz_target;

const T0: u64 = 1_763_900_000_000_000;

fuzz_target!(|data: &[u8]| {
    let store = MemoryStore {
        logs: vec![("a.mcap".into(), vec![1; 1000])],
    };
    let mut signed = VehicleLink::new(Some(Key::new([7; 32])), T0);
    let events = signed.receive(data, T0, &store);
    // Without the key no frame can be signed correctly: no command gets through.
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, LinkEvent::Command { .. }))
    );
    let _ = signed.tick(T0 + 1_000, Default::default(), None, &store);
    let mut open = VehicleLink::new(None, T0);
    let _ = open.receive(data, T0, &store);
    let _ = open.tick(T0 + 1_000, Default::default(), None, &store);
    let mut ground = GroundLink::new(None);
    ground.receive(data, T0);
    let _ = ground.download_tick(T0 + 1_000_000);
});
