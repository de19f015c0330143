//! Gain and parameter sweeps: one program, a grid of machine settings, the contour error
//! of each and what dominates it — ranked, with unstable settings flagged rather than
//! measured and settings short of the usual stability margins ([`health`]) ranked after
//! every healthy one.
//!
//! Any numeric machine key can be swept by name (`x.drive.backlash_um`, or its leaf
//! `x.backlash_um`); values are set through the machine's key table and each setting is
//! validated as a machine file is. Every grid point is an independent, pure
//! run of [`crate::check`], so the grid runs in parallel and gives the same results as a
//! serial run.

pub mod dominant;
pub mod health;

use rayon::prelude::*;
use serde::Serialize;

use crate::check::{CheckRun, CheckSettings, check};
use crate::gcode::Program;
use crate::machine::{AxisName, ConfigError, MachineConfig, keys};
use crate::numeric::units::um_from_m;
use crate::plan::PlanConfig;
use crate::sim::linear;
use crate::sim::{AxisModel, SimError};

pub use dominant::Dominant;
pub use health::{Flag, Health, POOR_DAMPING, Thresholds};

/// One swept dimension: a name for tables, the keys it sets (one per axis it applies to)
/// and its values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Dimension {
    /// Column name, e.g. `x.kv` or `xy.backlash_um`.
    pub name: String,
    /// Full dotted machine keys set to the value.
    pub keys: Vec<String>,
    /// Values in machine-file units.
    pub values: Vec<f64>,
}

/// What is wrong with a sweep's key or values as the user wrote them.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SweepInputError {
    /// A value that does not read as a number.
    #[error("'{0}' is not a number")]
    NotANumber(String),
    /// A range that is not `from:to:step` with from ≤ to and a positive step, or too long.
    #[error("'{text}': {problem}")]
    BadRange {
        /// The range as written.
        text: String,
        /// What is wrong.
        problem: &'static str,
    },
    /// A key without its axis.
    #[error("'{0}': name a key as axis.key, e.g. x.backlash_um")]
    NoAxis(String),
    /// A key no machine has.
    #[error(
        "'{key}': no numeric key of that name in a machine (docs/machine-keys.md lists them){hint}"
    )]
    UnknownKey {
        /// The key as written.
        key: String,
        /// " — did you mean `…`?", or empty.
        hint: String,
    },
    /// A leaf that names several keys of the axis.
    #[error("'{key}' is ambiguous: {}", .candidates.join(", "))]
    Ambiguous {
        /// The key as written.
        key: String,
        /// The full keys it could be.
        candidates: Vec<String>,
    },
    /// A key this machine cannot take: its section is absent or its controller does not
    /// read it.
    #[error("'{key}' {reason}")]
    NotSettable {
        /// The full key.
        key: String,
        /// Why.
        reason: keys::SetError,
    },
}

/// Parses `a:b:step`, `a,b,c` or a single number.
pub fn parse_range(text: &str) -> Result<Vec<f64>, SweepInputError> {
    let num = |s: &str| {
        s.trim()
            .parse::<f64>()
            .map_err(|_| SweepInputError::NotANumber(s.to_string()))
    };
    let bad = |problem| SweepInputError::BadRange {
        text: text.to_string(),
        problem,
    };
    let values = if let Some((from, rest)) = text.split_once(':') {
        let (to, step) = rest
            .split_once(':')
            .ok_or_else(|| bad("a range is from:to:step"))?;
        let (a, b, s) = (num(from)?, num(to)?, num(step)?);
        if !(s > 0.0 && s.is_finite()) || b < a {
            return Err(bad("needs from ≤ to and a positive step"));
        }
        let n = ((b - a) / s + 1e-9).floor() as usize;
        if n > 10_000 {
            return Err(bad("more than 10000 values"));
        }
        // Snapped to the step's decimals, so that 0.7 + 5 × 0.1 reads 1.2.
        let decimals = 10f64.powi(12 - s.abs().log10().floor() as i32).min(1e15);
        (0..=n)
            .map(|i| ((a + s * i as f64) * decimals).round() / decimals)
            .collect()
    } else {
        text.split(',').map(num).collect::<Result<Vec<_>, _>>()?
    };
    if values.iter().any(|v| !v.is_finite()) {
        return Err(bad("values must be finite"));
    }
    Ok(values)
}

