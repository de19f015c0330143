//! Tests of the point-by-point fits.

use super::*;
use crate::compare::compare;
use crate::diagnose::DiagnoseSettings;
use crate::diagnose::synth::{SynthSpec, synthesize};
use crate::gcode::{InterpretOptions, Program, parse_program};
use crate::trace::measured::{MeasuredTrace, parse_trace};

/// Backlash on X delays X after every reversal, and the first alignment takes part of
/// that delay as the clock's. Judged at that alignment, a smaller gap that makes up for
/// it looked better than the true one, and once X's stuck stops are compared (where the
/// table rests in its gap depends on the gap's size in no monotone way) the fit could
/// not walk from there to the truth: 5 µm hidden came back as 3.0 µm. Each start judged
/// at its own best offset, the fit finds the hidden gap on the grid and off it, and the
/// clock the record was synthesised on.
#[test]
fn a_gap_whose_lag_pulled_the_alignment_off_is_fitted_from_its_own_clock() {
    let machine = MachineConfig::preset("small-table").unwrap();
    let text = include_str!("../../../gcode-samples/square.nc");
    let program = parse_program(text, "square.nc", &InterpretOptions::default()).unwrap();
    let settings = DiagnoseSettings::for_machine(&machine).compare;
    for hidden_um in [3.5, 5.0] {
        let spec = SynthSpec {
            effect: Some((CauseId::Backlash, AxisName::X, vec![hidden_um])),
            ..SynthSpec::default()
        };
        let mut csv = Vec::new();
        synthesize(&program, &machine, &spec)
            .unwrap()
            .write_csv(&mut csv)
            .unwrap();
        let measured = parse_trace(std::str::from_utf8(&csv).unwrap(), "square.csv").unwrap();
        let c = compare(&program, &machine, &measured, &settings, Stepping::Full).unwrap();
        // The fit's clock must come back within 2 µs of the synthesised one (0 s): the
        // noise pins it to about 0.16 µs (0.3 µm at 1000 mm/min is 18 µs a sample, over
        // some 12 000 moving samples). The premise: the first alignment is ten times
        // further off.
        let clock_tolerance_s = 2e-6;
        assert!(c.offset_s > 10.0 * clock_tolerance_s, "{}", c.offset_s);
        let ctx = Context {
            stepping: Stepping::PerCycleWhereExact,
            ..c.ctx.clone()
        };
        let grid = super::super::fit_starts::starts(CauseId::Backlash, vec![1.0], &[0.0]);
        let f = fit_cause(
            &ctx,
            &machine,
            AxisName::X,
            CauseId::Backlash,
            &grid,
            c.offset_s,
            &c.nominal[1],
        )
        .unwrap();
        let (got, sigma) = (f.values[0], f.sigma[0]);
        assert!(
            (got - hidden_um).abs() < 2.0 * sigma && sigma < 0.2 * hidden_um,
            "{hidden_um} µm hidden, {got} ± {sigma} µm fitted"
        );
        assert!(
            f.offset_s.abs() < clock_tolerance_s,
            "clock {} s",
            f.offset_s
        );
    }
}

#[test]
fn a_phase_found_beyond_a_turn_is_written_as_the_angle_it_means() {
    let params = CauseId::ForceRipple.params();
    // Amplitude, then phase: 400° is 40°, −190° is 170°, 180° stays, −180° is 180°.
    for (found, meant) in [
        (400.0, 40.0),
        (-190.0, 170.0),
        (180.0, 180.0),
        (-180.0, 180.0),
    ] {
        let mut values = vec![250.0, found];
        wrap_phases(params, &mut values);
        assert_eq!(values[0], 250.0, "the amplitude is not a phase");
        assert!(
            (values[1] - meant).abs() < 1e-9,
            "{found}° gave {}°",
            values[1]
        );
    }
}

/// A record of `text` on `machine`, written as CSV and read back as a user's file.
fn record(text: &str, machine: &MachineConfig) -> (Program, MeasuredTrace) {
    let program = parse_program(text, "line.nc", &InterpretOptions::default()).unwrap();
    let mut csv = Vec::new();
    synthesize(&program, machine, &SynthSpec::default())
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    let csv = String::from_utf8(csv).unwrap();
    (program, parse_trace(&csv, "line.csv").unwrap())
}

/// Two records of the same length and timing, lines in opposite directions: a fit's
/// simulation kept for the one is not what the other's context asks for at the same
/// stepping and values — the other record is simulated (each time: it is not kept), and
/// the fit's own simulation stays kept.
#[test]
fn a_kept_simulation_never_answers_for_another_record() {
    let machine = MachineConfig::default_preset();
    let settings = DiagnoseSettings::for_machine(&machine).compare;
    let line = |to: &str| format!("G21 G90 G17 G94\nG0 X0 Y0\nG1 {to} F1000\nM2\n");
    let (forward, forward_record) = record(&line("X20 Y10"), &machine);
    let (back, back_record) = record(&line("X-20 Y-10"), &machine);
    let a = compare(
        &forward,
        &machine,
        &forward_record,
        &settings,
        Stepping::Full,
    )
    .unwrap();
    let b = compare(&back, &machine, &back_record, &settings, Stepping::Full).unwrap();
    assert_eq!(a.nominal[1].len(), b.nominal[1].len());
    let (axis, cause, values) = (AxisName::X, CauseId::Backlash, [8.0]);
    let model = Model {
        ctx: &a.ctx,
        machine: &machine,
        axis,
        cause,
        other: &a.nominal[1],
        simulated: Simulated::default(),
    };
    let on_a = model.pair_on(&a.ctx, &values).unwrap();
    let on_b = model.pair_on(&b.ctx, &values).unwrap();
    let with = with_cause(&machine, axis, cause, &values);
    let (fresh_b, _) = b.ctx.simulate_pair(&with, axis, model.other).unwrap();
    assert_eq!(on_b.trace, fresh_b);
    assert_ne!(on_b.trace, on_a.trace);
    assert!(Arc::ptr_eq(&on_a, &model.pair_on(&a.ctx, &values).unwrap()));
    assert!(!Arc::ptr_eq(
        &on_b,
        &model.pair_on(&b.ctx, &values).unwrap()
    ));
}
