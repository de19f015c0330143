//! The tests of the pipeline from the G-code front end to the command line's outputs, and of
//! the records with Z, in one test binary: one link instead of one per file, and their tests
//! run side by side on every core. Each module is a former test file of its own; `common` is
//! the helpers the test binaries share. The long identifications and diagnoses have binaries
//! of the same kind (`tests/identify/`, `tests/diagnose/`); the corpora and the real records,
//! which `.ci/run` runs alone with a variable set, `memory`, which measures its own process,
//! and `layering` and `docs`, which read the sources, keep binaries of their own.

#[path = "../common/mod.rs"]
mod common;

// The G-code front end and the planner.
mod gcode_geometry;
mod parser_props;
mod planner;
mod programs_and_machines;
mod sinumerik;

// The simulated axes and their controllers.
mod controllers;
mod margins;
mod model_extensions;
mod presliding;
mod three_axes;

// Checks, hotspots and sweeps.
mod check;
mod circle_entry;
mod hotspots;
mod sweep;

// Measured records and their files.
mod cut_records;
mod records_with_z;
mod trace_files;
mod trace_text;
mod work_offset;
mod z_circular;
mod z_placement;
mod z_records;
mod z_withdraw;

// The command line and what it writes.
mod cli;
mod cli_records;
mod flags;
mod html_circles;
mod html_report;
mod outputs;
mod plot_circles;
