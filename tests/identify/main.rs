//! The tests of `identify` in one test binary: one link instead of one per file, and their
//! searches run side by side on every core rather than one binary after another, each
//! binary's last search leaving a core idle. Each module is a former test file of its own;
//! `common` is the helpers the test binaries share.
//!
//! The harness starts the tests in the order of their full names (module, then test) on one
//! thread per core, and each search is parallel within itself as well. The longest searches
//! start first, so that the short ones fill in beside them and the binary does not end on
//! one long search alone: `hidden_machines` sorts first, and in it the two longest tests
//! (another controller than the template's, and the loop model without a template) are named
//! to sort before the rest; the searches for a start (`start`) come next by cost and are
//! named to follow.

#[path = "../common/mod.rs"]
mod common;

mod hidden_machines;
mod presliding;
mod ripple;
mod start;
mod z_axis;
mod z_reasons;
