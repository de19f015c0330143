//! Presliding friction (docs/model.md §1.9) tried where the template names no bristles: a
//! table that yields by micrometres before it slides, and whose friction near rest may lie
//! below Coulomb's, shapes every start and stop of a record.
//!
//! The bristles are not searched value by value: their stiffness, the level near rest and
//! the speed that level fades over trade with each other and with Coulomb friction through
//! the few starts a record holds. A small set of shapes is tried instead ([`SHAPES`]), and
//! with each the loop's values and Coulomb friction are fitted again (a round: the whole
//! record and each half), from the axis's fit without bristles — fitted without them, those
//! values bent to the starts (on the real table X's Coulomb friction went to zero, leaving
//! bristles nothing to bend: tried on top of that fit they found nothing). Coulomb friction
//! starts from the best of a short scan, since the fit without bristles may hold none.
//! The shape that scan leaves best is fitted on the whole record first, and where even its
//! fit cannot be written the others are not fitted; a shape whose whole fit holds no
//! Coulomb force the record tells from none (bristles bent by no friction carry no force),
//! or fits clearly worse than another's, goes no further.
//!
//! Each half picks the shape that fits its own samples best and is scored on the other
//! half's, like every value `identify` writes; the record's fit takes the shape that fits it
//! best. The bristles are written only where those held-out figures beat the fit without
//! them by the twentieth every larger model must earn, and then as a model's values (a
//! shape from a grid, not a measurement). Otherwise the axis says "not determined" and why.

use rayon::prelude::*;
use serde::Serialize;

use super::knobs::{self, COULOMB_KEY, Knob, STATIC_KEY, get, set_all};
use super::result::{AxisIdentification, IdentifiedValue};
use super::round::Round;
use super::solve::Fitted;
use super::solve::{Fit, masked_rms};
use super::{held_out, verdict, within_noise};
use crate::machine::AxisConfig;
use crate::numeric::units::{GRAVITY_M_PER_S2, um_from_m};
use crate::sim::AxisModel;

mod direction;
mod gates;

use gates::{Bars, Refusal, WholeFigures, carried, coulomb_held, first_stops};

/// The shapes tried: bristle stiffness (N/µm) and friction near rest over Coulomb's. The
/// separate model of the real table found a level near rest about a third below Coulomb's;
/// bristles of 50 N/µm give presliding ranges of a few µm at Coulomb forces of 100-300 N,
/// the magnitude ball-screw tables show (a few µm before gross sliding). A softer and a
/// stiffer spring at 0.7, and 50 N/µm at Coulomb's level, span it.
const SHAPES: [Shape; 4] = [
    Shape::new(50.0, 0.7),
    Shape::new(50.0, 1.0),
    Shape::new(15.0, 0.7),
    Shape::new(150.0, 0.7),
];
/// The speed over which friction near rest is regained (mm/min): 10 mm/s, where the
/// separate model of the real table found 9 and 13 mm/s on its halves.
const FADE_MM_PER_MIN: f64 = 600.0;
/// Bristle damping as a share of the critical damping of the bristle spring with the moving
/// mass: a tenth leaves the presliding oscillation visible for a few periods, as measured
/// presliding responses show, and it is the ratio of the 20,000 N·s/m measured with on the
/// real table at 50 N/µm on X's 172 kg.
const DAMPING_SHARE: f64 = 0.1;
/// The Coulomb forces tried as the fit's start, as shares of the moving mass's weight
/// (besides the fit's own): ball-screw guideways run at some hundredths to a few tenths.
const COULOMB_SCAN_OF_WEIGHT: [f64; 3] = [0.03, 0.1, 0.3];

/// What the record says of presliding friction on one axis whose template names none.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PreslidingVerdict {
    /// Whether bristles are written to the machine file (as a model's values).
    pub written: bool,
    /// One line: "presliding friction: …", "not determined (<reason>)" where not written.
    pub statement: String,
    /// The held-out RMS (µm) of the fit without bristles …
    pub held_out_without_um: f64,
    /// … and with the shape each half chose (NaN where not tried); with a level near rest
    /// each way where those are written.
    pub held_out_with_um: f64,
    /// Whether friction near rest is written each way (towards + and towards −).
    pub by_direction: bool,
    /// The held-out RMS (µm) of the written shape with one level near rest both ways, where
    /// a level each way was tried (NaN otherwise).
    pub held_out_one_level_um: f64,
}

/// One shape of bristles.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Shape {
    stiffness_n_per_um: f64,
    level: f64,
    /// Whether the level near rest is fitted each way, starting from `level` both ways.
    each_way: bool,
}

impl Shape {
    const fn new(stiffness_n_per_um: f64, level: f64) -> Shape {
        Shape {
            stiffness_n_per_um,
            level,
            each_way: false,
        }
    }

