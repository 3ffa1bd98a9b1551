//! Shards: a campaign split for a batch system that already exists. `--shard I/N` flies the
//! flights whose index is I modulo N; `heli campaign merge` joins the shards' reports.

use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::CampaignError;

/// One of `count` parts of a campaign: the flights whose index is `index` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which part, from 0.
    pub index: u64,
    /// How many parts.
    pub count: u64,
}

impl Shard {
    /// The whole campaign: shard 0/1.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether flight `flight` is in this shard.
    pub fn contains(&self, flight: u64) -> bool {
        flight % self.count == self.index
    }
}

impl FromStr for Shard {
    type Err = CampaignError;

    /// `I/N`, with `0 <= I < N`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |why: &str| {
            CampaignError(format!(
                "--shard {s}: {why} (write I/N, 0 <= I < N: I is 0-based, as $SLURM_ARRAY_TASK_ID and $JOB_COMPLETION_INDEX are)"
            ))
        };
        let (i, n) = s.split_once('/').ok_or_else(|| bad("no '/'"))?;
        let index: u64 = i
            .trim()
            .parse()
            .map_err(|_| bad("I is not a whole number"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| bad("N is not a whole number"))?;
        if count == 0 {
            return Err(bad("N must be at least 1"));
        }
        if index >= count {
            return Err(bad(&format!("I must be from 0 to {}", count - 1)));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}