/// Resolves `axis.key` to a full dotted key of the machine's key table
/// ([`crate::machine::keys`]): either already full (`x.drive.backlash_um`) or a leaf unique
/// within the axis (`x.backlash_um`). A key the machine does not have, or whose axis's
/// controller does not read it, is refused with what was likely meant.
pub fn resolve_key(machine: &MachineConfig, key: &str) -> Result<String, SweepInputError> {
    let mut paths = keys::machine_paths();
    if machine.z.simulated().is_some() {
        paths.extend(keys::AXIS_KEYS.iter().map(|k| format!("z.{}", k.path)));
    }
    let (part, leaf) = key
        .split_once('.')
        .ok_or_else(|| SweepInputError::NoAxis(key.to_string()))?;
    let full = if paths.iter().any(|p| p == key) {
        key.to_string()
    } else {
        let found: Vec<&String> = paths
            .iter()
            .filter(|p| {
                p.strip_prefix(part)
                    .and_then(|r| r.strip_prefix('.'))
                    .is_some_and(|r| r.rsplit('.').next() == Some(leaf))
            })
            .collect();
        match found.as_slice() {
            [one] => one.to_string(),
            [] => {
                let hint = paths
                    .iter()
                    .map(|p| (strsim::jaro_winkler(p, key), p))
                    .max_by(|a, b| a.0.total_cmp(&b.0))
                    .filter(|(score, _)| *score > 0.85)
                    .map(|(_, p)| format!(" — did you mean `{p}`?"))
                    .unwrap_or_default();
                return Err(SweepInputError::UnknownKey {
                    key: key.to_string(),
                    hint,
                });
            }
            many => {
                return Err(SweepInputError::Ambiguous {
                    key: key.to_string(),
                    candidates: many.iter().map(|s| s.to_string()).collect(),
                });
            }
        }
    };
    // Refused here rather than at every grid point.
    let mut probe = machine.clone();
    let value = keys::get_on_machine(machine, &full).unwrap_or(1.0);
    keys::set_on_machine(&mut probe, &full, value).map_err(|reason| {
        SweepInputError::NotSettable {
            key: full.clone(),
            reason,
        }
    })?;
    Ok(full)
}

/// The machine with `keys` set to `value`, validated as a machine file is.
pub(crate) fn with_values(
    machine: &MachineConfig,
    settings: &[(&[String], f64)],
) -> Result<MachineConfig, ConfigError> {
    let mut m = machine.clone();
    for (keys, value) in settings {
        for key in keys.iter() {
            keys::set_on_machine(&mut m, key, *value).map_err(|e| ConfigError::Invalid {
                file: "<sweep>".into(),
                key: key.clone(),
                problem: e.to_string(),
            })?;
        }
    }
    m.validate("<sweep>")?;
    Ok(m)
}

/// What one setting gave.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum PointResult {
    /// Simulated; flagged where its loops fall short of the thresholds.
    Ok {
        /// Figures.
        metrics: Metrics,
        /// Each loop's margins and the least damping of the modes the loops act on.
        health: Health,
        /// What falls short of the thresholds (empty: a healthy setting).
        flags: Vec<Flag>,
        /// What dominates the largest contour error.
        dominant: Dominant,
    },
    /// A closed-loop mode grows: no numbers.
    Unstable {
        /// Axis.
        axis: AxisName,
        /// The growing mode's frequency (Hz).
        frequency_hz: f64,
    },
    /// The setting is not a valid machine, or the simulation failed.
    Invalid {
        /// Why.
        reason: String,
    },
}

