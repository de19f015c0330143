//! Stability margins of each loop, as a commissioning engineer reads them off the open loop
//! L = T/(1 − T) (T the loop's closed response without feed-forward, [`super::linear`]):
//! the phase margin at every gain crossover (|L| = 1), the gain margin at every phase
//! crossover (L on the negative real axis), and the closed loop's resonance peak max |T|.
//!
//! A loop is read on a logarithmic frequency grid, 0.1 mHz to 100 kHz, thickened around
//! every pole of the closed loop and every mode of the mechanics alone, so that a lightly
//! damped resonance — where a margin is lost — is never stepped over; each crossing is then
//! refined by bisection and each peak by golden-section search.
//!
//! Beside them, the modes the loops act on: the closed-loop eigenvalues less those the loops
//! leave where the mechanics alone put them (a ball screw's kilohertz torsional mode, damped
//! by its material whatever the gains), so that a least damping read from them says
//! something about the loops' setting.

use std::f64::consts::TAU;

use nalgebra::{Complex, DMatrix};
use serde::Serialize;

use super::linear::{
    self, Loop, ModalFigure, closed_loop_modes, feedback_poles, feedback_response,
};
use super::model::{AxisModel, TH_M, TH_S, V2, W_M, W_S, X2};
use crate::numeric::golden_section;

/// Phase margin below which a loop is flagged (degrees): the usual commissioning floor; a
/// loop with less overshoots by half and rings for several periods after every step.
pub const MIN_PHASE_MARGIN_DEG: f64 = 30.0;

/// Gain margin below which a loop is flagged (dB): a factor of two in gain, what a change of
/// load, temperature or a drive's parameter set can take from a loop without it ringing.
pub const MIN_GAIN_MARGIN_DB: f64 = 6.0;

/// The margins of one loop.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LoopMargins {
    /// Which loop.
    pub which: Loop,
    /// The gain crossover where the phase margin is least (Hz); none where |L| never
    /// crosses 1.
    pub crossover_hz: Option<f64>,
    /// The least phase margin over the gain crossovers (degrees): how much phase, lag or
    /// lead, the loop takes there before it is unstable; negative (as far past) for a loop
    /// that is unstable already; infinite where there is no crossover.
    pub phase_margin_deg: f64,
    /// The phase crossover where the gain margin is read (Hz), where there is one.
    pub phase_crossover_hz: Option<f64>,
    /// How far the loop gain may rise before the loop is unstable (dB): the least of
    /// −20·log|L| over the phase crossovers below 0 dB; infinite where there are none.
    pub gain_margin_db: f64,
    /// How far it may fall (dB), for a loop that is stable only above some gain (an
    /// integrator on a double integrator): the least of 20·log|L| over the phase crossovers
    /// above 0 dB; infinite where there are none.
    pub gain_reduction_margin_db: f64,
    /// Where that is read (Hz), where there is one.
    pub gain_reduction_hz: Option<f64>,
    /// The closed loop's largest gain max |T| (dB); 0 dB for a loop that never rises above
    /// its low-frequency gain.
    pub peak_db: f64,
    /// Where that is (Hz); 0 where the gain only falls.
    pub peak_hz: f64,
    /// Whether the loop's closed-loop poles all lie in the left half-plane (those of the
    /// integrators it does not close aside).
    pub stable: bool,
}

impl LoopMargins {
    /// Whether the loop is unstable already: its gain margins then say how far the gain is
    /// from the edge, not how far it may move.
    pub fn unstable(&self) -> bool {
        !self.stable
    }

    /// Whether the loop falls short of a phase margin of `min_phase_deg` or a gain margin
    /// (either way) of `min_gain_db`.
    pub fn short_of(&self, min_phase_deg: f64, min_gain_db: f64) -> bool {
        self.phase_margin_deg < min_phase_deg
            || self.gain_margin_db < min_gain_db
            || self.gain_reduction_margin_db < min_gain_db
    }
}

/// Grid density (points per decade) and range (Hz).
const PER_DECADE: usize = 48;
const FROM_HZ: f64 = 1e-4;
const TO_HZ: f64 = 1e5;

/// The margins of every loop the axis has, inner first.
pub fn margins(model: &AxisModel) -> Vec<LoopMargins> {
    let extra = mechanical_modes(model);
    linear::loops(model)
        .into_iter()
        .map(|l| loop_margins_with(model, l, &extra))
        .collect()
}

