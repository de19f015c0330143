//! Which of an axis's fits is written, where the fit on every sample stays above the
//! record's noise: each fit's held-out figure is counted on its own samples, so the fit
//! away from the standstills is first run as its file is, on every sample, before its
//! figure is set beside the other's.

use super::AxisIdentification;
use super::solve::{Fit, masked_rms};
use super::{not_reached, presliding, verdict};
use crate::machine::AxisConfig;
use crate::numeric::units::um_from_m;

/// What the axis writes of its fit on every sample (`everywhere`) and its fit away from the
/// standstills ([`best_written`]); where the latter is written, the bristles' verdict of the
/// former is kept and said not to be written with it.
pub(super) fn of(
    fit: &Fit,
    everywhere: (AxisConfig, AxisIdentification),
    while_moving: Option<(AxisConfig, AxisIdentification)>,
    template: &AxisConfig,
) -> (AxisConfig, AxisIdentification) {
    let verdict = everywhere.1.presliding.clone();
    let on_every_sample = |c: &AxisConfig| file_residual_um(fit, c);
    let mut written = best_written(everywhere, while_moving, template, on_every_sample);
    if written.1.moving_only {
        written.1.presliding = verdict;
        let why = "the fit away from the standstills, without them, is written";
        presliding::not_written(&mut written.1.presliding, why);
    }
    written
}

/// What is written for an axis whose fit on every sample stayed above the record's noise:
/// the fit while moving where that reaches it; else whichever of the two predicts its
/// held-out halves best as a share of their following error — written as a model's values
/// where it predicts them better than the template does; else the template's values (NOT
/// IDENTIFIED). No model of a real machine reaches its encoder's noise: a fit is judged by
/// what it predicts. The two shares are counted on different samples (the fit away from
/// the standstills leaves them out), so that fit is a candidate only where, run as its file
/// is on every sample (`on_every_sample`, µm), it leaves no more than the fit on every
/// sample predicts of the halves it did not see (where it has such a figure: a half's fit
/// with a point of its own), by the margin any fit with more in it must
/// earn ([`verdict::predicts_better`]): a file the user runs on the record it came from sees
/// the standstills too, and a fit that is worse on them than another is on data it never
/// saw is not the model to predict other programs with.
fn best_written(
    everywhere: (AxisConfig, AxisIdentification),
    while_moving: Option<(AxisConfig, AxisIdentification)>,
    template: &AxisConfig,
    on_every_sample: impl Fn(&AxisConfig) -> Option<f64>,
) -> (AxisConfig, AxisIdentification) {
    if let Some(m) = &while_moving
        && m.1.reached
    {
        return m.clone();
    }
    // Where neither half of the fit on every sample found a point of its own, its figure is
    // its own residual on the samples it was fitted to — no held-out figure to hold another
    // fit's file to.
    let everywhere_um = everywhere.1.held_out_identified_um;
    let held_out = !everywhere.1.held_out_in_sample;
    let while_moving = while_moving.filter(|m| {
        let moving_um = on_every_sample(&m.0);
        !held_out || moving_um.is_some_and(|m| !verdict::predicts_better(everywhere_um, m))
    });
    let best = [Some(everywhere.clone()), while_moving]
        .into_iter()
        .flatten()
        .filter(|c| c.1.better_than_template)
        .min_by(|a, b| a.1.held_out_share.total_cmp(&b.1.held_out_share));
    match best {
        Some(c) => as_model(c),
        None => not_reached(everywhere, template),
    }
}

/// What `config` leaves on every sample the fit compares (µm RMS), run as its file is: no
/// force held at the record's start, a state of the record the file cannot carry.
fn file_residual_um(fit: &Fit, config: &AxisConfig) -> Option<f64> {
    let mut file = config.clone();
    file.held_at_start_n = 0.0;
    Some(um_from_m(masked_rms(&fit.residual(&file)?, fit.mask())))
}

/// A fit above the noise that predicts better than the template: written, every value a
/// model's (none reads as a measurement of the machine).
fn as_model(
    (config, mut identified): (AxisConfig, AxisIdentification),
) -> (AxisConfig, AxisIdentification) {
    identified.reached = false;
    for v in &mut identified.values {
        v.measured = false;
    }
    (config, identified)
}