impl PointResult {
    /// Whether the setting was simulated and meets every threshold.
    pub fn is_healthy(&self) -> bool {
        matches!(self, PointResult::Ok { flags, .. } if flags.is_empty())
    }
}

/// Figures of a setting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Metrics {
    /// Largest |contour error| while cutting (µm).
    pub max_contour_um: f64,
    /// RMS contour error while cutting (µm).
    pub rms_contour_um: f64,
    /// Largest |following error| of X and Y while cutting (µm).
    pub max_following_um: [f64; 2],
    /// Largest run past the commanded position against the last direction of motion (µm).
    pub overshoot_um: f64,
    /// RMS of the contour error's departure from its own 1/Kv moving average (µm): ringing.
    pub ripple_um: f64,
}

/// One grid point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepPoint {
    /// Values of the dimensions, in order.
    pub values: Vec<f64>,
    /// Outcome.
    pub result: PointResult,
}

impl SweepPoint {
    /// The ranking key: healthy settings by their largest contour error, then the flagged
    /// ones by theirs, then the unstable and invalid ones.
    pub(crate) fn rank_key(&self) -> (u8, f64) {
        match &self.result {
            PointResult::Ok { metrics, flags, .. } if flags.is_empty() => {
                (0, metrics.max_contour_um)
            }
            PointResult::Ok { metrics, .. } => (1, metrics.max_contour_um),
            _ => (2, f64::INFINITY),
        }
    }
}

/// Flags the settings that fall short of `thresholds` (any loop's phase or gain margin,
/// the least damping of the modes of the loops' making) and ranks every setting by
/// [`SweepPoint::rank_key`]: no flagged setting is ever ranked before a healthy one.
pub fn rank(points: &mut [SweepPoint], thresholds: &Thresholds) {
    for p in points.iter_mut() {
        if let PointResult::Ok { health, flags, .. } = &mut p.result {
            *flags = health.flags(thresholds);
        }
    }
    points.sort_by(|a, b| {
        let (ta, ea) = a.rank_key();
        let (tb, eb) = b.rank_key();
        ta.cmp(&tb).then(ea.total_cmp(&eb))
    });
}

/// Where no setting meets the thresholds, what every simulated setting falls short in alike
/// (the same loop of the same axis, by the same figure): an axis the sweep leaves as it is,
/// short of its margins, makes every row short, and no setting of the other axis mends it.
/// `None` where a setting is healthy or none was simulated.
pub fn shared_shortfall(points: &[SweepPoint]) -> Option<Vec<Flag>> {
    let mut flagged = points.iter().filter_map(|p| match &p.result {
        PointResult::Ok { flags, .. } => Some(flags),
        _ => None,
    });
    let first = flagged.next()?;
    let mut shared = first.clone();
    for flags in flagged {
        if flags.is_empty() {
            return None;
        }
        shared.retain(|f| flags.contains(f));
    }
    (!first.is_empty()).then_some(shared)
}

/// Every combination of the dimensions' values (the first dimension varies slowest).
pub(crate) fn grid(dims: &[Dimension]) -> Vec<Vec<f64>> {
    dims.iter().fold(vec![Vec::new()], |acc, d| {
        acc.iter()
            .flat_map(|prefix| {
                d.values
                    .iter()
                    .map(move |v| [prefix.clone(), vec![*v]].concat())
            })
            .collect()
    })
}

/// Runs the grid, in parallel when `parallel`, calling `done` after each point.
pub fn run(
    program: &Program,
    machine: &MachineConfig,
    plan: &PlanConfig,
    dims: &[Dimension],
    parallel: bool,
    done: &(dyn Fn() + Sync),
) -> Vec<SweepPoint> {
    let points = grid(dims);
    let cache = health::AxisCache::default();
    let one = |values: &Vec<f64>| {
        let r = run_point(program, machine, plan, dims, values, &cache);
        done();
        SweepPoint {
            values: values.clone(),
            result: r,
        }
    };
    if parallel {
        points.par_iter().map(one).collect()
    } else {
        points.iter().map(one).collect()
    }
}

