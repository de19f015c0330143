//! The SINUMERIK 840D control's own 50 Hz trace of a plate program's start, as a user brings
//! it: machine coordinates, a standstill at the machine's home, a rapid at 36 m/min from
//! there that the program does not describe (it blends into the program's second rapid),
//! a Z rapid down and the first tenth of a second of the first cutting block. The files
//! are not part of the repository: the tests read the folder `CONTOURCHECK_REAL_RECORDS`
//! names and say "skipped: real records not present" without it.
//!
//! What the tests know comes from the files themselves, not from the tool: where the
//! machine stood (the first row), when its commands first move and when the cutting block
//! begins (the commanded columns), and the work offset — where the first feed move's start
//! `X37.5 Y-5` stands in machine coordinates, the commands' standstill before that block.

use std::path::PathBuf;

use contourcheck::diagnose::{DiagnoseSettings, StartKind, diagnose};
use contourcheck::gcode::{InterpretOptions, Program, parse_program};
use contourcheck::identify::identify;
use contourcheck::machine::{AxisName, MachineConfig};
use contourcheck::trace::measured::{MeasuredTrace, read_trace};

const VARIABLE: &str = "CONTOURCHECK_REAL_RECORDS";
const PROGRAM: &str = "AL_2007_T4_Plate_Normal.mpf";
const TRACE: &str = "DMC_AL2007T4_Plate_Normal_Aircut_0.csv";

/// The folder of the 840D records, or `None` (after saying so) where this machine has none.
fn folder() -> Option<PathBuf> {
    use std::io::Write;
    let Some(dir) = std::env::var_os(VARIABLE) else {
        let _ = writeln!(
            std::io::stderr(),
            "skipped: real records not present ({VARIABLE} is not set)"
        );
        return None;
    };
    let dir = PathBuf::from(dir).join("kit-dmc-840d");
    assert!(
        dir.is_dir(),
        "{VARIABLE} names no folder with kit-dmc-840d/"
    );
    Some(dir)
}

/// The trace's own columns, read plainly: time, commanded X and Y (mm, machine coordinates).
fn commanded(dir: &std::path::Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(dir.join(TRACE)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, x, y) = (col("time"), col("cmd_pos_x"), col("cmd_pos_y"));
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect();
            [v[t], v[x], v[y]]
        })
        .collect()
}

/// The record's commanded Z (mm, machine coordinates) at each of its times (s), read plainly.
fn commanded_z(dir: &std::path::Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(dir.join(TRACE)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, z) = (col("time"), col("cmd_pos_z"));
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (v[t].parse().unwrap(), v[z].parse().unwrap())
        })
        .collect()
}

struct Facts {
    /// The work offset (mm): where `X37.5 Y-5` stands in machine coordinates.
    offset_mm: [f64; 2],
    /// Where the machine stood, in program coordinates (mm).
    home_mm: [f64; 2],
    /// When the commands first move, and when the cutting block's Y starts to move (s).
    first_move_s: f64,
    cut_starts_s: f64,
}

/// What the record's own columns say.
fn facts(dir: &std::path::Path) -> Facts {
    let rows = commanded(dir);
    let first = rows[0];
    let first_move = rows
        .iter()
        .find(|r| (r[1] - first[1]).abs() > 1e-3 || (r[2] - first[2]).abs() > 1e-3)
        .unwrap()[0];
    // The record ends in the cutting block `G1 Y10`: Y rises while X stands. Going back from
    // the end, the last row before Y began to rise is the block's start, X37.5 Y-5.
    let k = (1..rows.len())
        .rev()
        .find(|&k| rows[k][2] - rows[k - 1][2] < 1e-6)
        .unwrap();
    let standing = rows[k];
    let offset_mm = [standing[1] - 37.5, standing[2] + 5.0];
    Facts {
        offset_mm,
        home_mm: [first[1] - offset_mm[0], first[2] - offset_mm[1]],
        first_move_s: first_move,
        cut_starts_s: standing[0],
    }
}

