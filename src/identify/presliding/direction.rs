//! Friction near rest by direction, tried once bristles are written: a guideway whose
//! lubrication or preload, or a screw whose nut, differs with the direction of travel
//! starts and reverses differently each way, and one level near rest fits the starts of
//! one direction at the cost of the other's.
//!
//! The written shape's fit is fitted once more with a level near rest each way free
//! (`friction.static_to_coulomb` then holds towards + alone,
//! `friction.static_to_coulomb_negative` towards −), the loop's values and Coulomb
//! friction with them: on the whole record first, and on each half only where that fit
//! explains the record better by a twentieth than one level. The two levels are written only
//! where the halves' fits predict the other halves better than the written shape by the
//! twentieth every larger model must earn, and the record tells the two levels apart
//! (their difference beyond twice its uncertainty); otherwise the shape stays as it was,
//! and its statement says why.

use super::{
    AxisConfig, AxisIdentification, COULOMB_KEY, FADE_MM_PER_MIN, Fit, Knob, Round, get, held_out,
    um_from_m, verdict,
};
use crate::identify::knobs::{STATIC_KEY, STATIC_NEGATIVE_WITH_BRISTLES, STATIC_WITH_BRISTLES};

/// The axis `written` (bristles written, fitted with `knobs`) with a level near rest each
/// way where the record asks for it; as it was otherwise, its statement saying why.
pub(super) fn tried(
    fit: &Fit,
    (template, fold): (&AxisConfig, &[bool]),
    written: (AxisConfig, AxisIdentification),
    knobs: &[Knob],
) -> (AxisConfig, AxisIdentification) {
    let (config, mut id) = written;
    let one_um = id.held_out_identified_um;
    let all = each_way_knobs(knobs);
    let start = match landed(fit, &config, &all) {
        Ok(start) => start,
        Err(why) => {
            say(&mut id, why, one_um);
            return (config, id);
        }
    };
    // The round's fit on the whole record starts where that one landed: a step.
    let found = Round::fit(fit, all, &start, fold).and_then(|round| {
        let each_um = round.held_out_shown_um(fit, fold, id.reached)?;
        Some((round, each_um))
    });
    let Some((round, each_um)) = found else {
        let why = "its halves' fits could not be simulated or did not move".to_string();
        say(&mut id, why, one_um);
        return (config, id);
    };
    if !held_out::kept_over((each_um, false), (one_um, id.held_out_in_sample)) {
        let why = format!(
            "held out {each_um:.3} µm with a level each way against {one_um:.3} µm with one: \
             not better by a twentieth"
        );
        say(&mut id, why, one_um);
        return (config, id);
    }
    let [plus, minus] = match apart(&round) {
        Ok(levels) => levels,
        Err(why) => {
            say(&mut id, why, one_um);
            return (config, id);
        }
    };
    let adopted = super::adopted(fit, (template, fold), &id, (&round, &start), each_um);
    let Some((config_each, mut id_each)) = adopted else {
        let why = "the fit with them cannot be simulated on the whole record".to_string();
        say(&mut id, why, one_um);
        return (config, id);
    };
    if let Some(v) = id_each.presliding.as_mut() {
        v.statement = each_way_words(
            &config_each,
            [plus, minus],
            each_um,
            (Some(one_um), v.held_out_without_um),
        );
        v.held_out_with_um = each_um;
        v.by_direction = true;
        v.held_out_one_level_um = one_um;
    }
    (config_each, id_each)
}

/// `knobs` with the level near rest fitted each way: towards + and towards −.
pub(super) fn each_way_knobs(knobs: &[Knob]) -> Vec<Knob> {
    let mut all: Vec<Knob> = (knobs.iter())
        .filter(|k| k.key != STATIC_KEY)
        .copied()
        .collect();
    all.extend([STATIC_WITH_BRISTLES, STATIC_NEGATIVE_WITH_BRISTLES]);
    all
}

/// `config` with its level near rest towards − set apart, at its level towards +: where a
/// fit with a level each way starts.
pub(super) fn each_way_start(config: &AxisConfig) -> AxisConfig {
    let mut start = config.clone();
    start.friction.static_to_coulomb_negative = Some(start.friction.static_to_coulomb);
    start
}