fn run_point(
    program: &Program,
    base: &MachineConfig,
    plan: &PlanConfig,
    dims: &[Dimension],
    values: &[f64],
    cache: &health::AxisCache,
) -> PointResult {
    let settings: Vec<(&[String], f64)> = dims
        .iter()
        .zip(values)
        .map(|(d, v)| (d.keys.as_slice(), *v))
        .collect();
    let machine = match with_values(base, &settings) {
        Ok(m) => m,
        Err(e) => {
            return PointResult::Invalid {
                reason: e.to_string(),
            };
        }
    };
    for axis in machine.simulated_axes() {
        let model = AxisModel::from_config(machine.axis(axis));
        if let Err(SimError::Unstable { frequency_hz, .. }) = linear::check_stable(&model) {
            return PointResult::Unstable { axis, frequency_hz };
        }
    }
    let health = health::health_with(&machine, cache);
    let mut settings = CheckSettings::for_machine(&machine);
    settings.plan = plan_of_setting(plan, base, &machine);
    match check(program, &machine, &settings) {
        Ok(run) => {
            let kv = linear::equivalent_kv_per_s(&AxisModel::from_config(&machine.x));
            let metrics = metrics(&run, kv);
            let rerun = |m: &MachineConfig| {
                let mut s = CheckSettings::for_machine(m);
                s.plan = settings.plan;
                check(program, m, &s)
                    .ok()
                    .map(|r| um_from_m(r.result.summary.max_contour_error_m))
            };
            PointResult::Ok {
                dominant: dominant::dominant(&run, &metrics, &machine, &rerun),
                metrics,
                flags: health.flags(&Thresholds::default()),
                health,
            }
        }
        Err(e) if let SimError::Unstable { frequency_hz, .. } = *e.innermost() => {
            PointResult::Unstable {
                axis: match &e {
                    SimError::OnAxis { axis: 'Y', .. } => AxisName::Y,
                    SimError::OnAxis { axis: 'Z', .. } => AxisName::Z,
                    _ => AxisName::X,
                },
                frequency_hz,
            }
        }
        Err(e) => PointResult::Invalid {
            reason: e.to_string(),
        },
    }
}

/// The planner settings of one setting: its own machine's — a swept key may change the
/// interpolation cycle, the path's limits, the arcs' share or the in-position check — with
/// what the caller chose over the base machine's (`chosen` differing from the base's own)
/// kept. Planned with the base's, a sweep of `interpolation.cycle_ms` gave one figure for
/// every cycle.
fn plan_of_setting(
    chosen: &PlanConfig,
    base: &MachineConfig,
    machine: &MachineConfig,
) -> PlanConfig {
    let (base_own, own) = (
        PlanConfig::for_machine(base),
        PlanConfig::for_machine(machine),
    );
    fn kept<T: PartialEq>(chosen: T, base_own: T, own: T) -> T {
        if chosen != base_own { chosen } else { own }
    }
    PlanConfig {
        profile: chosen.profile,
        cycle_s: kept(chosen.cycle_s, base_own.cycle_s, own.cycle_s),
        default_blend_tolerance_m: chosen.default_blend_tolerance_m,
        arc_normal_share: kept(
            chosen.arc_normal_share,
            base_own.arc_normal_share,
            own.arc_normal_share,
        ),
        path_dynamics: kept(
            chosen.path_dynamics,
            base_own.path_dynamics,
            own.path_dynamics,
        ),
        in_position: own.in_position,
    }
}

/// The figures of a run.
pub(crate) fn metrics(run: &CheckRun, kv_per_s: f64) -> Metrics {
    let s = &run.result.summary;
    Metrics {
        max_contour_um: um_from_m(s.max_contour_error_m),
        rms_contour_um: um_from_m(s.rms_contour_error_m),
        max_following_um: s.max_following_error_cutting_m.map(um_from_m),
        overshoot_um: um_from_m(overshoot_m(run)),
        ripple_um: um_from_m(ripple_m(
            &run.contour.error_m,
            (1.0 / (kv_per_s * run.commands.dt_s)).round() as usize,
        )),
    }
}