fn program(dir: &std::path::Path) -> Program {
    let text = std::fs::read_to_string(dir.join(PROGRAM)).unwrap();
    parse_program(&text, PROGRAM, &InterpretOptions::default()).unwrap()
}

fn trace(dir: &std::path::Path, offset_mm: [f64; 2]) -> MeasuredTrace {
    read_trace(&dir.join(TRACE))
        .unwrap()
        .in_work_coordinates(offset_mm.map(|v| v * 1e-3))
}

/// The facts themselves, against the folder's README: home at machine X200 Y118.1, the
/// work offset puts the plate's corner a few hundred mm away from it.
fn assert_the_facts_are_the_readmes(f: &Facts) {
    assert!(
        f.first_move_s > 1.8 && f.first_move_s < 2.0,
        "{}",
        f.first_move_s
    );
    assert!(
        f.cut_starts_s > 3.1 && f.cut_starts_s < 3.3,
        "{}",
        f.cut_starts_s
    );
}

/// The lowest and highest Z of the file's `rows` (time s, Z mm) between `from_s` and `to_s`,
/// its ends read between rows (the record is read on a regular clock, so its ends fall
/// between the logger's rows).
fn z_span_of_rows(rows: &[(f64, f64)], from_s: f64, to_s: f64) -> (f64, f64) {
    let at = |t: f64| {
        let k = rows.iter().position(|r| r.0 >= t).unwrap().max(1);
        let ((t0, z0), (t1, z1)) = (rows[k - 1], rows[k]);
        z0 + (z1 - z0) * (t - t0) / (t1 - t0)
    };
    rows.iter()
        .filter(|&&(t, _)| t > from_s && t < to_s)
        .map(|&(_, z)| z)
        .chain([at(from_s), at(to_s)])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), z| {
            (l.min(z), h.max(z))
        })
}

/// The fastest Z speed (mm/min) between two of the file's `rows` inside `from_s`..`to_s`.
fn z_peak_speed_of_rows(rows: &[(f64, f64)], from_s: f64, to_s: f64) -> f64 {
    rows.windows(2)
        .filter(|w| w[0].0 > from_s && w[1].0 < to_s)
        .map(|w| ((w[1].1 - w[0].1) / (w[1].0 - w[0].0)).abs() * 60.0)
        .fold(0.0, f64::max)
}