/// Where the round with a level each way starts: `config`'s fit (a level towards − equal to
/// its level towards +) fitted again on the whole record with `knobs`, where that explains
/// the record better than `config` by the twentieth a larger model must earn — a level each
/// way that fits the samples it was fitted to no better cannot predict those it was not,
/// and the halves' fits are two thirds of a round's cost. Why not otherwise.
pub(super) fn landed(fit: &Fit, config: &AxisConfig, knobs: &[Knob]) -> Result<AxisConfig, String> {
    let start = each_way_start(config);
    let unsimulated = || "its fit on the whole record could not be simulated".to_string();
    let one_m2 = fit.cost(config).ok_or_else(unsimulated)?;
    let whole = fit.run(knobs, &start, &|_| true).ok_or_else(unsimulated)?;
    if !verdict::predicts_better(whole.cost.sqrt(), one_m2.sqrt()) {
        let samples = fit.mask().iter().filter(|m| **m).count().max(1) as f64;
        let rms = |m2: f64| um_from_m((m2 / samples).sqrt());
        return Err(format!(
            "fitted on the whole record it leaves {:.3} µm against {:.3} µm with one level: \
             not better by a twentieth",
            rms(whole.cost),
            rms(one_m2)
        ));
    }
    Ok(Fit::config(knobs, &start, &whole.values))
}

/// The levels near rest towards + and towards − `round`'s fit on the whole record found,
/// each with its uncertainty as the report gives it, where the record tells them apart
/// (their difference beyond twice its uncertainty); why not otherwise.
pub(super) fn apart(round: &Round) -> Result<[(f64, f64); 2], String> {
    let [plus, minus] = levels(round);
    if (minus.0 - plus.0).abs() <= 2.0 * plus.1.hypot(minus.1) {
        return Err(format!(
            "{:.2} ± {:.2} towards + and {:.2} ± {:.2} towards − of Coulomb's do not differ \
             beyond their uncertainty",
            plus.0, plus.1, minus.0, minus.1
        ));
    }
    Ok([plus, minus])
}

/// The statement of bristles written with a level near rest each way (`levels`, each with
/// its uncertainty) on `config`, held out to `each_um` against `one_um` with one level
/// (where scored) and `without_um` without bristles.
pub(super) fn each_way_words(
    config: &AxisConfig,
    [plus, minus]: [(f64, f64); 2],
    each_um: f64,
    (one_um, without_um): (Option<f64>, f64),
) -> String {
    let f = &config.friction;
    let one = match one_um {
        Some(one_um) => format!(" and {one_um:.3} µm with one level near rest"),
        None => String::new(),
    };
    format!(
        "presliding friction: bristles of {} N/µm, damping {:.0} N·s/m, Coulomb's {:.0} N, \
         friction near rest each way: {:.2} ± {:.2} of Coulomb's towards +, {:.2} ± {:.2} \
         towards −, regained over {} mm/s, a model's shape with its levels fitted; held out \
         {each_um:.3} µm against {without_um:.3} µm without bristles{one}",
        f.bristle_stiffness_n_per_um,
        f.bristle_damping_n_s_per_m,
        get(config, COULOMB_KEY),
        plus.0,
        plus.1,
        minus.0,
        minus.1,
        FADE_MM_PER_MIN / 60.0,
    )
}

/// The levels near rest towards + and towards − the round's fit on the whole record found,
/// each with its uncertainty as the report gives it (the round's, or the model's where
/// larger).
fn levels(round: &Round) -> [(f64, f64); 2] {
    [STATIC_KEY, STATIC_NEGATIVE_WITH_BRISTLES.key].map(|key| {
        let j = (round.knobs.iter())
            .position(|k| k.key == key)
            .expect("both levels are fitted");
        let sigma = round.sigma[j].max(round.whole.model_sigma[j]);
        (round.whole.values[j], sigma)
    })
}

/// The written shape's statement, saying why it keeps one level near rest both ways, and
/// its held-out figure `one_um` beside that of a level each way.
fn say(id: &mut AxisIdentification, why: String, one_um: f64) {
    if let Some(v) = id.presliding.as_mut() {
        v.statement = format!("{}; one level near rest both ways ({why})", v.statement);
        v.held_out_one_level_um = one_um;
    }
}
