//! Model checking of the streams' publish protocol with loom: every interleaving of a writer
//! publishing and a reader reading. Run with
//! `RUSTFLAGS="--cfg loom" cargo test -p heli-vehicle --test loom_streams --release`
//! (docs/verification.md); in an ordinary build this file is empty.

#![cfg(loom)]
#![allow(
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    clippy::cast_possible_wrap,
    clippy::unwrap_used
)]

use std::sync::Arc;

use heli_vehicle::streams::Latest;

/// A reader that has seen the count `n` sees the `n`-th value or a later one: the status
/// line's counts never run ahead of the values shown with them.
#[test]
fn the_count_never_runs_ahead_of_the_value() {
    loom::model(|| {
        let latest = Arc::new(Latest::<u64>::default());
        let writer = {
            let latest = Arc::clone(&latest);
            loom::thread::spawn(move || {
                latest.publish(1);
                latest.publish(2);
            })
        };
        let count = latest.published();
        let value = latest.latest().map_or(0, |v| *v);
        assert!(value >= count, "count {count} ahead of value {value}");
        writer.join().unwrap();
        assert_eq!(latest.published(), 2);
        assert_eq!(latest.latest().map(|v| *v), Some(2));
    });
}

/// Two readers never see the values go backwards, whatever the interleaving.
#[test]
fn a_reader_never_sees_an_older_value_again() {
    loom::model(|| {
        let latest = Arc::new(Latest::<u64>::default());
        let writer = {
            let latest = Arc::clone(&latest);
            loom::thread::spawn(move || {
                for v in 1..=3 {
                    latest.publish(v);
                }
            })
        };
        let first = latest.latest().map_or(0, |v| *v);
        let second = latest.latest().map_or(0, |v| *v);
        assert!(second >= first);
        writer.join().unwrap();
    });
}
