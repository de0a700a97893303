//! Deterministic sharding: shard K of N (1-based) holds the combinations whose index i satisfies
//! i mod N = K - 1, so a cluster job array can split a sweep without coordination and
//! [`crate::merge_csv`] can join the parts into the single-run table.

use std::fmt;
use std::str::FromStr;

use crate::EvalError;

/// Shard `k` of `n` (1 <= k <= n).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub k: usize,
    pub n: usize,
}

impl Shard {
    /// The whole sweep as one shard.
    pub const ALL: Shard = Shard { k: 1, n: 1 };

    pub fn new(k: usize, n: usize) -> Result<Shard, EvalError> {
        if n >= 1 && (1..=n).contains(&k) {
            Ok(Shard { k, n })
        } else {
            Err(EvalError::Shard(format!("{k}/{n}")))
        }
    }

    /// Whether combination `index` belongs to this shard.
    pub fn contains(self, index: usize) -> bool {
        index % self.n == self.k - 1
    }

    /// This shard's combination indices among `total`, ascending.
    pub fn indices(self, total: usize) -> Vec<usize> {
        (self.k - 1..total).step_by(self.n).collect()
    }
}

impl FromStr for Shard {
    type Err = EvalError;
    fn from_str(s: &str) -> Result<Shard, EvalError> {
        let bad = || EvalError::Shard(s.to_string());
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let k: usize = k.trim().parse().map_err(|_| bad())?;
        let n: usize = n.trim().parse().map_err(|_| bad())?;
        Shard::new(k, n).map_err(|_| bad())
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_partition_the_indices() {
        let mut all: Vec<usize> = (1..=3)
            .flat_map(|k| Shard::new(k, 3).expect("shard").indices(10))
            .collect();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert_eq!(
            "2/3".parse::<Shard>().expect("valid").indices(7),
            vec![1, 4]
        );
        for bad in ["0/3", "4/3", "1/0", "3", "a/b", "1/2/3", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
