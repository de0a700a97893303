//! # arcsim-resequence
//!
//! A faster delivery of the same dose without replanning. The layers of one control point belong to
//! its angle and are delivered inside its window; their order decides how many energy switches go
//! up (slow) instead of down. This crate finds the order that minimises the plan's summed
//! switching time exactly ([`best_orders`]: a dynamic programme over the control points, Held–Karp
//! inside each), optionally with each arc turned the other way and the arcs reordered, simulates
//! every candidate on the machine's controller and keeps the original wherever no candidate is
//! shorter ([`resequence`]). [`check_same_dose`] proves a candidate delivers the same layers and
//! spots at the same control points before anything is written.

#![warn(missing_docs)]

mod estimate;
mod neutral;
mod order;
mod resequence;

pub use estimate::GantryCost;
pub use neutral::{check_same_dose, DoseChange};
pub use order::{
    best_orders, best_orders_by, order_cost_s, switch_cost_s, SwitchCost, MAX_LAYERS_REORDERED,
};
pub use resequence::{
    arrange, resequence, ArcFreedom, Candidate, Outcome, ResequenceError, ResequenceOptions,
    SEARCH_LAYER_BUDGET,
};
