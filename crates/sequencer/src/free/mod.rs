//! Free motion: the gantry may change speed while a layer is irradiated.
//!
//! ATOM's model (and arcsim's `constant` motion) irradiates each layer at one constant speed,
//! its sweep centred on the layer's angle, with zero acceleration at every beam-on and beam-off.
//! The machine is bound by less: layer `k` is irradiated for `t_k` seconds while the gantry is
//! anywhere inside the window `[θ_k - w_k/2, θ_k + w_k/2]`; at least the ELST passes between one
//! beam-off and the next beam-on; and the whole delivery is one jerk-, acceleration- and
//! speed-limited motion that never reverses inside an arc. Every constant-speed timeline is a
//! free one, so free motion is never slower; with a low jerk limit it is much faster, because the
//! gantry keeps accelerating across many layers instead of returning to zero acceleration at
//! each of them.
//!
//! The solver (per arc):
//! 1. *Anchors* are cut at the switches that are long against the moves between layers (the
//!    gantry must slow down to last them) and at rest ends. Between two cuts, the layers are
//!    delivered along **one** move, the fastest jerk-limited move between its anchor states
//!    (beam-on of its first layer, beam-off of its last), with every beam scheduled as early as
//!    the window and the previous switch allow; when the fastest move outruns a beam, it is
//!    lengthened just enough, and a stretch that cannot be delivered that way is cut in two.
//! 2. A pattern search moves every anchor's position (inside its window), speed and
//!    acceleration while the total drops; a cut's switch lasts its ELST less the time the
//!    previous stretch already spent after its last beam.
//! 3. The result is compared with the constant-speed optimum it started from and the faster of
//!    the two is kept; every move is re-integrated from our own segments.
//!
//! The search is local (a feasible schedule, not a certified optimum). Full-state moves (any
//! acceleration at both ends) come from rsruckig ([`mover`]).

mod assemble;
mod mover;
mod solve;

pub(crate) use assemble::{assemble, from_constant};
pub(crate) use solve::{solve_arc, End, Start};