    /// The same bristles with the level near rest fitted towards + and towards −.
    fn each_way(self) -> Shape {
        Shape {
            each_way: true,
            ..self
        }
    }

    /// The shape as a reason names it.
    fn describe(self) -> String {
        let each_way = if self.each_way {
            " fitted each way"
        } else {
            ""
        };
        format!(
            "bristles of {} N/µm, friction near rest {} of Coulomb's{each_way}",
            self.stiffness_n_per_um, self.level
        )
    }

    /// What a fit with this shape fits: `knobs`, and with a level each way both levels.
    fn knobs(self, knobs: &[Knob]) -> Vec<Knob> {
        if self.each_way {
            direction::each_way_knobs(knobs)
        } else {
            knobs.to_vec()
        }
    }

    /// `config` with these bristles and Coulomb friction `coulomb_n`.
    fn on(self, config: &AxisConfig, coulomb_n: f64) -> AxisConfig {
        let mut c = config.clone();
        set_all(&mut c, &[COULOMB_KEY], &[coulomb_n]);
        let moving_kg = AxisModel::from_config(config)
            .mass_at_table_kg()
            .max(config.drive.table_mass_kg);
        let sigma0 = self.stiffness_n_per_um * 1e6;
        let f = &mut c.friction;
        f.bristle_stiffness_n_per_um = self.stiffness_n_per_um;
        f.bristle_damping_n_s_per_m = DAMPING_SHARE * 2.0 * (sigma0 * moving_kg).sqrt();
        f.static_to_coulomb = self.level;
        f.stribeck_level_n = 0.0;
        f.stribeck_velocity_mm_per_min = FADE_MM_PER_MIN;
        c
    }
}

/// A shape's round: the loop's values and Coulomb friction fitted with it in place.
struct Tried {
    shape: Shape,
    round: Round,
    base: AxisConfig,
}

/// The fit `hybrid` (without bristles, of `knobs_all`' knobs that it fitted) kept, or
/// replaced by the fit with bristles where the held-out halves keep them; its verdict set
/// either way. Where the template names bristles, `hybrid` as it is (no verdict).
/// `moving_share` gives the held-out share of the fit away from the standstills, asked for
/// only where a shape's fit on every sample stays above the record's noise (the first
/// shape's, then all of them): a shape whose fit does not come below it even on the samples
/// it was fitted to cannot be written.
pub(super) fn tried(
    fit: &Fit,
    template: &AxisConfig,
    hybrid: (AxisConfig, AxisIdentification),
    knobs_all: &[Knob],
    moving_share: &dyn Fn() -> Option<f64>,
) -> (AxisConfig, AxisIdentification) {
    if template.friction.has_presliding() {
        return hybrid;
    }
    let (config, mut id) = hybrid;
    let without_um = id.held_out_identified_um;
    let not = |reason: &str, with_um: f64| PreslidingVerdict {
        written: false,
        statement: format!("presliding friction: not determined ({reason})"),
        held_out_without_um: without_um,
        held_out_with_um: with_um,
        by_direction: false,
        held_out_one_level_um: f64::NAN,
    };
    let Some(knobs) = refitted(&id, knobs_all) else {
        let reason = "the model fitted has no Coulomb friction for bristles to carry";
        id.presliding = Some(not(reason, f64::NAN));
        return (config, id);
    };
    let fold = fit.ctx().halves(fit.offset());
    let judge = |rounds: &[Tried]| judged(fit, (template, &fold), &id, rounds);
    let outcome = rounds(fit, &config, &knobs, &fold, (&id, moving_share))
        .map_err(|reason| Refused::because(reason, f64::NAN))
        .and_then(|rounds| {
            judge(&rounds).or_else(|refused| match refused.retry {
                // One level near rest, on its halves, does not predict better: the shape
                // they judged, with a level each way.
                Some(best) => each_way_round(fit, &rounds[best], &fold)
                    .map_err(|why| Refused::because(why, f64::NAN))
                    .and_then(|each| judge(&[each]))
                    .map_err(|each| refused.beside(each)),
                None => Err(refused),
            })
        });
    match outcome {
        Ok(found) => found,
        Err(refused) => {
            id.presliding = Some(not(&refused.reason, refused.with_um));
            (config, id)
        }
    }
}

/// Why bristles are not written, with the held-out figure with them where scored (NaN
/// otherwise); `retry` names the round (by index) whose one level near rest did not predict
/// better by a twentieth, which may still with a level each way.
struct Refused {
    reason: String,
    with_um: f64,
    retry: Option<usize>,
}

impl Refused {
    fn because(reason: impl Into<String>, with_um: f64) -> Refused {
        Refused {
            reason: reason.into(),
            with_um,
            retry: None,
        }
    }

