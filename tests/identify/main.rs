//! The tests of `identify` in one test binary: one link instead of one per file, and their
//! searches run side by side on every core rather than one binary after another, each
//! binary's last search leaving a core idle. Each module is a former test file of its own;
//! `common` is the helpers the test binaries share.
//!
//! The harness starts the tests in the order of their full names (module, then test) on one
//! thread per core, and each search is parallel within itself as well. The longest searches
//! start first, so that the short ones fill in beside them and the binary does not end on
//! one long search alone. `hard_searches` sorts first: its controller tuned far off its design
//! was the longest search when it started late (87 s of a binary's 286 s, load 2–4), the
//! values that trade the fourth (53 s); `hidden_machines` next, where the second and third
//! longest (63 s each: another controller than the template's, and the loop model without a
//! template) are named to sort before the rest; then `leads`, two searches of the loop
//! model's orders, one of them twice (a lead's ripple refitted). In this order (before
//! `leads`) the binary took 254 s, on the same 316 CPU-s. A module or test renamed can move
//! a long search to the end.

#[path = "../common/mod.rs"]
mod common;

mod hard_searches;
mod held_start;
mod hidden_machines;
mod lead_lag_family;
mod leads;
mod limits;
mod presliding;
mod record_rate;
mod ripple;
mod z_axis;
mod z_reasons;
