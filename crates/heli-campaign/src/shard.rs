//! Shards: a campaign split for a batch system that already exists. `--shard I/N` flies the
//! flights whose index is I modulo N; `heli campaign merge` joins the shards' reports.

use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::CampaignError;
use crate::error::ShardProblem;

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
        let bad = |problem| CampaignError::Shard {
            given: s.to_string(),
            problem,
        };
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| bad(ShardProblem::NoSlash))?;
        let index: u64 = i
            .trim()
            .parse()
            .map_err(|_| bad(ShardProblem::IndexNotWhole))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| bad(ShardProblem::CountNotWhole))?;
        if count == 0 {
            return Err(bad(ShardProblem::NoShards));
        }
        if index >= count {
            return Err(bad(ShardProblem::IndexTooLarge { count }));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}
