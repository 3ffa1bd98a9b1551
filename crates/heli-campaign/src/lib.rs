//! The heli workstation's analysis of many flights and of one.
//!
//! What it is: Monte Carlo campaigns — many simulated flights of one scenario with some of
//! its values drawn at random or stepped over a grid, flown in parallel and summed up in one
//! report (`heli campaign`, docs/campaigns.md) — and the plots of a flight log's channels
//! ([`log_plot`], `heli log plot`). The crate that takes a thread pool (rayon) and a plotting
//! library (plotters), so that nothing below it does.
//!
//! What it is not: the simulation itself (`heli-sim` flies each flight) or anything that
//! flies: the onboard program never links it.
//!
//! A campaign's pieces, in the order it goes through them:
//!
//! - [`file`]: the campaign file (TOML), checked when it is loaded: every number finite,
//!   ranges ordered, counts positive, every varied key present in the scenario, and the ends
//!   of every range accepted by the scenario's own checks. Errors name the file, the key and
//!   the allowed range.
//! - [`sample`]: flight `i` of a campaign, a pure function of the file and `i`: its values
//!   are drawn from a ChaCha stream of its own (campaign seed, stream `i`), so that a shard
//!   draws exactly the flights a whole run draws. Each flight's scenario is built as a
//!   scenario file and goes through [`heli_scenario::from_toml`], checks included.
//! - [`runner`]: the flights on a rayon pool (`--jobs`), one shard of them (`--shard I/N`:
//!   the flights whose index is `I` modulo `N`); a flight that cannot be built or panics is
//!   recorded as an error, never the end of the campaign.
//! - [`report`]: what the flights gave (JSON): per flight, totals, failures per criterion and
//!   the worst cases (ranked by a score: the worst criterion against its limit) with the
//!   command that flies each again; [`merge()`] joins shard reports into the report one
//!   whole run would have written.
//! - [`plot`]: outcomes against each varied value (SVG, PNG); [`files`] writes them with the
//!   report, [`table`] prints it.
//! - [`suite`]: every campaign file of a directory flown and judged together against a
//!   floor (the robustness suite).

mod checks;
pub mod error;
pub mod file;
pub mod files;
mod keys;
pub mod log_plot;
mod merge;
pub mod plot;
pub mod report;
pub mod runner;
pub mod sample;
mod score;
pub mod shard;
pub mod suite;
pub mod table;
pub mod vary;

#[cfg(test)]
mod tests;

pub use file::Campaign;
pub use merge::merge;
pub use report::{FlightOutcome, FlightRecord, Report, Totals};
pub use runner::{RunConfig, run, run_with_software};
pub use sample::Flight;
pub use shard::Shard;
pub use vary::{Draw, Vary};

pub use checks::VaryError;
pub use error::{CampaignError, FileProblem, FlightError, MergeProblem, ShardProblem};
pub use keys::KeyError;
pub use vary::ResolveError;

/// A 64-bit FNV-1a hash of `parts` (each length-prefixed), as 16 hex digits: the campaign's
/// fingerprint. Not cryptographic: it keeps reports of different campaign files from being
/// merged by mistake.
pub(crate) fn fingerprint(parts: &[&[u8]]) -> String {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut hash = OFFSET;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            hash ^= u64::from(*b);
            hash = hash.wrapping_mul(PRIME);
        }
    };
    for part in parts {
        eat(&(part.len() as u64).to_le_bytes());
        eat(part);
    }
    format!("{hash:016x}")
}