#[test]
fn the_840d_trace_from_home_is_diagnosed_from_where_its_commands_join_the_program() {
    let Some(dir) = folder() else { return };
    let f = facts(&dir);
    assert_the_facts_are_the_readmes(&f);
    let nominal = MachineConfig::default_preset();
    let d = diagnose(
        &program(&dir),
        &nominal,
        &trace(&dir, f.offset_mm),
        &DiagnoseSettings::for_machine(&nominal),
    )
    .expect("diagnosed, not refused");
    let c = d.coverage;
    assert_eq!(c.start, StartKind::BeforeProgram, "{c:?}");
    let [hx, hy] = c.stood_at_mm.unwrap();
    assert!(
        (hx - f.home_mm[0]).abs() < 0.01 && (hy - f.home_mm[1]).abs() < 0.01,
        "{c:?}, home {:?}",
        f.home_mm
    );
    // The approach ends after the rapid from home began and before the cut: the commands
    // join the program where the rapids leave them standing at X37.5 Y-5.
    assert!(
        c.approach_s > f.first_move_s && c.approach_s < f.cut_starts_s,
        "{c:?}"
    );
    // The record ends in the first cutting block (line 17, `G1 Y10`), long before the
    // program does.
    assert_eq!(c.last_line, 17, "{c:?}");
    assert!(c.from_program_start && !c.to_program_end, "{c:?}");
    // Where the residual is largest is given on the record's clock, inside the stretch
    // compared (the model's own clock runs from the join, not the record's start).
    assert!(!d.places.is_empty(), "{c:?}");
    for p in &d.places {
        let t = p.t_record_s;
        assert!(
            t >= c.compared_from_s - 1e-9 && t <= c.compared_to_s + 1e-9,
            "{p:?}: {c:?}"
        );
    }
    // The 36 m/min rapid from home is beyond the nominal machine's 6 m/min, but the model
    // is not driven by it: what the model follows, from the join on (the end of the rapids
    // and a cut at F350), asks nothing beyond the machine file's limits.
    assert!(d.beyond_machine.is_empty(), "{:?}", d.beyond_machine);
    // Half a second after the approach, most of it standing, is too little to tell any cause
    // from how the machine came out of its approach: nothing is named.
    assert!(d.causes.is_empty(), "{:?}", d.causes);
    // Z comes down in the stretch compared (the Z rapid to the part): the record's own Z
    // columns are read, and the report says how far Z moved there, with the lowest and
    // highest commanded Z of the file's rows in that stretch.
    let [lo, hi] = c.z_span_mm.expect("the 840D trace has Z");
    let rows = commanded_z(&dir);
    let (file_lo, file_hi) = z_span_of_rows(&rows, c.compared_from_s, c.compared_to_s);
    assert!(
        (lo - file_lo).abs() < 0.01 && (hi - file_hi).abs() < 0.01,
        "{c:?}: file {file_lo}..{file_hi}"
    );
    assert!(hi - lo > 1.0, "{c:?}");
    let said = c.to_string();
    assert!(said.contains("Z: moves"), "{said}");
    // The preset simulates Z, so Z is compared; but that rapid runs faster than the
    // preset's Z rapid rate (4000 mm/min) by the file's own rows in the stretch, so the
    // model cannot follow it: the diagnosis says so and seeks no cause on Z.
    let file_peak_mm_per_min = z_peak_speed_of_rows(&rows, c.compared_from_s, c.compared_to_s);
    assert!(
        file_peak_mm_per_min > 1.05 * 4000.0,
        "{file_peak_mm_per_min}"
    );
    assert!(d.z.compared, "{:?}", d.z);
    let rapid =
        d.z.beyond_machine
            .iter()
            .find(|b| b.key == "limits.rapid_mm_per_min")
            .unwrap_or_else(|| panic!("{:?}", d.z));
    assert!(
        (rapid.recorded - file_peak_mm_per_min).abs() < 0.1 * file_peak_mm_per_min,
        "{rapid:?}, file {file_peak_mm_per_min}"
    );
    assert!(d.z.cause.is_none() && d.z.not_named.is_empty(), "{:?}", d.z);
}

