//! The linearised axis (friction as viscous only, nut in contact, no limits): closed-loop
//! stability and the frequency responses of the current, velocity and position loops.
//!
//! Each loop is unity-feedback (the current filter acts on command and feedback alike), so
//! its open loop follows from its closed loop: L = T/(1 − T). A loop's closed response is
//! taken with the loops inside it closed and the loop outside it open, as a drive's
//! commissioning tool measures it.

use nalgebra::{Complex, DMatrix, DVector};
use serde::Serialize;

use super::SimError;
use super::model::{AR, AxisModel, ClampMode, ContactMode, FrictionMode, Mode, Row, VR, XR, ZW};
use crate::numeric::decompose;

/// The loops of the cascade.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Loop {
    /// Current command → current (velocity loop open).
    Current,
    /// Speed command → motor speed (position loop open).
    Velocity,
    /// Position command → position feedback.
    Position,
}

impl Loop {
    /// All three, inner first.
    pub const ALL: [Loop; 3] = [Loop::Current, Loop::Velocity, Loop::Position];

    /// Name for tables.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Loop::Current => "current",
            Loop::Velocity => "velocity",
            Loop::Position => "position",
        }
    }
}

/// The loops an axis has, inner first: a drive without a velocity loop of its own (a
/// position controller on a current amplifier) has the current and position loops only.
pub fn loops(model: &AxisModel) -> Vec<Loop> {
    Loop::ALL
        .into_iter()
        .filter(|&l| l != Loop::Velocity || model.has_velocity_loop())
        .collect()
}

/// The position gain an axis behaves with, in 1/s: the cascade's Kv, or for another
/// controller the closed position loop's −3 dB bandwidth in rad/s (which a P loop on a fast
/// velocity loop has as its Kv). Used where a time scale of the loop is wanted (how long a
/// following error lasts), not for the lag F/Kv of a controller with integral action.
pub(crate) fn equivalent_kv_per_s(model: &AxisModel) -> f64 {
    match model.control {
        super::model::ControlModel::Cascade => model.kv_per_s(),
        _ => {
            let f = loop_figures(model, Loop::Position).bandwidth_3db_hz;
            if f.is_finite() {
                std::f64::consts::TAU * f
            } else {
                1.0
            }
        }
    }
}

/// How fast the slowest closed-loop mode of the axis decays (1/s): what a disturbance —
/// friction at a reversal — takes to die away. For a proportional position loop on a fast
/// velocity loop about its Kv; for a controller with integral action the mode its
/// integrator leaves, often far slower than its bandwidth.
pub(crate) fn settling_rate_per_s(model: &AxisModel) -> f64 {
    let modes = closed_loop_modes(model);
    let fastest = modes.iter().map(|m| -m.real_per_s).fold(0.0, f64::max);
    modes
        .iter()
        .map(|m| -m.real_per_s)
        // Integrators no loop closes (none in a closed loop) would read as zero.
        .filter(|&r| r > 1e-9 * fastest)
        .fold(f64::INFINITY, f64::min)
}

/// The linear mode used for analysis.
pub(crate) fn nominal_mode() -> Mode {
    Mode {
        friction: FrictionMode::SlipPos,
        contact: ContactMode::Pos,
        current: ClampMode::Linear,
        voltage: ClampMode::Linear,
    }
}

/// A single-input single-output state space: ẋ = A x + (b0 + s·b1 + s²·b2) u, y = c x.
struct Siso {
    a: DMatrix<f64>,
    b: [DVector<f64>; 3],
    c: DVector<f64>,
}

/// The states the axis uses, as indices into the model's state: the mechanics and the
/// current always, the current loop's filters and integral where it is modelled, the
/// velocity integral where there is one, and a transfer function's states. The reference
/// states are inputs here, and states a structure leaves unused (which would only add
/// eigenvalues at zero) are left out.
struct Restriction {
    states: Vec<usize>,
}

impl Restriction {
    fn of(model: &AxisModel) -> Self {
        Restriction {
            states: model.active_states(),
        }
    }

    fn len(&self) -> usize {
        self.states.len()
    }