/// The margins of one loop.
pub fn loop_margins(model: &AxisModel, which: Loop) -> LoopMargins {
    loop_margins_with(model, which, &mechanical_modes(model))
}

fn loop_margins_with(model: &AxisModel, which: Loop, mechanics: &[ModalFigure]) -> LoopMargins {
    let t = feedback_response(model, which);
    let open = |f: f64| {
        let tf = t(f);
        tf / (Complex::new(1.0, 0.0) - tf)
    };
    let poles = feedback_poles(model, which);
    // Integrators the loop does not close (a rigid body's position, an outer loop's
    // integral) are repeated poles at zero: the eigensolver returns them as a small cluster
    // about it, some a hair to the right.
    let largest = poles.iter().map(|l| l.norm()).fold(0.0, f64::max);
    let stable = poles
        .iter()
        .all(|l| l.re <= 1e-9 * (1.0 + l.norm() / TAU) || l.norm() <= 1e-5 * largest);
    let grid = grid_around(&resonances(&poles, mechanics), (FROM_HZ, TO_HZ), PER_DECADE);
    let values: Vec<Complex<f64>> = grid.iter().map(|&f| open(f)).collect();
    let (crossover_hz, distance_deg) = least_phase_margin(&grid, &values, &open);
    // A stable loop takes that much phase, lag or lead, at a crossover before a closed-loop
    // pole reaches the imaginary axis; an unstable one is that far past it.
    let phase_margin_deg = if stable { distance_deg } else { -distance_deg };
    let GainMargins {
        up_hz: phase_crossover_hz,
        up_db: gain_margin_db,
        down_hz: gain_reduction_hz,
        down_db: gain_reduction_margin_db,
    } = least_gain_margins(&grid, &values, &open);
    let (peak_hz, peak_db) = closed_peak(&grid, &t);
    LoopMargins {
        which,
        crossover_hz,
        phase_margin_deg,
        phase_crossover_hz,
        gain_margin_db,
        gain_reduction_margin_db,
        gain_reduction_hz,
        peak_db,
        peak_hz,
        stable,
    }
}

/// Where a loop's responses can peak: (frequency Hz, damping ratio) of each oscillatory
/// pole of its closed loop and each mode of the mechanics.
fn resonances(poles: &[Complex<f64>], mechanics: &[ModalFigure]) -> Vec<(f64, f64)> {
    poles
        .iter()
        .filter(|l| l.im > 0.0)
        .map(|l| (l.norm() / TAU, (-l.re / l.norm()).max(1e-4)))
        .chain(
            mechanics
                .iter()
                .map(|m| (m.frequency_hz, m.damping.max(1e-4))),
        )
        .collect()
}

/// A logarithmic grid from `from_hz` to `to_hz`, `per_decade` points a decade, thickened
/// around the loop's resonances: what a plot of the loop needs to show its peaks whole.
#[cfg(feature = "cli")]
pub(crate) fn response_grid(
    model: &AxisModel,
    which: Loop,
    (from_hz, to_hz): (f64, f64),
    per_decade: usize,
) -> Vec<f64> {
    grid_around(
        &resonances(&feedback_poles(model, which), &mechanical_modes(model)),
        (from_hz, to_hz),
        per_decade,
    )
}

/// What a closed response shows on its Bode plot: its largest gain and where, and where it
/// first falls to −3 dB and first lags by 10°.
#[cfg(feature = "cli")]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ClosedFigures {
    /// The largest gain (dB); the low-frequency gain where it only falls.
    pub peak_db: f64,
    /// Where that is (Hz); 0 where the gain only falls.
    pub peak_hz: f64,
    /// First frequency where the gain falls to −3 dB (Hz).
    pub bandwidth_3db_hz: f64,
    /// First frequency where the phase reaches −10° (Hz).
    pub phase_10deg_hz: f64,
}

