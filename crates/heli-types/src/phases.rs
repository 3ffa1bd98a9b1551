//! The flight software's phases by name: the names its state records, events and the
//! heartbeat give them (`heli_fsw::phase::Phase::name`), one list for every crate that
//! speaks of a phase (the link's heartbeat codes, a scenario's fault timing).

/// The flight software's phases, by name (`heli_fsw::phase::Phase::name`), in the
/// heartbeat's order (its phase code is the index from 1).
pub const PHASES: [&str; 19] = [
    "calibrating",
    "manual",
    "ground-failsafe",
    "blind-descent",
    "takeoff-refused",
    "preflight-check",
    "takeoff",
    "hold",
    "fly",
    "accelerate",
    "pull-up",
    "rolling",
    "recover",
    "land",
    "autorotation",
    "landed",
    "augmented-rate",
    "augmented-attitude",
    "augmented-velocity",
];