    /// Where model state `i` sits here; `None` for a state the structure does not use.
    fn at(&self, i: usize) -> Option<usize> {
        self.states.iter().position(|&s| s == i)
    }

    fn row(&self, row: &Row) -> DVector<f64> {
        DVector::from_fn(self.len(), |k, _| row[self.states[k]])
    }

    fn matrix(&self, full: &super::model::AugMatrix) -> DMatrix<f64> {
        DMatrix::from_fn(self.len(), self.len(), |i, j| {
            full[(self.states[i], self.states[j])]
        })
    }

    fn column(&self, full: &super::model::AugMatrix, j: usize) -> DVector<f64> {
        DVector::from_fn(self.len(), |i, _| full[(self.states[i], j)])
    }
}

/// The loop's system. The position loop's closed response includes the feed-forward (the
/// reference enters with its velocity and acceleration); its open loop, read as T/(1 − T),
/// is only the feedback's, so `feedback_only` leaves the feed-forward out. `None` for a loop
/// the axis does not have (see [`loops`]): a position controller on a current amplifier
/// has no speed command to open a velocity loop at.
fn loop_system(model: &AxisModel, which: Loop, feedback_only: bool) -> Option<Siso> {
    if !loops(model).contains(&which) {
        return None;
    }
    let full = model.dynamics(nominal_mode());
    let s = model.signals();
    let r = Restriction::of(model);
    let n = r.len();
    let mut a = r.matrix(&full);
    let zero = DVector::zeros(n);
    Some(match which {
        Loop::Position => Siso {
            a,
            b: if feedback_only {
                [r.column(&full, XR), zero.clone(), zero]
            } else {
                [
                    r.column(&full, XR),
                    r.column(&full, VR),
                    r.column(&full, AR),
                ]
            },
            c: r.row(&s.x_fb),
        },
        Loop::Velocity => {
            // ω_cmd becomes the input: remove its dependence on the states.
            let w = r.row(&s.w_cmd);
            let (target, rate) = model.current_command_target();
            let (target, zw) = (r.at(target)?, r.at(ZW)?);
            let k = model.ks * rate;
            for j in 0..n {
                a[(target, j)] -= k * w[j];
                a[(zw, j)] -= w[j];
            }
            let mut b = DVector::zeros(n);
            b[target] = k;
            b[zw] = 1.0;
            let mut c = DVector::zeros(n);
            let speed = r.row(&model.motor_speed_row());
            c.copy_from(&speed);
            Siso {
                a,
                b: [b, zero.clone(), zero],
                c,
            }
        }
        Loop::Current => {
            // i_cmd becomes the input: the command filter (or the amplifier) sees it instead
            // of the controller.
            let (target, rate) = model.current_command_target();
            let target = r.at(target)?;
            for j in 0..n {
                a[(target, j)] = 0.0;
            }
            a[(target, target)] = -rate;
            let mut b = DVector::zeros(n);
            b[target] = rate;
            let mut c = DVector::zeros(n);
            c[r.at(super::model::I)?] = 1.0;
            Siso {
                a,
                b: [b, zero.clone(), zero],
                c,
            }
        }
    })
}

/// A response where the axis has no such loop.
const NO_RESPONSE: Complex<f64> = Complex::new(f64::NAN, f64::NAN);

impl Siso {
    fn response(&self, freq_hz: f64) -> Complex<f64> {
        let n = self.c.len();
        let s = Complex::new(0.0, std::f64::consts::TAU * freq_hz);
        let m = DMatrix::from_fn(n, n, |i, j| {
            let diag = if i == j { s } else { Complex::new(0.0, 0.0) };
            diag - Complex::new(self.a[(i, j)], 0.0)
        });
        let b = DVector::from_fn(n, |i, _| {
            Complex::new(self.b[0][i], 0.0) + s * self.b[1][i] + s * s * self.b[2][i]
        });
        let x = m.lu().solve(&b).unwrap_or_else(|| DVector::zeros(n));
        (0..n).map(|i| x[i] * self.c[i]).sum()
    }
}

