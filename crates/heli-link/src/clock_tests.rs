//! The vehicle's link and the grounds' clocks and streams: a ground whose clock is fast
//! locks no one out, two grounds signing at once are two streams, a held-back parameter
//! write is not obeyed, and a refused ground is told why in its own terms.

use mavlink::dialects::common::*;

use crate::command::{CMD_CONNECT, command_long};
use crate::ground::GroundLink;
use crate::logs::MemoryStore;
use crate::messages::GroundCommand;
use crate::params::{ONE_GAIN, ParamTable};
use crate::signing::{Key, Refusal};
use crate::vehicle::{LinkEvent, VehicleLink};

/// 2025-11-23: the vehicle's clock is set.
const T0: u64 = 1_763_900_000_000_000;
const HOUR_US: u64 = 3_600_000_000;

fn connect(g: &mut GroundLink, now_us: u64) -> Vec<u8> {
    g.command_frame(
        command_long(&GroundCommand::Connect, (1, 1)).unwrap(),
        now_us,
    )
}

fn refusals(events: &[LinkEvent]) -> Vec<Refusal> {
    events
        .iter()
        .filter_map(|e| match e {
            LinkEvent::Refused { reason, .. } => Some(*reason),
            _ => None,
        })
        .collect()
}

fn commands(events: &[LinkEvent]) -> usize {
    events
        .iter()
        .filter(|e| matches!(e, LinkEvent::Command { .. }))
        .count()
}

#[test]
fn a_ground_an_hour_fast_is_refused_and_a_correct_one_still_commands_on_the_same_stream() {
    let key = Key::new([6; 32]);
    let store = MemoryStore::default();
    let mut v = VehicleLink::new(Some(key.clone()), T0);
    // Both on link 1: the stream every ground shared before each picked its own.
    let mut fast = GroundLink::on_link(Some(key.clone()), 1);
    let mut correct = GroundLink::on_link(Some(key), 1);
    let ev = v.receive(&connect(&mut fast, T0 + HOUR_US), T0, &store);
    assert_eq!(refusals(&ev), [Refusal::Future]);
    assert_eq!(v.refused().future, 1);
    let ev = v.receive(&connect(&mut correct, T0 + 1_000), T0 + 1_000, &store);
    assert_eq!(commands(&ev), 1, "{ev:?}");
    // The fast ground is no peer (its frames were refused), but it holds the key: it is
    // answered, once, that its clock is the cause, naming its stream.
    for d in v.take_replies() {
        fast.receive(&d, T0 + 2_000);
    }
    fast.flush_texts(T0 + 4_000_000);
    let said = fast.refusal_of_ours().expect("the vehicle's refusal");
    assert!(said.contains("stamped in the future"), "{said}");
    assert!(said.contains("from 255/190 link 1 "), "{said}");
    assert!(said.contains("clock is fast"), "{said}");
    // A sender without the key is answered nothing.
    let mut stranger = GroundLink::on_link(Some(Key::new([7; 32])), 1);
    let ev = v.receive(&connect(&mut stranger, T0 + 3_000), T0 + 3_000, &store);
    assert_eq!(refusals(&ev), [Refusal::BadSignature]);
    assert!(v.take_replies().is_empty());
}

#[test]
fn two_grounds_on_their_own_links_never_look_like_replays_of_each_other() {
    let key = Key::new([6; 32]);
    let store = MemoryStore::default();
    let mut v = VehicleLink::new(Some(key.clone()), T0);
    let mut a = GroundLink::on_link(Some(key.clone()), 17);
    let mut b = GroundLink::on_link(Some(key.clone()), 200);
    // `a` stamps a little ahead of `b` (clocks a few ms apart): on one stream, b's every
    // frame would be a replay.
    for k in 0..5 {
        let t = T0 + k * 100_000;
        assert!(refusals(&v.receive(&connect(&mut a, t + 50_000), t, &store)).is_empty());
        assert!(refusals(&v.receive(&connect(&mut b, t), t, &store)).is_empty());
    }
    assert_eq!(v.refused().total(), 0);
    assert_eq!(v.stats.frames_in, 10);
    // The same two on one link: the later-stamped one wins and the other is refused.
    let mut c = GroundLink::on_link(Some(key.clone()), 9);
    let mut d = GroundLink::on_link(Some(key), 9);
    let t = T0 + HOUR_US / 100;
    assert!(refusals(&v.receive(&connect(&mut c, t + 50_000), t, &store)).is_empty());
    let ev = v.receive(&connect(&mut d, t), t, &store);
    assert_eq!(refusals(&ev), [Refusal::Replayed]);
    for reply in v.take_replies() {
        d.receive(&reply, t);
    }
    d.flush_texts(t + 2_000_000);
    let said = d.refusal_of_ours().expect("the vehicle's refusal");
    assert!(said.contains("same link id"), "{said}");
    assert_eq!(a.link_id(), 17);
}

#[test]
fn a_recorded_parameter_write_sent_after_a_restart_is_not_obeyed() {
    let key = Key::new([6; 32]);
    let store = MemoryStore::default();
    let mut g = GroundLink::on_link(Some(key.clone()), 3);
    let set = g.param_set_frame("A_GAIN", 0.9, T0);
    // The vehicle restarts (its streams forgotten); the frame comes 30 s after it was
    // signed, well inside a new stream's minute.
    let mut v = VehicleLink::new(Some(key), T0).with_params(ParamTable::new(&ONE_GAIN));
    let ev = v.receive(&set, T0 + 30_000_000, &store);
    assert_eq!(refusals(&ev), [Refusal::Stale]);
    assert_eq!(v.params().get("A_GAIN"), Some(0.5));
    // Sent fresh, the same write is obeyed.
    let fresh = g.param_set_frame("A_GAIN", 0.9, T0 + 30_000_000);
    let ev = v.receive(&fresh, T0 + 30_000_000, &store);
    assert!(refusals(&ev).is_empty(), "{ev:?}");
    assert_eq!(v.params().get("A_GAIN"), Some(0.9));
    assert_eq!(CMD_CONNECT, MavCmd::MAV_CMD_USER_1);
}

#[test]
fn a_vehicle_without_a_set_clock_takes_a_correct_ground_and_refuses_a_far_future_one() {
    let key = Key::new([6; 32]);
    let store = MemoryStore::default();
    // A flight computer booted in 1970 (no real-time clock, no network time yet).
    let boot_us = 5_000_000;
    let mut v = VehicleLink::new(Some(key.clone()), boot_us);
    let mut g = GroundLink::on_link(Some(key.clone()), 4);
    assert_eq!(
        commands(&v.receive(&connect(&mut g, T0), boot_us, &store)),
        1
    );
    let mut far = GroundLink::on_link(Some(key), 5);
    let ev = v.receive(&connect(&mut far, T0 + 24 * HOUR_US), boot_us + 1, &store);
    assert_eq!(refusals(&ev), [Refusal::Future]);
    let ev = v.receive(&connect(&mut g, T0 + 1_000_000), boot_us + 2, &store);
    assert!(refusals(&ev).is_empty(), "{ev:?}");
    assert_eq!(v.stats.frames_in, 2);
}