    /// This refusal with that of the same shape tried again with a level each way.
    fn beside(self, each: Refused) -> Refused {
        Refused {
            reason: format!(
                "{}; with friction near rest fitted each way: {}",
                self.reason, each.reason
            ),
            with_um: self.with_um,
            retry: None,
        }
    }
}

/// The axis with the bristles of `rounds` written, where their held-out halves beat the fit
/// without them (`id`) by a twentieth, the fit holds a Coulomb force, and levels near rest
/// fitted each way differ beyond their uncertainty; why not otherwise.
fn judged(
    fit: &Fit,
    (template, fold): (&AxisConfig, &[bool]),
    id: &AxisIdentification,
    rounds: &[Tried],
) -> Result<(AxisConfig, AxisIdentification), Refused> {
    let without_um = id.held_out_identified_um;
    let Some(scored) = scored(fit, rounds, fold, id.reached) else {
        let reason = "the halves' fits of the shapes chosen, or of the one that fits the whole \
                      record best, could not be simulated or did not move from its whole fit's";
        return Err(Refused::because(reason, f64::NAN));
    };
    let with_um = scored.figure_um();
    let best = &rounds[scored.best];
    if !held_out::kept_over((with_um, false), (without_um, id.held_out_in_sample)) {
        let reason = format!(
            "held out {with_um:.3} µm with them against {without_um:.3} µm without: not \
             better by a twentieth"
        );
        let retry = (!best.shape.each_way).then_some(scored.best);
        return Err(Refused {
            retry,
            ..Refused::because(reason, with_um)
        });
    }
    if !holds_coulomb(
        &best.round.knobs,
        &best.round.whole.values,
        &best.round.sigma,
    ) {
        // The round's fit on the whole record may move Coulomb friction again from where
        // the shape's first fit held it: bristles bent by no friction carry no force.
        let reason = "the fit with them holds no Coulomb force above its uncertainty, and \
                      bristles bent by no friction carry no force";
        return Err(Refused::because(reason, with_um));
    }
    let levels = if best.shape.each_way {
        let apart = direction::apart(&best.round);
        let why = |why| format!("{}: {why}", best.shape.describe());
        Some(apart.map_err(|w| Refused::because(why(w), with_um))?)
    } else {
        None
    };
    written(fit, (template, fold), id, (best, levels), &scored).ok_or_else(|| {
        let reason = "the axis cannot be simulated on the whole record with them";
        Refused::because(reason, with_um)
    })
}

/// `best`'s shape with its level near rest fitted each way: its fit on the whole record from
/// where `best`'s landed, where that fits the record better by a twentieth, and its halves.
fn each_way_round(fit: &Fit, best: &Tried, fold: &[bool]) -> Result<Tried, String> {
    let knobs = direction::each_way_knobs(&best.round.knobs);
    let start = direction::landed(fit, &best.round.config(&best.round.whole), &knobs)?;
    let round = Round::fit(fit, knobs, &start, fold)
        .ok_or_else(|| "its halves could not be fitted".to_string())?;
    Ok(Tried {
        shape: best.shape.each_way(),
        round,
        base: start,
    })
}

/// The rounds of the shapes worth scoring on the halves. Each shape's fit on the whole
/// record comes first, the shape ranked best at the loop's values without bristles before
/// the others, which are not fitted where its fit stays above the noise and does not come
/// below the held-out share of the fit away from the standstills (`moving_share`): that fit
/// is written otherwise, whatever the halves make of the bristles. Then only the shapes
/// whose fit there (a) lies below the fit's without bristles (`config`) by the twentieth a
/// larger model must earn — a shape that does not fit the samples it was fitted to better
/// cannot predict those it was not (the halves' fits are two thirds of a round's cost) —,
/// (b) holds Coulomb friction above its uncertainty, (c) where none reaches the noise, lies
/// below that held-out share, and (d) is not beaten by another shape's fit by a twentieth.
/// Where none is (or the first stopped the others), the first-ranked shape is fitted once
/// more with its level near rest free each way, and goes on alone where that fit clears
/// (a) to (c). Why none is, where none is.
fn rounds(
    fit: &Fit,
    config: &AxisConfig,
    knobs: &[Knob],
    fold: &[bool],
    (id, moving_share): (&AxisIdentification, &dyn Fn() -> Option<f64>),
) -> Result<Vec<Tried>, String> {
    let unsimulated = || "the fit without bristles cannot be simulated".to_string();
    let without_m2 = fit.cost(config).ok_or_else(unsimulated)?;
    let samples = fit.mask().iter().filter(|m| **m).count().max(1) as f64;
    let bars = Bars {
        without_m2,
        noise_um: um_from_m(fit.ctx().noise_sigma),
        following_um: id.following_error_rms_um,
    };
    let figures = |w: &Whole| WholeFigures::of(&w.shape.knobs(knobs), &w.fitted, samples);
    let gate = |first: &Whole| match first_stops(figures(first).rms_um, &bars, moving_share) {
        Some(share) => Err(Refusal::FirstBelowShare(first.shape, share).reason()),
        None => Ok(()),
    };
    let carried_of = |wholes: Vec<Whole>| {
        let all: Vec<WholeFigures> = wholes.iter().map(figures).collect();
        match carried(&all, &bars, moving_share) {
            Ok(kept) => Ok(keep_only(wholes, &kept)),
            Err(refusal) => Err((refusal.reason(), wholes.into_iter().next().map(Box::new))),
        }
    };
    let wholes = match gated_wholes(fit, knobs, config, &gate).and_then(carried_of) {
        Ok(wholes) => wholes,
        Err((reason, first)) => {
            // One level near rest cannot be written: the first-ranked shape each way.
            let each = first.and_then(|first| first_each_way(fit, knobs, &first));
            let each = each.filter(|w| carried(&[figures(w)], &bars, moving_share).is_ok());
            let nor = || format!("{reason}; nor with its friction near rest fitted each way");
            vec![each.ok_or_else(nor)?]
        }
    };
    let rounds: Vec<Tried> = wholes
        .into_par_iter()
        .filter_map(|w| {
            // The round's fit on the whole record starts where this one landed: a step.
            let knobs = w.shape.knobs(knobs);
            let landed = Fit::config(&knobs, &w.base, &w.fitted.values);
            let round = Round::fit(fit, knobs, &landed, fold)?;
            Some(Tried {
                shape: w.shape,
                round,
                base: landed,
            })
        })
        .collect();
    if rounds.is_empty() {
        return Err("no shape's halves could be fitted".to_string());
    }
    Ok(rounds)
}