/// The loop's closed response without feed-forward, T(f) with f in Hz, as a function: its
/// open loop is T/(1 − T). Built once, evaluated at as many frequencies as wanted; NaN for
/// a loop the axis does not have.
pub(crate) fn feedback_response(model: &AxisModel, which: Loop) -> impl Fn(f64) -> Complex<f64> {
    let sys = loop_system(model, which, true);
    move |f| sys.as_ref().map_or(NO_RESPONSE, |s| s.response(f))
}

/// The eigenvalues of a loop's closed feedback system (1/s): where its response can peak.
/// None for a loop the axis does not have.
pub(crate) fn feedback_poles(model: &AxisModel, which: Loop) -> Vec<Complex<f64>> {
    loop_system(model, which, true)
        .and_then(|sys| decompose::eigenvalues(sys.a))
        .unwrap_or_default()
}

/// Closed-loop frequency response of a loop at `freq_hz`; NaN for a loop the axis does not
/// have (see [`loops`]).
pub fn closed_loop(model: &AxisModel, which: Loop, freq_hz: f64) -> Complex<f64> {
    loop_system(model, which, false).map_or(NO_RESPONSE, |s| s.response(freq_hz))
}

/// The position loop's steady following error per unit speed (s): what a ramp command
/// leaves, lim (1 − T(s))/s over the closed loop with its feed-forward — 1/Kv for a
/// proportional loop, (1 − k_f)/Kv with velocity feed-forward, none with integral action.
/// Read at 10 µHz, where the loop's own dynamics add nothing measurable.
pub(crate) fn velocity_lag_s(model: &AxisModel) -> f64 {
    let f = 1e-5;
    let t = closed_loop(model, Loop::Position, f);
    ((Complex::new(1.0, 0.0) - t) / Complex::new(0.0, std::f64::consts::TAU * f)).re
}

/// Open-loop frequency response of the feedback, L = T/(1 − T) with T the closed loop
/// without feed-forward; NaN for a loop the axis does not have.
pub fn open_loop(model: &AxisModel, which: Loop, freq_hz: f64) -> Complex<f64> {
    let t = loop_system(model, which, true).map_or(NO_RESPONSE, |s| s.response(freq_hz));
    t / (Complex::new(1.0, 0.0) - t)
}

/// Which of a loop's responses a Bode plot draws.
#[cfg(feature = "cli")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Response {
    /// The open loop L = T/(1 − T), where the margins are read.
    Open,
    /// The feedback loop closed, T = L/(1 + L), feed-forward left out.
    Feedback,
    /// From the command to the loop's output with the feed-forward added.
    WithFeedforward,
}

/// Magnitude (dB) and phase (degrees, unwrapped from 0 at low frequency) of one of a
/// loop's responses over a frequency list; none for a loop the axis does not have.
#[cfg(feature = "cli")]
pub(crate) fn bode(
    model: &AxisModel,
    which: Loop,
    freqs_hz: &[f64],
    response: Response,
) -> Vec<(f64, f64, f64)> {
    let open = response == Response::Open;
    let feedback_only = response != Response::WithFeedforward;
    let Some(sys) = loop_system(model, which, feedback_only) else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(freqs_hz.len());
    let mut prev_phase: Option<f64> = None;
    for &f in freqs_hz {
        let t = sys.response(f);
        let h = if open {
            t / (Complex::new(1.0, 0.0) - t)
        } else {
            t
        };
        let mut phase = h.arg().to_degrees();
        if let Some(p) = prev_phase {
            while phase - p > 180.0 {
                phase -= 360.0;
            }
            while phase - p < -180.0 {
                phase += 360.0;
            }
        }
        prev_phase = Some(phase);
        out.push((f, 20.0 * h.norm().log10(), phase));
    }
    if open && let Some(&(_, _, first, ..)) = out.first() {
        // An open loop's integrators put its phase below 0° at low frequency, where the
        // margins are read against −180°: its curve starts in (−360°, 0°], not a turn above.
        let turns = 360.0 * (first / 360.0).ceil();
        for p in &mut out {
            p.2 -= turns;
        }
    }
    out
}

