//! Parallel evaluation of plans x machine variants x schedules: sweeps, summaries, shards.