/// `config`, whose bristles the fit on the whole record chose, with the shape of [`SHAPES`]
/// that explains the samples `own` allows best at its other values (its Coulomb force as it
/// is): where a half's fit starts from a whole fit with bristles written, the shape that
/// half's own samples choose, as each half chose its own here; levels near rest fitted each
/// way stay the fit's. None where none can be simulated.
pub(super) fn own_shape(
    fit: &Fit,
    config: &AxisConfig,
    own: &(dyn Fn(usize) -> bool + Sync),
) -> Option<AxisConfig> {
    let coulomb_n = get(config, COULOMB_KEY);
    SHAPES
        .par_iter()
        .filter_map(|shape| {
            let mut c = shape.on(config, coulomb_n);
            if config.friction.static_to_coulomb_negative.is_some() {
                // Levels near rest fitted each way are the fit's, not the grid's.
                c.friction.static_to_coulomb = config.friction.static_to_coulomb;
            }
            let r = fit.residual(&c)?;
            let ss: f64 = (0..r.len()).filter(|&i| own(i)).map(|i| r[i] * r[i]).sum();
            Some((ss, c))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// Whether `values` (of `knobs`) put Coulomb friction above its uncertainty in `sigma`.
fn holds_coulomb(knobs: &[Knob], values: &[f64], sigma: &[f64]) -> bool {
    knobs
        .iter()
        .position(|k| k.key == COULOMB_KEY)
        .is_some_and(|j| coulomb_held(values[j], sigma[j]))
}

/// A shape's fit on the whole record, from `base` (the shape at its Coulomb start).
struct Whole {
    shape: Shape,
    base: AxisConfig,
    fitted: Fitted,
}

impl Whole {
    /// `shape`'s fit on the whole record from `base`, of `knobs` and the shape's own.
    fn of(fit: &Fit, knobs: &[Knob], shape: Shape, base: AxisConfig) -> Option<Whole> {
        let fitted = fit.run(&shape.knobs(knobs), &base, &|_| true)?;
        Some(Whole {
            shape,
            base,
            fitted,
        })
    }
}

/// Each shape's fit on the whole record (the loop's values and Coulomb friction fitted
/// again with it in place), the shape that explains the record best at the fit's loop
/// values (its Coulomb force scanned) fitted first: where `gate` finds that even its fit
/// cannot be written, the others are not fitted, and `gate`'s reason is returned with that
/// fit. A whole fit costs about a third of a round; an axis the bristles do not help pays
/// one instead of every shape's.
fn gated_wholes(
    fit: &Fit,
    knobs: &[Knob],
    config: &AxisConfig,
    gate: &dyn Fn(&Whole) -> Result<(), String>,
) -> Result<Vec<Whole>, (String, Option<Box<Whole>>)> {
    let mut ranked: Vec<(f64, Shape, AxisConfig)> = SHAPES
        .par_iter()
        .filter_map(|&shape| {
            let start = coulomb_start(fit, shape, config)?;
            Some((start.cost_m2, shape, shape.on(config, start.coulomb_n)))
        })
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut rest = ranked.into_iter();
    let first = rest
        .next()
        .and_then(|(_, shape, base)| Whole::of(fit, knobs, shape, base));
    if let Some(f) = &first
        && let Err(reason) = gate(f)
    {
        return Err((reason, first.map(Box::new)));
    }
    let others: Vec<Whole> = rest
        .collect::<Vec<_>>()
        .into_par_iter()
        .filter_map(|(_, shape, base)| Whole::of(fit, knobs, shape, base))
        .collect();
    Ok(first.into_iter().chain(others).collect())
}

/// `wholes` of the indices `kept`, in order.
fn keep_only(wholes: Vec<Whole>, kept: &[usize]) -> Vec<Whole> {
    (wholes.into_iter().enumerate())
        .filter(|(i, _)| kept.contains(i))
        .map(|(_, w)| w)
        .collect()
}

/// The first-ranked shape's fit (`first`, with which one level near rest cannot be written)
/// fitted again from where it landed with its level near rest free each way. A guideway or
/// nut whose friction near rest differs by direction lets one level fit the stops of one
/// direction only, at the other's cost: on the real table Y overruns its stop moving
/// towards + by 106 µm and its stop moving towards − by 42 µm, where one level gives both
/// about 60.
fn first_each_way(fit: &Fit, knobs: &[Knob], first: &Whole) -> Option<Whole> {
    let landed = Fit::config(knobs, &first.base, &first.fitted.values);
    let base = direction::each_way_start(&landed);
    Whole::of(fit, knobs, first.shape.each_way(), base)
}

/// The knobs of `knobs_all` the fit `id` fitted in its last round (those with an
/// uncertainty), but the level near rest, which each shape sets; and Coulomb friction,
/// whatever the fit without bristles made of it (put back to the template's where the
/// record did not determine it without them). None where the model has no Coulomb friction.
fn refitted(id: &AxisIdentification, knobs_all: &[Knob]) -> Option<Vec<Knob>> {
    let mut knobs: Vec<Knob> = Vec::new();
    for k in knobs_all {
        let fitted = id
            .values
            .iter()
            .any(|v| v.key == k.key && (v.uncertainty.is_finite() || k.key == COULOMB_KEY));
        if fitted && k.key != STATIC_KEY && !knobs.iter().any(|q| q.key == k.key) {
            knobs.push(*k);
        }
    }
    knobs.iter().any(|k| k.key == COULOMB_KEY).then_some(knobs)
}

/// Where a shape's fit starts: a Coulomb force and what the record makes of it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CoulombStart {
    /// The residual's sum of squares (m²) over the samples the fit compares, with the shape
    /// at this force and the loop's values of the fit without bristles.
    cost_m2: f64,
    coulomb_n: f64,
}

/// The Coulomb force a shape's fit starts from: of the fit's own and the scan's, the one
/// that explains the record best with the shape; none where none can be simulated.
fn coulomb_start(fit: &Fit, shape: Shape, config: &AxisConfig) -> Option<CoulombStart> {
    let weight_n = config.drive.table_mass_kg * GRAVITY_M_PER_S2;
    std::iter::once(get(config, COULOMB_KEY))
        .chain(COULOMB_SCAN_OF_WEIGHT.iter().map(|s| s * weight_n))
        .filter_map(|coulomb_n| {
            let cost_m2 = fit.cost(&shape.on(config, coulomb_n))?;
            Some(CoulombStart { cost_m2, coulomb_n })
        })
        .min_by(|a, b| a.cost_m2.total_cmp(&b.cost_m2))
}

/// The held-out figures of the shapes tried.
struct Scored {
    /// The RMS (µm) of the halves' fits with bristles on the other halves' samples: each
    /// half takes the shape whose fit on its own samples is best.
    chosen_um: f64,
    /// Whether the two halves chose the same shape.
    agree: bool,
    /// The shape whose fit on the whole record is best (by index): the one written …
    best: usize,
    /// … and its own held-out figure (µm): its halves' fits on the other halves' samples.
    best_um: f64,
}

impl Scored {
    /// The figure the bristles are judged by and reported with: the worse of the halves'
    /// choice and the written shape's own — where the halves chose another shape than the
    /// whole record did, the written one has not shown its own figure otherwise.
    fn figure_um(&self) -> f64 {
        self.chosen_um.max(self.best_um)
    }
}

/// The held-out figures of `rounds`. Above the noise (`reached` false) only a half whose
/// fit found a point of its own counts, as for every held-out figure
/// ([`Round::held_out_rms_own`]). None where no half counts for the halves' choice or for
/// the shape written, or they cannot be simulated.
fn scored(fit: &Fit, rounds: &[Tried], fold: &[bool], reached: bool) -> Option<Scored> {
    let mask = fit.mask();
    let chosen: Vec<Option<(usize, (f64, usize))>> = [0usize, 1]
        .into_par_iter()
        .map(|h| {
            let (i, t) = rounds.iter().enumerate().min_by(|a, b| {
                a.1.round.halves[h]
                    .cost
                    .total_cmp(&b.1.round.halves[h].cost)
            })?;
            if !reached && !t.round.halves[h].own_point {
                return None;
            }
            Some((i, t.round.half_held_out(fit, fold, mask, h)?))
        })
        .collect();
    let (ss, n) = chosen
        .iter()
        .flatten()
        .fold((0.0, 0usize), |(s, m), (_, (a, b))| (s + a, m + b));
    if n == 0 {
        return None;
    }
    let best = (0..rounds.len()).min_by(|&a, &b| {
        let cost = |i: usize| rounds[i].round.whole.cost;
        cost(a).total_cmp(&cost(b))
    })?;
    // Above the noise, a written shape whose halves both stayed at its whole fit's values
    // has no held-out figure of its own: the shape is not written.
    let best_um = rounds[best].round.held_out_shown_um(fit, fold, reached)?;
    Some(Scored {
        chosen_um: um_from_m((ss / n as f64).sqrt()),
        agree: matches!(chosen.as_slice(), [Some((a, _)), Some((b, _))] if a == b),
        best,
        best_um,
    })
}

/// The axis with bristles written: `best`'s fit on the whole record, its values replacing
/// those fitted again and the bristles' added, judged on the held-out figure `with_um`; its
/// levels near rest each way (`levels`) where the shape fitted them, tried each way after
/// otherwise.
fn written(
    fit: &Fit,
    (template, fold): (&AxisConfig, &[bool]),
    id: &AxisIdentification,
    (best, levels): (&Tried, Option<[(f64, f64); 2]>),
    scored: &Scored,
) -> Option<(AxisConfig, AxisIdentification)> {
    let with_um = scored.figure_um();
    let without_um = id.held_out_identified_um;
    let (config, mut id) = adopted(
        fit,
        (template, fold),
        id,
        (&best.round, &best.base),
        with_um,
    )?;
    let f = &config.friction;
    let statement = match levels {
        Some(levels) => direction::each_way_words(&config, levels, with_um, (None, without_um)),
        None => format!(
            "presliding friction: bristles of {} N/µm, damping {:.0} N·s/m, friction near rest \
             {} of Coulomb's ({:.0} N) regained over {} mm/s, a model's shape ({}); held out \
             {with_um:.3} µm against {without_um:.3} µm without",
            best.shape.stiffness_n_per_um,
            f.bristle_damping_n_s_per_m,
            best.shape.level,
            get(&config, COULOMB_KEY),
            FADE_MM_PER_MIN / 60.0,
            chosen_words(scored),
        ),
    };
    id.presliding = Some(PreslidingVerdict {
        written: true,
        statement,
        held_out_without_um: without_um,
        held_out_with_um: with_um,
        by_direction: levels.is_some(),
        held_out_one_level_um: f64::NAN,
    });
    if levels.is_some() {
        return Some((config, id));
    }
    Some(direction::tried(
        fit,
        (template, fold),
        (config, id),
        &best.round.knobs,
    ))
}

/// The axis as `round` (fitted about `base`) has it on the whole record: its values replacing
/// those `id` holds and the bristles' added where the round did not fit them, judged on the
/// held-out figure `with_um`.
fn adopted(
    fit: &Fit,
    (template, fold): (&AxisConfig, &[bool]),
    id: &AxisIdentification,
    (round, base): (&Round, &AxisConfig),
    with_um: f64,
) -> Option<(AxisConfig, AxisIdentification)> {
    let config = round.config(&round.whole);
    let residual = fit.residual(&config)?;
    let mask = fit.mask();
    let mut id = id.clone();
    for v in super::fitted_values(&round.knobs, round, &config, template) {
        match id.values.iter_mut().find(|w| w.key == v.key) {
            Some(w) => *w = super::refitted_value(w, v, &round.knobs),
            None => id.values.push(v),
        }
    }
    let fitted = |key: &str| round.knobs.iter().any(|k| k.key == key);
    for (key, unit) in BRISTLE_KEYS.into_iter().filter(|(key, _)| !fitted(key)) {
        let value = model_value(key, unit, template, &config);
        match id.values.iter_mut().find(|w| w.key == key) {
            Some(w) => *w = value,
            None => id.values.push(value),
        }
    }
    let (ctx, axis, offset) = (fit.ctx(), fit.axis(), fit.offset());
    let rms_um = um_from_m(masked_rms(&residual, mask));
    id.reached = within_noise(rms_um, um_from_m(ctx.noise_sigma));
    id.rms_identified_um = rms_um;
    id.held_out_identified_um = with_um;
    id.held_out_in_sample = false;
    id.held_out_share = with_um / id.following_error_rms_um;
    id.better_than_template = verdict::predicts_better(with_um, id.held_out_template_um);
    id.largest_at = verdict::largest_at(ctx, axis, offset, &residual, mask);
    id.gain_per_inertia = super::gain_per_inertia(round, base);
    if id.while_moving.is_some() {
        let template_residual = fit.residual(template)?;
        id.while_moving = verdict::while_moving(fit, round, fold, &template_residual);
    }
    Some((config, id))
}

/// Which shapes the halves chose, and the figure the written one is given.
fn chosen_words(scored: &Scored) -> String {
    if scored.agree && scored.chosen_um == scored.best_um {
        return "both halves chose it".to_string();
    }
    let (chosen, own) = (scored.chosen_um, scored.best_um);
    let which = if scored.agree {
        "both halves chose another"
    } else {
        "the halves chose different shapes"
    };
    format!(
        "{which}: held out {chosen:.3} µm with the halves' choice, {own:.3} µm with its own \
         halves; the worse is given"
    )
}

/// The keys the bristles are written under, with their units.
const BRISTLE_KEYS: [(&str, &str); 4] = [
    ("friction.bristle_stiffness_n_per_um", "N/µm"),
    ("friction.bristle_damping_n_s_per_m", "N·s/m"),
    (STATIC_KEY, ""),
    ("friction.stribeck_velocity_mm_per_min", "mm/min"),
];

/// A bristle value written as a model's: picked from a grid, which spans threefold steps and
/// more about it, so its uncertainty is stated as its own size (every value written loose
/// carries a finite one).
fn model_value(
    key: &'static str,
    unit: &'static str,
    template: &AxisConfig,
    config: &AxisConfig,
) -> IdentifiedValue {
    IdentifiedValue {
        key,
        unit,
        template: get(template, key),
        value: get(config, key),
        uncertainty: get(config, key).abs(),
        determined: false,
        measured: false,
        traded_with: None,
        loose: true,
        complex_pair: None,
    }
}

/// An axis whose fit without bristles reaches the record's noise: bristles are not tried
/// (nothing is left for them to explain), said so where the template names none.
pub(super) fn at_noise(
    found: (AxisConfig, AxisIdentification),
    template: &AxisConfig,
) -> (AxisConfig, AxisIdentification) {
    not_tried(
        found,
        template,
        "the fit without bristles reaches the record's noise",
    )
}

/// An axis whose fit without bristles is kept as it is, bristles not tried (`why`), said so
/// where the template names none.
pub(super) fn not_tried(
    (config, mut id): (AxisConfig, AxisIdentification),
    template: &AxisConfig,
    why: &str,
) -> (AxisConfig, AxisIdentification) {
    if !template.friction.has_presliding() {
        id.presliding = Some(PreslidingVerdict {
            written: false,
            statement: format!("presliding friction: not determined (not tried: {why})"),
            held_out_without_um: id.held_out_identified_um,
            held_out_with_um: f64::NAN,
            by_direction: false,
            held_out_one_level_um: f64::NAN,
        });
    }
    (config, id)
}

/// Where bristles are no longer written (the template's values stay, or another fit is
/// written): a statement that says they are is turned into why not.
pub(super) fn not_written(verdict: &mut Option<PreslidingVerdict>, why: &str) {
    if let Some(v) = verdict.as_mut().filter(|v| v.written) {
        v.written = false;
        v.by_direction = false;
        v.statement = format!("presliding friction: not determined ({why})");
    }
}

/// The candidate knobs a fit may have fitted: the template's, its nonlinear parts and the
/// loop models'.
pub(super) fn candidate_knobs(template: &AxisConfig, nonlinear: &[Knob]) -> Vec<Knob> {
    let mut all = knobs::for_axis(template);
    all.extend_from_slice(nonlinear);
    all.extend(super::loop_model::orders(template).concat());
    all
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn a_shape_sets_its_bristles_damped_at_a_tenth_of_critical_on_the_coulomb_force_given() {
        let x = MachineConfig::preset("small-table").unwrap().x;
        let c = Shape::new(50.0, 0.7).on(&x, 88.3);
        let f = &c.friction;
        // The small table's X moves its 30 kg table and, through 10 mm a turn, the rotor's
        // and screw's 2.05e-4 kg·m²: 30 + 2.05e-4 / (0.01 / 2π)² = 110.9 kg. A tenth of the
        // critical damping 2·√(σ0·m) of 50 N/µm on it.
        let r = 0.01 / std::f64::consts::TAU;
        let moving_kg = 30.0 + 2.05e-4 / (r * r);
        let expected = 0.1 * 2.0 * (50e6 * moving_kg).sqrt();
        assert!(
            (f.bristle_damping_n_s_per_m - expected).abs() < 1e-3 * expected,
            "{} against {expected}",
            f.bristle_damping_n_s_per_m
        );
        assert_eq!(f.bristle_stiffness_n_per_um, 50.0);
        assert_eq!(f.static_to_coulomb, 0.7);
        assert_eq!(f.stribeck_velocity_mm_per_min, 600.0);
        assert!((get(&c, COULOMB_KEY) - 88.3).abs() < 1e-9);
    }

    #[test]
    fn a_shape_fitted_each_way_starts_both_levels_at_its_own_and_frees_both() {
        let x = MachineConfig::preset("small-table").unwrap().x;
        let shape = Shape::new(150.0, 0.7).each_way();
        let one = shape.on(&x, 88.3);
        assert_eq!(one.friction.static_to_coulomb_negative, None);
        // Both directions start at the shape's level: the fit, not the grid, parts them.
        let f = direction::each_way_start(&one).friction;
        assert_eq!(f.static_to_coulomb, 0.7);
        assert_eq!(f.static_to_coulomb_negative, Some(0.7));
        // The knobs of the fit without bristles (no level near rest among them, which each
        // shape sets) and both levels, towards + and towards −.
        let knobs = knobs::for_axis(&x);
        let each: Vec<&str> = shape.knobs(&knobs).iter().map(|k| k.key).collect();
        let plain: Vec<&str> = knobs.iter().map(|k| k.key).collect();
        assert_eq!(each[..plain.len()], plain[..]);
        assert_eq!(
            each[plain.len()..],
            [STATIC_KEY, "friction.static_to_coulomb_negative"]
        );
        assert!(
            shape.describe().ends_with("fitted each way"),
            "{}",
            shape.describe()
        );
    }

    #[test]
    fn a_refusal_beside_its_try_each_way_gives_both_reasons_and_tries_no_more() {
        let one = Refused {
            retry: Some(0),
            ..Refused::because("held out 22.9 µm with them against 22.8 µm without", 22.9)
        };
        let both = one.beside(Refused::because("held out 47.8 µm", 47.8));
        assert_eq!(
            both.reason,
            "held out 22.9 µm with them against 22.8 µm without; with friction near rest \
             fitted each way: held out 47.8 µm"
        );
        // The figure given is the one level's, the shape the halves judged.
        assert_eq!(both.with_um, 22.9);
        assert_eq!(both.retry, None);
    }

    #[test]
    fn bristles_need_a_coulomb_force_the_fit_tells_from_none() {
        let x = MachineConfig::preset("small-table").unwrap().x;
        let knobs = knobs::for_axis(&x);
        let j = knobs
            .iter()
            .position(|k| k.key == COULOMB_KEY)
            .expect("the small table's axis fits Coulomb friction");
        let at = |coulomb_n: f64, sigma_n: f64| {
            let mut values = vec![1.0; knobs.len()];
            let mut sigma = vec![0.1; knobs.len()];
            values[j] = coulomb_n;
            sigma[j] = sigma_n;
            holds_coulomb(&knobs, &values, &sigma)
        };
        // 90 N known to ±5 N holds the bristles; 20 N known to ±51 N (the record cannot tell
        // it from none) and none at all do not.
        assert!(at(90.0, 5.0));
        assert!(!at(20.0, 51.0));
        assert!(!at(0.0, 0.0));
        // No Coulomb knob among those fitted: nothing holds them.
        let without: Vec<Knob> = knobs
            .iter()
            .copied()
            .filter(|k| k.key != COULOMB_KEY)
            .collect();
        assert!(!holds_coulomb(
            &without,
            &vec![90.0; without.len()],
            &vec![1.0; without.len()]
        ));
    }

    #[test]
    fn bristles_not_written_or_not_tried_say_why() {
        let mut x = MachineConfig::preset("small-table").unwrap().x;
        let id = AxisIdentification::scored(0.4, 0.1);
        let (_, at) = at_noise((x.clone(), id.clone()), &x);
        let v = at
            .presliding
            .expect("a template without bristles gets a verdict");
        assert!(!v.written);
        assert!(v.statement.contains("not tried"), "{}", v.statement);
        // Written, then the template's values written instead: taken back, with the reason.
        let mut written = Some(PreslidingVerdict {
            written: true,
            by_direction: true,
            statement: "presliding friction: bristles of 50 N/µm".to_string(),
            ..v
        });
        not_written(&mut written, "the axis's fit is not written");
        let w = written.unwrap();
        assert!(!w.written && !w.by_direction);
        assert_eq!(
            w.statement,
            "presliding friction: not determined (the axis's fit is not written)"
        );
        // A template that names bristles keeps them: no verdict.
        x.friction.bristle_stiffness_n_per_um = 50.0;
        let (_, named) = at_noise((x.clone(), id), &x);
        assert_eq!(named.presliding, None);
    }
}