/// The figures of one of a loop's closed responses, each read off that response alone: the
/// feedback loop's T (`with_feedforward` false) or the command's with its feed-forward,
/// which can rise far above T where the feed-forward drives a resonance T keeps down.
#[cfg(feature = "cli")]
pub(crate) fn closed_figures(
    model: &AxisModel,
    which: Loop,
    with_feedforward: bool,
) -> ClosedFigures {
    let grid = response_grid(model, which, (FROM_HZ, TO_HZ), PER_DECADE);
    let (peak_hz, peak_db) = if with_feedforward {
        closed_peak(&grid, &linear::command_response(model, which))
    } else {
        closed_peak(&grid, &feedback_response(model, which))
    };
    let (bandwidth_3db_hz, phase_10deg_hz) =
        linear::response_bandwidths(model, which, with_feedforward);
    ClosedFigures {
        peak_db,
        peak_hz,
        bandwidth_3db_hz,
        phase_10deg_hz,
    }
}

/// The logarithmic grid with, around each (frequency, damping) sharper than the grid
/// resolves (ζ below 0.3), points a quarter of the resonance's half-width ζ·f apart over
/// four half-widths either side: where a gain crosses 1 on a resonance's flank, a sample
/// falls on each side of it.
fn grid_around(
    resonances: &[(f64, f64)],
    (from_hz, to_hz): (f64, f64),
    per_decade: usize,
) -> Vec<f64> {
    let mut grid = linear::log_space(from_hz, to_hz, per_decade);
    for &(f, zeta) in resonances {
        if !(f > from_hz && f < to_hz) || zeta >= 0.3 {
            continue;
        }
        let step = (zeta * f).max(1e-9) / 4.0;
        grid.extend(
            (-16..=16)
                .map(|i| f + step * f64::from(i))
                .filter(|&g| g > from_hz && g < to_hz),
        );
    }
    grid.sort_by(f64::total_cmp);
    grid.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * b.abs());
    grid
}

/// Bisection on a log scale for the sign change of `g` in [lo, hi] (g(lo) and g(hi) of
/// opposite signs).
fn bisect(mut lo: f64, mut hi: f64, g: impl Fn(f64) -> f64) -> f64 {
    let below = g(lo) < 0.0;
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if (g(mid) < 0.0) == below {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo * hi).sqrt()
}

/// How far, in phase, an open loop of unit gain with phase `phase_deg` lies from −1: the
/// phase margin at a gain crossover, in [0°, 180°]. A loop whose phase lies 60° above
/// −180° (or −540°: three integrators) has 60°; one whose resonance lifts it to unit gain
/// at +45° is 135° from −1, whichever way its phase would have to turn.
fn phase_margin_at(phase_deg: f64) -> f64 {
    let above = (180.0 + phase_deg).rem_euclid(360.0);
    above.min(360.0 - above)
}

/// The gain crossover with the least phase margin, and the margin (infinite where |L| never
/// crosses 1).
fn least_phase_margin(
    grid: &[f64],
    values: &[Complex<f64>],
    open: &impl Fn(f64) -> Complex<f64>,
) -> (Option<f64>, f64) {
    let mut best = (None, f64::INFINITY);
    for i in 1..grid.len() {
        let (a, b) = (values[i - 1].norm() - 1.0, values[i].norm() - 1.0);
        if (a < 0.0) == (b < 0.0) {
            continue;
        }
        let f = bisect(grid[i - 1], grid[i], |f| open(f).norm() - 1.0);
        // The margin is the phase modulo a turn: no unwrapping needed.
        let margin = phase_margin_at(open(f).arg().to_degrees());
        if margin < best.1 {
            best = (Some(f), margin);
        }
    }
    best
}

/// A loop that is unstable only if its gain falls a thousandfold is not conditionally
/// stable in any sense a machine shows (an uncontrolled integrator's pole at zero puts the
/// open loop near the negative axis near DC, at such gains): beyond this (dB) a downward
/// crossing is not a margin.
const MEANINGLESS_DB: f64 = 60.0;

/// The least gain margins either way and where they are read (Hz, dB).
struct GainMargins {
    up_hz: Option<f64>,
    up_db: f64,
    down_hz: Option<f64>,
    down_db: f64,
}