/// Logarithmically spaced frequencies.
pub(crate) fn log_space(from_hz: f64, to_hz: f64, per_decade: usize) -> Vec<f64> {
    let decades = (to_hz / from_hz).log10();
    let n = (decades * per_decade as f64).ceil() as usize;
    (0..=n)
        .map(|i| from_hz * 10f64.powf(decades * i as f64 / n as f64))
        .collect()
}

/// The figures a commissioning engineer reads off a loop's Bode plots.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LoopFigures {
    /// Which loop.
    pub which: Loop,
    /// Open-loop gain crossover (Hz).
    pub crossover_hz: f64,
    /// Phase margin at the crossover (degrees).
    pub phase_margin_deg: f64,
    /// Closed loop: first frequency where the gain falls to −3 dB (Hz).
    pub bandwidth_3db_hz: f64,
    /// Closed loop: first frequency where the phase reaches −10° (Hz).
    pub phase_10deg_hz: f64,
    /// Closed-loop gain at low frequency (dB).
    pub dc_gain_db: f64,
}

/// Crossover, phase margin, −3 dB and −10° frequencies of a loop; NaN throughout for a
/// loop the axis does not have (see [`loops`]).
pub fn loop_figures(model: &AxisModel, which: Loop) -> LoopFigures {
    let (Some(sys), Some(feedback)) = (
        loop_system(model, which, false),
        loop_system(model, which, true),
    ) else {
        return LoopFigures {
            which,
            crossover_hz: f64::NAN,
            phase_margin_deg: f64::NAN,
            bandwidth_3db_hz: f64::NAN,
            phase_10deg_hz: f64::NAN,
            dc_gain_db: f64::NAN,
        };
    };
    let grid = log_space(1e-4, 100_000.0, 360);
    let closed: Vec<Complex<f64>> = grid.iter().map(|&f| sys.response(f)).collect();
    let closed_feedback: Vec<Complex<f64>> = if sys.b == feedback.b {
        closed.clone()
    } else {
        grid.iter().map(|&f| feedback.response(f)).collect()
    };
    let open_mag = |t: Complex<f64>| (t / (Complex::new(1.0, 0.0) - t)).norm();
    let crossover_hz = first_crossing(
        &grid,
        |f| open_mag(feedback.response(f)) - 1.0,
        &closed_feedback,
        |t| open_mag(t) - 1.0,
    );
    // A loop with several integrators starts below −180°: the margin is read modulo a turn.
    let phase_margin_deg =
        (180.0 + unwrapped_phase(&feedback, crossover_hz) + 180.0).rem_euclid(360.0) - 180.0;
    let (bandwidth_3db_hz, phase_10deg_hz) = bandwidths(&sys, &grid, &closed);
    LoopFigures {
        which,
        crossover_hz,
        phase_margin_deg,
        bandwidth_3db_hz,
        phase_10deg_hz,
        dc_gain_db: 20.0 * sys.response(1e-4).norm().log10(),
    }
}

/// The first frequencies where a closed response `sys` falls to −3 dB and where its phase
/// reaches −10°, read on `grid` where it takes the values `closed`.
fn bandwidths(sys: &Siso, grid: &[f64], closed: &[Complex<f64>]) -> (f64, f64) {
    let gain_3db = 1.0 / 2f64.sqrt();
    let bandwidth_3db_hz = first_crossing(
        grid,
        |f| sys.response(f).norm() - gain_3db,
        closed,
        |t| t.norm() - gain_3db,
    );
    (bandwidth_3db_hz, first_crossing_phase(sys, grid, -10.0))
}

/// The −3 dB and −10° frequencies of one of a loop's closed responses: the feedback loop's
/// T = L/(1 + L) (`with_feedforward` false) or the command's with the feed-forward the
/// position loop adds to it; NaN for a loop the axis does not have.
#[cfg(feature = "cli")]
pub(crate) fn response_bandwidths(
    model: &AxisModel,
    which: Loop,
    with_feedforward: bool,
) -> (f64, f64) {
    let Some(sys) = loop_system(model, which, !with_feedforward) else {
        return (f64::NAN, f64::NAN);
    };
    let grid = log_space(1e-4, 100_000.0, 360);
    let closed: Vec<Complex<f64>> = grid.iter().map(|&f| sys.response(f)).collect();
    bandwidths(&sys, &grid, &closed)
}

