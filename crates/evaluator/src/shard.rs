//! Deterministic sharding: shard K of N (1-based) holds the combinations whose index i satisfies
//! i mod N = K - 1, so a cluster job array can split a sweep without coordination and
//! [`crate::merge_csv`] can join the parts into the single-run table.

use std::fmt;
use std::str::FromStr;

use crate::EvalError;

/// Shard `k` of `n` (1 <= k <= n).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard's number, 1-based.
    pub k: usize,
    /// Number of shards.
    pub n: usize,
}

impl Shard {
    /// The whole sweep as one shard.
    pub const ALL: Shard = Shard { k: 1, n: 1 };

    /// Shard `k` of `n`; an error unless 1 <= k <= n.
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

    /// This shard's combination indices among `total`, ascending: `K−1, K−1+N, ..` below `total`,
    /// computed on demand (nothing is allocated, whatever `total`).
    pub fn indices(self, total: usize) -> ShardIndices {
        let first = self.k - 1;
        ShardIndices {
            first,
            step: self.n,
            len: total.saturating_sub(first).div_ceil(self.n),
        }
    }
}

/// The combination indices of a shard ([`Shard::indices`]): an arithmetic progression, held as
/// its first index, step and length. Iterate it, or hand it to [`crate::Evaluator::run`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ShardIndices {
    first: usize,
    step: usize,
    len: usize,
}

impl ShardIndices {
    /// Number of indices.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the shard holds no index.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The index at `position` (`None` from [`ShardIndices::len`] on).
    pub fn get(&self, position: usize) -> Option<usize> {
        (position < self.len).then(|| self.first + position * self.step)
    }

    /// The indices, ascending.
    pub fn iter(&self) -> std::iter::StepBy<std::ops::Range<usize>> {
        // The last index is first + (len − 1)·step < total, so the end cannot overflow.
        let end = match self.len {
            0 => self.first,
            n => self.first + (n - 1) * self.step + 1,
        };
        (self.first..end).step_by(self.step)
    }
}

impl IntoIterator for ShardIndices {
    type Item = usize;
    type IntoIter = std::iter::StepBy<std::ops::Range<usize>>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl IntoIterator for &ShardIndices {
    type Item = usize;
    type IntoIter = std::iter::StepBy<std::ops::Range<usize>>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// An ordered list of combination indices that [`crate::Evaluator::run`] reads position by
/// position, a chunk at a time, so it need not be materialised: a [`ShardIndices`], a range, or
/// an explicit list (`Vec<usize>`, `[usize]`, `[usize; N]`).
pub trait IndexList {
    /// Number of indices.
    fn index_count(&self) -> usize;
    /// The index at `position` (< [`IndexList::index_count`]).
    fn index_at(&self, position: usize) -> usize;
}

impl IndexList for ShardIndices {
    fn index_count(&self) -> usize {
        self.len
    }
    fn index_at(&self, position: usize) -> usize {
        assert!(position < self.len, "position {position} of {}", self.len);
        self.first + position * self.step
    }
}

impl IndexList for std::ops::Range<usize> {
    fn index_count(&self) -> usize {
        self.end.saturating_sub(self.start)
    }
    fn index_at(&self, position: usize) -> usize {
        assert!(
            position < self.index_count(),
            "position {position} of {self:?}"
        );
        self.start + position
    }
}

impl IndexList for [usize] {
    fn index_count(&self) -> usize {
        self.len()
    }
    fn index_at(&self, position: usize) -> usize {
        self[position]
    }
}

impl IndexList for Vec<usize> {
    fn index_count(&self) -> usize {
        self.len()
    }
    fn index_at(&self, position: usize) -> usize {
        self[position]
    }
}

impl<const N: usize> IndexList for [usize; N] {
    fn index_count(&self) -> usize {
        N
    }
    fn index_at(&self, position: usize) -> usize {
        self[position]
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
        let two = "2/3".parse::<Shard>().expect("valid").indices(7);
        assert_eq!(two.iter().collect::<Vec<_>>(), vec![1, 4]);
        assert_eq!((two.len(), two.get(1), two.get(2)), (2, Some(4), None));
        for total in 0..12 {
            for n in 1..5 {
                for k in 1..=n {
                    let s = Shard::new(k, n).expect("shard").indices(total);
                    let old: Vec<usize> = (k - 1..total).step_by(n).collect();
                    assert_eq!(s.iter().collect::<Vec<_>>(), old, "{k}/{n} of {total}");
                    assert_eq!(s.len(), old.len());
                    assert_eq!(s.is_empty(), old.is_empty());
                    let at: Vec<usize> = (0..s.index_count()).map(|p| s.index_at(p)).collect();
                    assert_eq!(at, old);
                }
            }
        }
        for bad in ["0/3", "4/3", "1/0", "3", "a/b", "1/2/3", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    /// A shard of an enormous sweep is a few numbers, not a list of its indices.
    #[test]
    fn shard_indices_are_lazy() {
        let s = Shard::new(3, 4).expect("shard").indices(usize::MAX);
        assert_eq!(s.len(), usize::MAX / 4 + 1);
        assert_eq!(s.get(s.len() - 1), Some(usize::MAX - 1));
        assert_eq!(s.iter().take(3).collect::<Vec<_>>(), [2, 6, 10]);
        assert_eq!(s.iter().nth(s.len() - 1), Some(usize::MAX - 1));
        assert!(std::mem::size_of::<ShardIndices>() <= 3 * std::mem::size_of::<usize>());
        assert_eq!(Shard::ALL.indices(0).len(), 0);
        assert_eq!(
            Shard::new(5, 5).expect("shard").indices(3).iter().count(),
            0
        );
    }
}