/// The largest distance either axis runs past a point where its command stands still, in
/// the direction it was travelling (a reversal without standstill is not an overshoot: the
/// axis simply has not reached the turning point yet).
fn overshoot_m(run: &CheckRun) -> f64 {
    let mut worst = 0.0f64;
    for (trace, cmd) in [(&run.x, &run.commands.x), (&run.y, &run.commands.y)] {
        let mut direction = 0.0;
        for k in 0..trace.len() {
            let (v, a) = (cmd.vel_m_per_s[k], cmd.acc_m_per_s2[k]);
            if v.abs() > 1e-12 || a.abs() > 1e-12 {
                if v.abs() > 1e-12 {
                    direction = v.signum();
                }
                continue;
            }
            worst = worst.max(direction * (trace.pos_m[k] - trace.ref_m[k]));
        }
    }
    worst
}

/// RMS of the departure from a centred moving average of `window` samples, over the
/// stretches of finite values.
fn ripple_m(e: &[f64], window: usize) -> f64 {
    let half = (window / 2).max(1);
    let (mut sum, mut n) = (0.0, 0usize);
    for run in e.split(|x| !x.is_finite()).filter(|r| r.len() > 2 * half) {
        let mut prefix = vec![0.0; run.len() + 1];
        for (i, x) in run.iter().enumerate() {
            prefix[i + 1] = prefix[i] + x;
        }
        for i in half..run.len() - half {
            let mean = (prefix[i + half + 1] - prefix[i - half]) / (2 * half + 1) as f64;
            sum += (run[i] - mean).powi(2);
            n += 1;
        }
    }
    if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_grids() {
        let kv = parse_range("0.7:1.2:0.1").unwrap();
        assert_eq!(kv.len(), 6);
        assert_eq!(kv[5], 1.2);
        assert_eq!(parse_range("12,16,20").unwrap(), vec![12.0, 16.0, 20.0]);
        assert!(parse_range("1:0:1").is_err());
        let dims = [
            Dimension {
                name: "a".into(),
                keys: vec![],
                values: vec![1.0, 2.0],
            },
            Dimension {
                name: "b".into(),
                keys: vec![],
                values: vec![3.0, 4.0, 5.0],
            },
        ];
        let g = grid(&dims);
        assert_eq!(g.len(), 6);
        assert_eq!(g[0], vec![1.0, 3.0]);
        assert_eq!(g[5], vec![2.0, 5.0]);
    }

    #[test]
    fn keys_resolve_by_leaf_and_values_are_validated() {
        let m = MachineConfig::default_preset();
        assert_eq!(
            resolve_key(&m, "x.backlash_um").unwrap(),
            "x.drive.backlash_um"
        );
        assert_eq!(
            resolve_key(&m, "y.velocity_loop.ks_nm_s_per_rad").unwrap(),
            "y.velocity_loop.ks_nm_s_per_rad"
        );
        assert!(resolve_key(&m, "x.nonsense").is_err());
        let keys = vec!["x.drive.backlash_um".to_string()];
        let changed = with_values(&m, &[(&keys, 7.5)]).unwrap();
        assert_eq!(changed.x.drive.backlash_um, 7.5);
        let e = with_values(&m, &[(&keys, -1.0)]).unwrap_err();
        assert!(e.to_string().contains("x.drive.backlash_um"));
    }

    #[test]
    fn ripple_sees_oscillation_not_offset() {
        let steady = vec![5.0; 200];
        assert!(ripple_m(&steady, 20) < 1e-12);
        let wavy: Vec<f64> = (0..400).map(|i| 5.0 + (i as f64 * 0.9).sin()).collect();
        let r = ripple_m(&wavy, 20);
        assert!((r - 0.5f64.sqrt()).abs() < 0.1, "{r}");
    }
}