/// Whether the loop's command reaches it through a feed-forward as well as its feedback:
/// its response from the command then differs from its feedback loop's T.
#[cfg(feature = "cli")]
pub(crate) fn has_feedforward(model: &AxisModel, which: Loop) -> bool {
    match (
        loop_system(model, which, false),
        loop_system(model, which, true),
    ) {
        (Some(with), Some(without)) => with.b != without.b,
        _ => false,
    }
}

/// The loop's closed response from its command with the feed-forward, as a function of f
/// in Hz; NaN for a loop the axis does not have.
#[cfg(feature = "cli")]
pub(crate) fn command_response(model: &AxisModel, which: Loop) -> impl Fn(f64) -> Complex<f64> {
    let sys = loop_system(model, which, false);
    move |f| sys.as_ref().map_or(NO_RESPONSE, |s| s.response(f))
}

/// First frequency on the grid where `g` changes sign from positive, refined by bisection.
fn first_crossing(
    grid: &[f64],
    g: impl Fn(f64) -> f64,
    sampled: &[Complex<f64>],
    g_sampled: impl Fn(Complex<f64>) -> f64,
) -> f64 {
    for i in 1..grid.len() {
        if g_sampled(sampled[i - 1]) > 0.0 && g_sampled(sampled[i]) <= 0.0 {
            let (mut lo, mut hi) = (grid[i - 1], grid[i]);
            for _ in 0..60 {
                let mid = (lo * hi).sqrt();
                if g(mid) > 0.0 { lo = mid } else { hi = mid }
            }
            return (lo * hi).sqrt();
        }
    }
    f64::NAN
}

/// The loop's open-loop phase at `f`, unwrapped from low frequency (degrees).
fn unwrapped_phase(sys: &Siso, f: f64) -> f64 {
    let grid = log_space(0.01f64.min(f / 100.0), f, 100);
    let mut phase = 0.0;
    let mut prev: Option<f64> = None;
    for &g in &grid {
        let t = sys.response(g);
        let l = t / (Complex::new(1.0, 0.0) - t);
        let mut p = l.arg().to_degrees();
        if let Some(q) = prev {
            while p - q > 180.0 {
                p -= 360.0;
            }
            while p - q < -180.0 {
                p += 360.0;
            }
        }
        prev = Some(p);
        phase = p;
    }
    phase
}

