//! The tests of `diagnose` in one test binary — the hidden effects of the catalogue, the
//! records of a foreign interpolator and of the independent reference, records as users bring
//! them, odd records, and the force ripple — one link instead of one per file, and their
//! diagnoses run side by side on every core rather than one binary after another. Each module
//! is a former test file of its own; `common` is the helpers the test binaries share.

#[path = "../common/mod.rs"]
mod common;

mod circular_reference;
mod external_circle_window;
mod force_ripple;
mod foreign_commands;
mod hidden_effects;
mod odd_records;
mod records;
mod reference_records;
mod ripple;
mod tables;