/// The phase crossovers (L on the negative real axis): below unit gain the least upward
/// margin, above it the least downward one.
fn least_gain_margins(
    grid: &[f64],
    values: &[Complex<f64>],
    open: &impl Fn(f64) -> Complex<f64>,
) -> GainMargins {
    let mut m = GainMargins {
        up_hz: None,
        up_db: f64::INFINITY,
        down_hz: None,
        down_db: f64::INFINITY,
    };
    for i in 1..grid.len() {
        let (a, b) = (values[i - 1], values[i]);
        let crosses = (a.im < 0.0) != (b.im < 0.0) && a.re < 0.0 && b.re < 0.0;
        if !crosses {
            continue;
        }
        let f = bisect(grid[i - 1], grid[i], |f| open(f).im);
        let db = 20.0 * open(f).norm().log10();
        if db < 0.0 && -db < m.up_db {
            (m.up_hz, m.up_db) = (Some(f), -db);
        } else if (0.0..=MEANINGLESS_DB).contains(&db) && db < m.down_db {
            (m.down_hz, m.down_db) = (Some(f), db);
        }
    }
    m
}

/// The closed loop's largest gain (Hz, dB), refined about the grid's largest sample; (0, gain
/// at the lowest frequency) where the gain never rises above that.
fn closed_peak(grid: &[f64], t: &impl Fn(f64) -> Complex<f64>) -> (f64, f64) {
    let gains: Vec<f64> = grid.iter().map(|&f| t(f).norm()).collect();
    let (i, &g) = gains
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .expect("a grid of frequencies");
    let low = gains[0];
    if i == 0 || g <= low * (1.0 + 1e-9) {
        return (0.0, 20.0 * low.log10());
    }
    let (lo, hi) = (grid[i - 1].ln(), grid[(i + 1).min(grid.len() - 1)].ln());
    let x = golden_section(lo, hi, 1e-9 * (hi - lo).abs().max(1e-12), &|x| {
        -t(x.exp()).norm()
    });
    let (f, gain) = (x.exp(), t(x.exp()).norm().max(g));
    (f, 20.0 * gain.log10())
}

/// The oscillatory modes of the mechanics alone (motor, screw and table with no torque from
/// the motor): what a loop that leaves them be leaves in its closed-loop modes.
pub(crate) fn mechanical_modes(model: &AxisModel) -> Vec<ModalFigure> {
    let states: &[usize] = if model.linear_motor {
        &[X2, V2]
    } else {
        &[TH_M, W_M, TH_S, W_S, X2, V2]
    };
    let full = model.dynamics(linear::nominal_mode());
    let a = DMatrix::from_fn(states.len(), states.len(), |i, j| {
        full[(states[i], states[j])]
    });
    crate::numeric::decompose::eigenvalues(a)
        .unwrap_or_default()
        .iter()
        .filter(|l| l.im > 0.0)
        .map(|l| ModalFigure {
            frequency_hz: l.norm() / TAU,
            damping: -l.re / l.norm(),
            real_per_s: l.re,
        })
        .collect()
}

/// A closed-loop mode as a point of the complex plane (1/s), upper half.
fn eigenvalue(m: &ModalFigure) -> Complex<f64> {
    let omega = TAU * m.frequency_hz;
    Complex::new(
        m.real_per_s,
        (omega * omega - m.real_per_s * m.real_per_s)
            .max(0.0)
            .sqrt(),
    )
}

/// A closed-loop mode the loops act on, with the damping the mechanics alone give the mode
/// it continues (none for a mode of the loops' own).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LoopMode {
    /// The closed-loop mode.
    pub mode: ModalFigure,
    /// The damping ratio of the mechanics' mode it continues, where it continues one.
    pub mechanics_damping: Option<f64>,
}

impl LoopMode {
    /// Whether the loops made this mode or took at least half of the damping the mechanics
    /// alone give it: where a damping below the threshold is the setting's doing. A lightly
    /// damped mode of the mechanics that any position loop shifts a little (the heavy
    /// table's 38 Hz axial mode, 0.051 alone, 0.049 at Kv 0.5) is the machine's, and would
    /// otherwise flag every gain alike; halved, it rings twice as long for the gain.
    pub(crate) fn of_the_loops_making(&self) -> bool {
        self.mechanics_damping
            .is_none_or(|own| self.mode.damping < LOOPS_TAKE_SHARE * own)
    }
}

/// The share of a mechanics' mode's own damping below which the loops have made it theirs.
const LOOPS_TAKE_SHARE: f64 = 0.5;