fn first_crossing_phase(sys: &Siso, grid: &[f64], level_deg: f64) -> f64 {
    let mut prev: Option<(f64, f64)> = None;
    for &f in grid {
        let mut p = sys.response(f).arg().to_degrees();
        if let Some((_, q)) = prev {
            while p - q > 180.0 {
                p -= 360.0;
            }
            while p - q < -180.0 {
                p += 360.0;
            }
        }
        if let Some((f0, q)) = prev
            && q > level_deg
            && p <= level_deg
        {
            let (mut lo, mut hi) = (f0, f);
            for _ in 0..60 {
                let mid = (lo * hi).sqrt();
                // Near the crossing the phase is far from the ±180° cut.
                if sys.response(mid).arg().to_degrees() > level_deg {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            return (lo * hi).sqrt();
        }
        prev = Some((f, p));
    }
    f64::NAN
}

/// A closed-loop mode: its natural frequency and damping ratio.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModalFigure {
    /// Natural frequency |λ|/2π (Hz).
    pub frequency_hz: f64,
    /// Damping ratio −Re λ/|λ|.
    pub damping: f64,
    /// Real part of the eigenvalue (1/s).
    pub real_per_s: f64,
}

/// Eigenvalues of the closed position loop (the whole linearised axis); none where a
/// setting makes the loop's matrix non-finite ([`check_stable`] refuses such an axis).
pub fn closed_loop_modes(model: &AxisModel) -> Vec<ModalFigure> {
    modal_figures(&closed_loop_eigenvalues(model).unwrap_or_default())
}

fn modal_figures(eigenvalues: &[Complex<f64>]) -> Vec<ModalFigure> {
    eigenvalues
        .iter()
        .map(|l| {
            let norm = l.norm();
            ModalFigure {
                frequency_hz: norm / std::f64::consts::TAU,
                damping: if norm > 0.0 { -l.re / norm } else { 1.0 },
                real_per_s: l.re,
            }
        })
        .collect()
}

/// The closed position loop's eigenvalues (1/s), `None` where they cannot be computed.
fn closed_loop_eigenvalues(model: &AxisModel) -> Option<Vec<Complex<f64>>> {
    decompose::eigenvalues(Restriction::of(model).matrix(&model.dynamics(nominal_mode())))
}

/// The least damped oscillatory closed-loop mode (damping below 1).
#[cfg(feature = "cli")]
pub(crate) fn least_damped(model: &AxisModel) -> Option<ModalFigure> {
    closed_loop_modes(model)
        .into_iter()
        .filter(|m| m.damping < 0.999 && m.frequency_hz > 0.0)
        .min_by(|a, b| a.damping.total_cmp(&b.damping))
}

/// An error when any closed-loop mode grows.
pub fn check_stable(model: &AxisModel) -> Result<(), SimError> {
    let Some(eigenvalues) = closed_loop_eigenvalues(model) else {
        return Err(SimError::NoModes);
    };
    let modes = modal_figures(&eigenvalues);
    let worst = modes
        .iter()
        .max_by(|a, b| a.real_per_s.total_cmp(&b.real_per_s));
    match worst {
        Some(m) if m.real_per_s > 1e-9 * (1.0 + m.frequency_hz) => Err(SimError::Unstable {
            frequency_hz: m.frequency_hz,
            growth_per_s: m.real_per_s,
        }),
        _ => Ok(()),
    }
}

/// For a cascade axis whose setting is unstable: the largest position gain Kv (m/min/mm)
/// that is stable with every other setting held, found by bisection on the linear model
/// between a hundredth of a m/min/mm and the gain given; `None` for another controller, or
/// when even the smallest gain is unstable (the velocity or current loop is).
#[cfg(feature = "cli")]
pub(crate) fn largest_stable_kv(config: &crate::machine::AxisConfig) -> Option<f64> {
    if !config.controller.is_cascade() {
        return None;
    }
    let stable_at = |kv: f64| {
        let mut c = config.clone();
        c.position_loop.kv_m_per_min_per_mm = kv;
        check_stable(&AxisModel::from_config(&c)).is_ok()
    };
    let (mut lo, mut hi) = (0.01, config.position_loop.kv_m_per_min_per_mm);
    if !stable_at(lo) || stable_at(hi) {
        return None;
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if stable_at(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::MachineConfig;

    #[test]
    fn the_largest_stable_kv_is_the_edge_of_stability() {
        let mut x = MachineConfig::default_preset().x;
        x.position_loop.kv_m_per_min_per_mm = 2.0;
        let edge = largest_stable_kv(&x).unwrap();
        let stable = |kv: f64| {
            let mut c = x.clone();
            c.position_loop.kv_m_per_min_per_mm = kv;
            check_stable(&AxisModel::from_config(&c)).is_ok()
        };
        assert!(stable(0.999 * edge) && !stable(1.001 * edge), "{edge}");
        // The preset's Kv of 1 lies well inside; a stable setting has no edge to report.
        assert!(edge > 1.2 && edge < 2.0, "{edge}");
        assert_eq!(largest_stable_kv(&MachineConfig::default_preset().x), None);
    }

    #[test]
    fn an_axis_with_a_setting_that_is_not_a_number_is_refused_at_once() {
        // Inside a fit a candidate can come out NaN; the eigen-solver would spin on it for ever.
        let mut x = MachineConfig::default_preset().x;
        x.position_loop.kv_m_per_min_per_mm = f64::NAN;
        let model = AxisModel::from_config(&x);
        assert!(matches!(check_stable(&model), Err(SimError::NoModes)));
        assert!(closed_loop_modes(&model).is_empty());
    }
}
