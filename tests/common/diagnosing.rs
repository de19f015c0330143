//! Diagnosing what a user hands over: a record of the nominal machine with one cause hidden,
//! written as a measurement would be and read back from its CSV text, against the program
//! and the nominal machine; and the checks that the cause was found.

use std::path::{Path, PathBuf};

use super::assert_within_k_sigma;
use super::sample_program as program;
use contourcheck::diagnose::causes::CauseId;
use contourcheck::diagnose::synth::{SynthSpec, synthesize};
use contourcheck::diagnose::{AxisResidual, DiagnoseSettings, Diagnosis, diagnose};
use contourcheck::gcode::Program;
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::{MeasuredTrace, parse_trace};

pub fn sample_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("gcode-samples")
        .join(name)
}

/// `measured` of `prog` diagnosed against the nominal machine with the default settings.
pub fn diagnose_nominal(prog: &Program, measured: &MeasuredTrace) -> Diagnosis {
    let nominal = MachineConfig::default_preset();
    diagnose(
        prog,
        &nominal,
        measured,
        &DiagnoseSettings::for_machine(&nominal),
    )
    .unwrap()
}

/// Hides `effect` in the nominal machine, runs `name`, measures it and diagnoses the CSV.
/// What a user would hand over: `program` run on `machine` with `spec`, written as CSV and
/// read back as the trace file `name`.
pub fn recorded(
    program: &Program,
    machine: &MachineConfig,
    spec: &SynthSpec,
    name: &str,
) -> MeasuredTrace {
    let mut csv = Vec::new();
    synthesize(program, machine, spec)
        .unwrap()
        .write_csv(&mut csv)
        .unwrap();
    parse_trace(std::str::from_utf8(&csv).unwrap(), name).unwrap()
}

pub fn diagnose_hidden(
    name: &str,
    effect: Option<(CauseId, AxisName, Vec<f64>)>,
    seed: u64,
) -> Diagnosis {
    let nominal = MachineConfig::default_preset();
    let prog = program(name);
    // An offset off the sampling grid, different per test.
    let spec = SynthSpec {
        effect,
        offset_s: 0.3 + 0.0137 * seed as f64,
        seed,
        ..SynthSpec::default()
    };
    let measured = recorded(&prog, &nominal, &spec, "measured.csv");
    let d = diagnose_nominal(&prog, &measured);
    assert!(
        (d.offset_s - spec.offset_s).abs() < 1e-3,
        "clock offset {} vs {}",
        d.offset_s,
        spec.offset_s
    );
    d
}

/// The residual measure that sees a cause.
pub fn measure(cause: CauseId, r: &AxisResidual) -> f64 {
    match cause {
        CauseId::Backlash | CauseId::CoulombFriction | CauseId::Resonance => r.event_rms_um,
        CauseId::Stribeck => r.chatter_um,
        _ => r.rms_um,
    }
}

pub fn assert_found(
    name: &str,
    cause: CauseId,
    axis: AxisName,
    hidden: &[f64],
    seed: u64,
) -> Diagnosis {
    let d = diagnose_hidden(name, Some((cause, axis, hidden.to_vec())), seed);
    let named: Vec<(CauseId, AxisName)> = d.causes.iter().map(|c| (c.id, c.axis)).collect();
    assert_eq!(
        named,
        vec![(cause, axis)],
        "{name}: {cause:?} on {axis}; not named: {:?}",
        d.rejected
            .iter()
            .map(|r| (r.id, r.axis, r.reason.as_str()))
            .collect::<Vec<_>>()
    );
    let found = &d.causes[0];
    for (p, &truth) in found.params.iter().zip(hidden) {
        assert!(
            (p.value - truth).abs() <= 0.25 * truth.abs(),
            "{name}: {} = {} ± {}, hidden {truth}",
            p.key,
            p.value,
            p.uncertainty
        );
        assert!(
            p.uncertainty.is_finite() && p.uncertainty > 0.0,
            "{}: uncertainty {}",
            p.key,
            p.uncertainty
        );
        // An honest uncertainty covers the hidden value.
        let what = format!("{name}: {}", p.key);
        assert_within_k_sigma(&what, truth, p.value, p.uncertainty, 4.0);
    }
    let (before, after) = (measure(cause, &found.before), measure(cause, &found.after));
    assert!(
        after <= 0.5 * before || after <= 1.2 * d.noise_floor_um,
        "{name}: {cause:?} residual {before:.3} → {after:.3} µm, noise {:.3} µm",
        d.noise_floor_um
    );
    // The noise floor the diagnosis estimated is the noise that was added.
    assert!(
        (d.noise_floor_um - 0.3).abs() < 0.06,
        "noise floor {}",
        d.noise_floor_um
    );
    d
}
