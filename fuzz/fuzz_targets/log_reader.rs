//! A damaged flight log: arbitrary bytes, and real logs cut or corrupted anywhere (the
//! fuzzer mutates the seeds). Reading must never panic, must say why it stopped when it did
//! not reach the end, and what it read must export and select for plotting without panicking.
#![no_main]

use heli_campaign::log_plot::{self as plot, Window};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let contents = heli_log::read(data);
    let counted: u64 = contents.counts().values().sum();
    assert_eq!(counted, contents.messages.len() as u64);
    if let Some((first, last)) = contents.span_us() {
        assert!(first <= last);
    }
    let mut topics: Vec<&str> = contents.messages.iter().map(|m| m.topic.as_str()).collect();
    topics.dedup();
    for topic in topics.into_iter().take(4) {
        let _ = heli_log::to_csv(&contents, topic);
        let _ = plot::panels(&contents, topic, &[], Window::default());
    }
    let _ = plot::events(&contents, Window::default());
    let _ = heli_log::stats::channels(&contents);
    let _ = heli_log::stats::faults(&contents);
});