/// How far (as a share of its decay rate, the half-width of its resonance in rad/s) the loops
/// may move a mode of the mechanics before they act on it.
const LEFT_AS_IT_IS: f64 = 0.1;

/// The closed loops' oscillatory modes that the loops act on: every closed-loop mode with a
/// damping below 1 except, for each mode of the mechanics alone, its continuation where the
/// loops leave it where the mechanics put it — its eigenvalue moved by less than a tenth of
/// its decay rate (a screw's kilohertz torsion, far above every loop's crossover). Which
/// modes count does not depend on how well the loops damp them, so the least damping over
/// them moves continuously with the gains.
pub(crate) fn loop_modes(model: &AxisModel) -> Vec<LoopMode> {
    let mut modes: Vec<ModalFigure> = closed_loop_modes(model)
        .into_iter()
        .filter(|m| m.damping < 0.999 && m.frequency_hz > 0.0 && m.real_per_s.is_finite())
        .collect();
    // Conjugate pairs appear twice with the same figures: one of each is enough.
    modes.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    modes.dedup_by(|a, b| {
        (a.frequency_hz - b.frequency_hz).abs() <= 1e-9 * b.frequency_hz
            && (a.damping - b.damping).abs() <= 1e-9
    });
    let mut out: Vec<Option<LoopMode>> = modes
        .iter()
        .map(|&mode| {
            Some(LoopMode {
                mode,
                mechanics_damping: None,
            })
        })
        .collect();
    for own in mechanical_modes(model) {
        let at = eigenvalue(&own);
        // Its continuation: the closed-loop mode nearest it, within a tenth of its frequency.
        let nearest = modes
            .iter()
            .enumerate()
            .filter(|(_, m)| (m.frequency_hz / own.frequency_hz - 1.0).abs() <= 0.1)
            .min_by(|a, b| {
                let d = |m: &ModalFigure| (eigenvalue(m) - at).norm();
                d(a.1).total_cmp(&d(b.1))
            });
        let Some((i, m)) = nearest else { continue };
        if (eigenvalue(m) - at).norm() <= LEFT_AS_IT_IS * own.real_per_s.abs() {
            out[i] = None;
        } else if let Some(lm) = &mut out[i] {
            lm.mechanics_damping = Some(own.damping);
        }
    }
    out.into_iter().flatten().collect()
}

/// The least damped of the modes the loops act on ([`loop_modes`]): `sweep`'s `loop damping`.
pub(crate) fn least_damped_loop_mode(model: &AxisModel) -> Option<ModalFigure> {
    least_of(loop_modes(model).into_iter())
}

/// The least damped of the modes of the loops' making ([`LoopMode::of_the_loops_making`]):
/// what a setting is flagged by.
pub(crate) fn least_damped_of_the_loops_making(model: &AxisModel) -> Option<ModalFigure> {
    least_of(
        loop_modes(model)
            .into_iter()
            .filter(LoopMode::of_the_loops_making),
    )
}

fn least_of(modes: impl Iterator<Item = LoopMode>) -> Option<ModalFigure> {
    modes
        .map(|m| m.mode)
        .min_by(|a, b| a.damping.total_cmp(&b.damping))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn margins_read_off_the_nearest_odd_half_turn() {
        assert!((phase_margin_at(-120.0) - 60.0).abs() < 1e-12);
        assert!((phase_margin_at(-200.0) - 20.0).abs() < 1e-12);
        // A loop with three integrators starts at −270°: 60° above −540°.
        assert!((phase_margin_at(-480.0) - 60.0).abs() < 1e-12);
        assert!((phase_margin_at(-314.5) - 134.5).abs() < 1e-9);
    }

    #[test]
    fn the_screws_torsional_mode_is_the_mechanics_not_the_loops() {
        let model = AxisModel::from_config(&MachineConfig::default_preset().x);
        let own = mechanical_modes(&model);
        // The torsional mode (≈ 10 kHz, ζ 0.02) and the axial one.
        assert_eq!(own.len(), 2, "{own:?}");
        let loops = loop_modes(&model);
        assert!(
            loops.iter().all(|m| m.mode.frequency_hz < 5_000.0),
            "{loops:?}"
        );
        let all = closed_loop_modes(&model);
        assert!(all.iter().any(|m| m.frequency_hz > 5_000.0));
    }
}