#[test]
fn identify_on_the_840d_trace_writes_a_machine_and_says_what_it_cannot_determine() {
    let Some(dir) = folder() else { return };
    let f = facts(&dir);
    let template = MachineConfig::default_preset();
    let id = identify(
        &program(&dir),
        &template,
        &trace(&dir, f.offset_mm),
        &DiagnoseSettings::for_machine(&template).compare,
    )
    .expect("identified or said undetermined, not refused for the approach from home");
    assert_eq!(id.coverage.start, StartKind::BeforeProgram);
    for a in &id.axes {
        for v in &a.values {
            // A value the record does not determine is the template's, said so.
            if !v.fitted() {
                assert_eq!(v.value, v.template, "{:?} {}", a.axis, v.key);
            }
            assert!(v.value.is_finite(), "{:?} {}", a.axis, v.key);
        }
    }
    // The compared stretch is the cutting block's first 0.26 s at 50 Hz, less each axis's
    // run-in of 0.15 s: about five samples of a block in which X stands. Too few to fit
    // the preset's seven values on two halves (at least 28), so no axis is identified, and
    // none is said to reach the record's noise on the nothing it compared.
    for a in &id.axes {
        let why = a.too_little.as_deref().unwrap_or_else(|| panic!("{a:?}"));
        assert!(why.contains("fewer than the 28"), "{why}");
        assert!(!a.reached && !a.better_than_template, "{a:?}");
    }
    let written = id.machine.axis(AxisName::X);
    assert!(written.position_loop.kv_m_per_min_per_mm > 0.0);
    offset_told_where_not_given(&dir, &f);
    // Z: its compared stretch holds little more than its rapid to the part, which the
    // preset's Z cannot follow; none of its values is determined, and the template's Z is
    // what is written.
    let z = id.axes.iter().find(|a| a.axis == AxisName::Z);
    let z = z.unwrap_or_else(|| panic!("Z not fitted: {:?}", id.z_not_identified));
    assert!(!z.values.is_empty());
    for v in &z.values {
        assert!(!v.determined, "Z {} determined: {v:?}", v.key);
    }
    // But for its limits: the rapid's speed, counted as a rapid (the program's own G0 Z,
    // though the record's commands join the program's plane path while Z still comes
    // down), goes beyond the preset's Z rapid rate and is written in its place — within a
    // tenth of the fastest Z of the file's rows in the stretch (the peak is read through
    // ±30 ms of the 50 Hz rows, their one-row differences are not); Z has no feed move
    // there, so its feed limit stays the preset's.
    let c = &id.coverage;
    let rows = commanded_z(&dir);
    let file_peak = z_peak_speed_of_rows(&rows, c.compared_from_s, c.compared_to_s);
    let i = &id.interpolator;
    let k = i
        .axes
        .iter()
        .position(|&a| a == AxisName::Z)
        .expect("Z read");
    assert!(
        (i.rapid_mm_per_min[k] - file_peak).abs() < 0.1 * file_peak && i.feed_mm_per_min[k] == 0.0,
        "{i:?}, file {file_peak}"
    );
    let (written, preset) = (id.machine.axis(AxisName::Z), template.axis(AxisName::Z));
    assert!(
        written.limits.rapid_mm_per_min >= i.rapid_mm_per_min[k],
        "{written:?}"
    );
    assert_eq!(
        written.limits.max_feed_mm_per_min,
        preset.limits.max_feed_mm_per_min
    );
    let mut but_limits = written.clone();
    but_limits.limits = preset.limits.clone();
    assert_eq!(&but_limits, preset, "Z written other than the template's");
}

/// The same trace in its machine coordinates, no offset given: refused, and told the one
/// offset that puts it on the program (the facts' own, from the cutting block's start): the
/// program moves along +Y from a standstill at several places, but plunges before it only at
/// the first, as the record's commands do.
fn offset_told_where_not_given(dir: &std::path::Path, f: &Facts) {
    let template = MachineConfig::default_preset();
    let raw = read_trace(&dir.join(TRACE)).unwrap();
    let err = identify(
        &program(dir),
        &template,
        &raw,
        &DiagnoseSettings::for_machine(&template).compare,
    )
    .expect_err("machine coordinates are not the program's");
    let said = err.to_string();
    let flag = format!("--work-offset {:.3},{:.3}", f.offset_mm[0], f.offset_mm[1]);
    assert!(said.contains(&flag), "{said}\nexpected {flag}");
    assert!(!said.contains("as well"), "{said}");
}

/// The control's own 50 Hz trace holds no sample a logger misread: none of its positions is
/// bridged (the bound there is 100 m/s² · (20 ms)² = 40 mm, and the rapid from home at
/// 36 m/min turns far inside it).
#[test]
fn no_sample_of_the_840d_trace_reads_as_misread() {
    let Some(dir) = folder() else { return };
    let mut raw = read_trace(&dir.join(TRACE)).unwrap();
    let spikes = raw.bridge_spikes();
    assert!(spikes.is_empty(), "{spikes:?}");
}
