//! The last check on an axis's values before they are written: that they run the whole
//! record. The searches stop a simulation after the last sample they read, so a
//! configuration that diverges or chatters later (in a hold the fits leave out) reaches them
//! as one that runs; run once more over all of it, it shows itself.

use super::{AxisIdentification, unfitted};
use crate::compare::{CompareSettings, Comparison, Context, Stepping, compare};
use crate::gcode::Program;
use crate::identify::solve::Fit;
use crate::machine::{AxisConfig, AxisName, MachineConfig};
use crate::numeric::units::um_from_m;
use crate::trace::measured::MeasuredTrace;

/// How far the file's figure may lie from the fit's before it is said beside it: a
/// twentieth, the margin every figure of the identification is compared by.
const SAID_BESIDE: f64 = 0.05;

/// `found` where its configuration runs the whole record; else the template's values, as an
/// axis the search could not fit (none where even the template cannot be simulated).
pub(super) fn runs_whole_record(
    ctx: &Context,
    template: &MachineConfig,
    axis: AxisName,
    offset: f64,
    found: (AxisConfig, AxisIdentification),
) -> Option<(AxisConfig, AxisIdentification)> {
    let mut machine = template.clone();
    *machine.axis_mut(axis) = found.0.clone();
    if ctx.simulate_axis(&machine, axis).is_some() {
        return Some(found);
    }
    unfitted(Fit::new(ctx, template, axis, offset), template.axis(axis))
}

/// Sets each fitted axis's `file_rms_um`: `machine` — the file as written — run on `measured`
/// as `diagnose` runs a machine file on it (compared afresh with it: its own hunting holds
/// left out, every other sample compared, no force held at the start), where that residual
/// lies more than [`SAID_BESIDE`] from the fit's own figure. The fit's figures may be on
/// other samples (while moving) or hold a force at the start the file cannot: a user runs
/// the file, and its figure is the one they will see.
pub(super) fn file_figures(
    program: &Program,
    machine: &MachineConfig,
    measured: &MeasuredTrace,
    settings: &CompareSettings,
    axes: &mut [AxisIdentification],
) {
    let Ok(Comparison {
        ctx,
        offset_s,
        nominal,
        ..
    }) = compare(program, machine, measured, settings, Stepping::Full)
    else {
        return;
    };
    let fitted = |a: &&mut AxisIdentification| a.too_little.is_none() && a.axis != AxisName::Z;
    for a in axes.iter_mut().filter(fitted) {
        let residual = ctx.residual(a.axis, &nominal[a.axis.index()], offset_s);
        let compared: Vec<f64> = (0..residual.len())
            .filter(|&k| ctx.compared(a.axis, k))
            .map(|k| residual[k])
            .collect();
        if compared.is_empty() {
            continue;
        }
        let file_um = um_from_m(crate::compare::residual::rms(&compared));
        let apart = (file_um - a.rms_identified_um).abs() > SAID_BESIDE * a.rms_identified_um;
        a.file_rms_um = (file_um.is_finite() && apart).then_some(file_um);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{CheckSettings, check};
    use crate::compare::{CompareSettings, Stepping, compare};
    use crate::gcode::{InterpretOptions, parse_program};
    use crate::plan::InPosition;
    use crate::sim::{AxisModel, SimError, simulate};
    use crate::trace::measured::parse_trace;

    /// The nominal machine's own X and Y on a line out and back, sampled every 2 ms from
    /// 0.5 s on the record's clock, written as a user's CSV.
    fn record_of(machine: &MachineConfig, program: &crate::gcode::Program) -> String {
        let run = check(program, machine, &CheckSettings::for_machine(machine)).unwrap();
        let step = (2e-3 / run.x.dt_s).round().max(1.0) as usize;
        let mut csv = String::from("t_s,x_mm,y_mm\n");
        for k in (0..run.x.pos_m.len().min(run.y.pos_m.len())).step_by(step) {
            let t_s = 0.5 + k as f64 * run.x.dt_s;
            let (x_mm, y_mm) = (run.x.pos_m[k] * 1e3, run.y.pos_m[k] * 1e3);
            csv.push_str(&format!("{t_s:.6},{x_mm:.7},{y_mm:.7}\n"));
        }
        csv
    }

    /// That `unstable` (axis `axis` of `template` with its velocity loop's gain negated) is
    /// refused by the simulation itself. Its position gain stays the template's, so the
    /// in-position waits, and with them the commands the record is simulated on, stay those
    /// of the plan the context was built on (no other plan is made for these values): the
    /// only step that can refuse them is the simulation on those commands, and it does so
    /// before its first step, as a loop with a growing mode. The rigid drive's speed grows as
    /// e^(s·t) with J·s² = K_s·s + K_s/T_s (the PI loop of gain K_s on the whole inertia J,
    /// the current loop taken as instant): from the template's K_s = 16 N·m·s/rad, T_s =
    /// 10 ms and J = 0.0246 kg·m², s = 740 /s. The current loop's lag can only slow that
    /// growth; the band asserted, down to half K_s/J (326 /s), is loose enough for any lag
    /// of a current loop far faster than the velocity loop, and excludes the position
    /// loop's own modes (tens per second).
    fn assert_refused_by_the_simulation(
        ctx: &Context,
        template: &MachineConfig,
        axis: AxisName,
        unstable: &AxisConfig,
    ) {
        let mut machine = template.clone();
        *machine.axis_mut(axis) = unstable.clone();
        assert_eq!(
            InPosition::kv_per_s_of_cascades(&machine),
            InPosition::kv_per_s_of_cascades(template)
        );
        let d = &unstable.drive;
        let r_m_per_rad = d.lead_mm * 1e-3 / std::f64::consts::TAU * d.gear_ratio;
        let j = unstable.motor.jm_kg_m2
            + d.gear_ratio.powi(2) * d.js_kg_m2
            + r_m_per_rad.powi(2) * d.table_mass_kg;
        let velocity = template.axis(axis).velocity_loop.as_ref().unwrap();
        let (ks, ts) = (velocity.ks_nm_s_per_rad, velocity.ts_ms * 1e-3);
        let rigid = (ks + (ks * ks + 4.0 * j * ks / ts).sqrt()) / (2.0 * j);
        let on = |c: &AxisConfig| {
            let model = AxisModel::from_config(c);
            simulate(&model, ctx.commands.axis(axis), ctx.dt, &ctx.sim)
        };
        match on(unstable) {
            Err(SimError::Unstable { growth_per_s, .. }) => assert!(
                growth_per_s > 0.5 * ks / j && growth_per_s < 1.1 * rigid,
                "{growth_per_s} /s against K_s/J = {} and {rigid} /s",
                ks / j
            ),
            other => panic!("not refused as unstable: {other:?}"),
        }
        assert!(on(template.axis(axis)).is_ok());
        // And the context's own simulation of the axis, the call `runs_whole_record` makes,
        // refuses the same values.
        assert!(ctx.simulate_axis(&machine, axis).is_none());
    }

    #[test]
    fn values_that_run_are_kept_and_values_the_simulation_refuses_give_the_template_back() {
        let template = MachineConfig::default_preset();
        let text = "G21 G90 G17 G94\nG0 X0 Y0\nG1 X20 Y10 F1000\nG1 X0 Y0\nM2\n";
        let program = parse_program(text, "line.nc", &InterpretOptions::default()).unwrap();
        let measured = parse_trace(&record_of(&template, &program), "line.csv").unwrap();
        let settings = CompareSettings::for_machine(&template);
        let comparison = compare(&program, &template, &measured, &settings, Stepping::Full);
        let comparison = comparison.unwrap();
        let (ctx, offset) = (&comparison.ctx, comparison.offset_s);
        let axis = AxisName::X;
        // A position gain a tenth lower: a stable loop, which runs any record. What was found
        // comes back as it was, its figures too.
        let mut slower = template.axis(axis).clone();
        slower.position_loop.kv_m_per_min_per_mm *= 0.9;
        let marker = AxisIdentification::scored(0.5, 0.06);
        let kept = runs_whole_record(ctx, &template, axis, offset, (slower.clone(), marker));
        let (config, identification) = kept.expect("a stable loop runs");
        assert_eq!(config, slower);
        assert_eq!(identification, AxisIdentification::scored(0.5, 0.06));
        // The velocity loop's gain negated: the speed error is fed back with its sign and
        // drives the motor faster. The simulation refuses these values on the context's own
        // commands (`assert_refused_by_the_simulation`).
        let mut unstable = template.axis(axis).clone();
        let velocity = unstable.velocity_loop.as_mut().unwrap();
        velocity.ks_nm_s_per_rad = -velocity.ks_nm_s_per_rad;
        assert_refused_by_the_simulation(ctx, &template, axis, &unstable);
        // Those values cannot be written: the template's are, as an axis not fitted — each
        // value the template's, none determined.
        let marker = AxisIdentification::scored(0.5, 0.06);
        let back = runs_whole_record(ctx, &template, axis, offset, (unstable, marker));
        let (config, identification) = back.expect("the template runs");
        assert_eq!(&config, template.axis(axis));
        assert_eq!(identification.axis, axis);
        assert!(!identification.reached && !identification.values.is_empty());
        for v in &identification.values {
            assert!(
                v.value == v.template && !v.determined && !v.measured,
                "{v:?}"
            );
        }
    }
}
