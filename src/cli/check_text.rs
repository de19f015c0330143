//! The check's words and rows for the terminal and the `--trace` file: the summary a run
//! prints, and the run written as CSV chunk by chunk while it is simulated.

use std::io::Write;

use crate::analysis::contour::ContourPoint;
use crate::check::report::{CheckReport, FollowingInfo, HotspotInfo};
use crate::gcode::interp::SourceLine;
use crate::gcode::{Program, SourceFile};
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::plan::execute::RunChunk;

/// A run written as CSV chunk by chunk as it is simulated, one row every `every` samples:
/// time, line, commanded and actual X/Y (mm), following errors and contour error (µm; empty
/// while not cutting); where Z is simulated and some block is measured in space, then
/// commanded and actual Z, its following error and the contour error's parts in the block's
/// plane and across it.
#[derive(Debug, Clone)]
pub struct TraceCsv {
    every: usize,
    started: bool,
    /// Whether the rows give Z: where it is simulated and some block is measured in space
    /// (a 2.5-D program's trace is the same with Z simulated or carried).
    with_z: bool,
    /// The program's subprogram files, whose lines the `line` column names by file.
    sources: Vec<SourceFile>,
}

impl TraceCsv {
    /// The trace of `program`, keeping every `every`-th sample.
    pub(crate) fn of(program: &Program, every: usize) -> Self {
        TraceCsv {
            sources: program.sources.clone(),
            ..TraceCsv::new(every)
        }
    }

    /// A trace keeping every `every`-th sample.
    pub(crate) fn new(every: usize) -> Self {
        TraceCsv {
            every: every.max(1),
            started: false,
            with_z: false,
            sources: Vec::new(),
        }
    }

    /// Writes the rows of the next chunk (with the header before the first).
    pub(crate) fn write_chunk(
        &mut self,
        w: &mut dyn Write,
        chunk: &RunChunk,
        points: &[ContourPoint],
    ) -> std::io::Result<()> {
        let mut out = csv::Writer::from_writer(w);
        if !self.started {
            let mut header = vec![
                "t_s",
                "line",
                "x_ref_mm",
                "y_ref_mm",
                "x_mm",
                "y_mm",
                "fe_x_um",
                "fe_y_um",
                "contour_um",
            ];
            self.with_z =
                chunk.z.is_some() && chunk.plan.segments.iter().any(|s| s.is_contour_in_space());
            if self.with_z {
                header.extend(["z_ref_mm", "z_mm", "fe_z_um", "in_plane_um", "across_um"]);
            }
            out.write_record(header)?;
            self.started = true;
        }
        let c = chunk.commands;
        let first_kept = chunk.first.next_multiple_of(self.every) - chunk.first;
        let um_or_empty = |e: f64| {
            if e.is_finite() {
                format!("{:.4}", um_from_m(e))
            } else {
                String::new()
            }
        };
        for i in (first_kept..points.len().min(chunk.x.len())).step_by(self.every) {
            let mut row = vec![
                format!("{:.4}", c.time_s(chunk.first + i)),
                SourceLine::among(
                    &self.sources,
                    chunk.plan.segments[c.segment[i] as usize].line,
                )
                .short(),
                format!("{:.6}", mm_from_m(c.x.pos_m[i])),
                format!("{:.6}", mm_from_m(c.y.pos_m[i])),
                format!("{:.6}", mm_from_m(chunk.x.pos_m[i])),
                format!("{:.6}", mm_from_m(chunk.y.pos_m[i])),
                format!("{:.4}", um_from_m(chunk.x.following_error_m(i))),
                format!("{:.4}", um_from_m(chunk.y.following_error_m(i))),
                um_or_empty(points[i].error_m),
            ];
            if let Some(z) = chunk.z.as_ref().filter(|_| self.with_z) {
                row.extend([
                    format!("{:.6}", mm_from_m(c.z.pos_m[i])),
                    format!("{:.6}", mm_from_m(z.pos_m[i])),
                    format!("{:.4}", um_from_m(z.following_error_m(i))),
                    um_or_empty(points[i].in_plane_m),
                    um_or_empty(points[i].across_m),
                ]);
            }
            out.write_record(&row)?;
        }
        out.flush()
    }
}

/// The human-readable summary.
pub(crate) fn summary_text(r: &CheckReport, max_hotspots: usize) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "program   {} ({} lines, {} blocks)",
        r.program.file, r.program.lines, r.program.blocks
    );
    let _ = writeln!(
        s,
        "machine   {} — {}",
        r.machine.name, r.machine.description
    );
    let _ = writeln!(
        s,
        "settings  {} profile, interpolation {} ms, simulation step {} ms",
        r.settings.profile, r.settings.interpolation_cycle_ms, r.settings.simulation_step_ms
    );
    let _ = writeln!(
        s,
        "cycle     {:.2} s over {:.1} mm ({:.1} mm cutting)",
        r.cycle_time_s, r.path_length_mm, r.cut_length_mm
    );
    let at = r
        .contour_error_um
        .max_at
        .as_ref()
        .map_or(String::new(), |l| {
            format!(
                " at {}{} (X {:.3}, Y {:.3} mm, t {:.3} s)",
                in_file(l.file.as_deref(), l.line),
                l.block_number.map_or(String::new(), |n| format!(" N{n}")),
                l.x_mm,
                l.y_mm,
                l.t_s
            )
        });
    let _ = writeln!(
        s,
        "contour   max {:.2} µm{at}, RMS {:.2} µm",
        r.contour_error_um.max, r.contour_error_um.rms
    );
    let _ = writeln!(s, "{}", contour_note(r));
    let p = &r.positioning_error_um;
    if let (Some(line), Some(t)) = (p.line, p.t_s)
        && p.max >= 0.005
    {
        let block = p.block_number.map_or(String::new(), |n| format!(" N{n}"));
        let _ = writeln!(
            s,
            "settling max {:.2} µm at {}{block} (t {t:.3} s): XY still arriving while only Z \
             moves or the program dwells",
            p.max,
            in_file(p.file.as_deref(), line)
        );
    }
    let _ = writeln!(s, "{}", following_line(&r.following_error_um));
    if let (Some(t), Some(ok)) = (r.tolerance_um, r.within_tolerance) {
        let verdict = if ok { "within" } else { "EXCEEDS" };
        let _ = writeln!(s, "tolerance {t} µm: the predicted maximum {verdict} it");
    }
    if !r.circular_test.circles.is_empty() {
        let _ = writeln!(s, "\ncircular test (ISO 230-4 figures, predicted)");
        s.push_str(&r.circular_test.text());
    }
    if !r.hotspots.is_empty() {
        s.push_str(&hotspot_table(r, max_hotspots));
    }
    s
}

/// The line under the contour figure: how it was measured, and its parts where some blocks
/// were measured in space.
fn contour_note(r: &CheckReport) -> String {
    match (
        r.contour_error_um.max_in_plane,
        r.contour_error_um.max_across,
    ) {
        (Some(in_plane), Some(across)) => {
            format!(
                "          (3-D distance to the path on blocks that move Z or lie in ZX or YZ, XY \
                 elsewhere; largest part in the block's plane {in_plane:.2} µm, across it {across:.2} µm; signed + \
                 to the left of travel in the plane)"
            )
        }
        _ => "          (XY feed moves only; signed + to the left of the direction of travel: \
              inside a ccw circle, outside a cw one)"
            .to_string(),
    }
}

/// The simulated axes' largest following errors, while cutting and with the rapids.
fn following_line(fe: &FollowingInfo) -> String {
    match &fe.z {
        None => {
            format!(
                "following max while cutting: X {:.1} µm, Y {:.1} µm (with rapids: X {:.1} µm, \
                 Y {:.1} µm)",
                fe.x.max_cutting, fe.y.max_cutting, fe.x.max, fe.y.max
            )
        }
        Some(z) => {
            format!(
                "following max while cutting: X {:.1} µm, Y {:.1} µm, Z {:.1} µm (with rapids: \
                 X {:.1} µm, Y {:.1} µm, Z {:.1} µm)",
                fe.x.max_cutting, fe.y.max_cutting, z.max_cutting, fe.x.max, fe.y.max, z.max
            )
        }
    }
}

/// "line 16", or "L1.SPF line 7" for a line of a subprogram's file.
fn in_file(file: Option<&str>, line: u32) -> String {
    match file {
        Some(f) => format!("{} line {line}", file_name(f)),
        None => format!("line {line}"),
    }
}

/// A file's name without its folder.
fn file_name(path: &str) -> &str {
    std::path::Path::new(path)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(path)
}

/// The hotspot table: the largest `max_hotspots`, with the program's own block numbers
/// beside the file's lines where it gives them.
fn hotspot_table(r: &CheckReport, max_hotspots: usize) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "\nhotspots (largest first)");
    let numbered = r.hotspots.iter().any(|h| h.block_number.is_some());
    let line_of = |h: &HotspotInfo| match &h.file {
        Some(file) => format!("{}:{}", file_name(file), h.hotspot.line),
        None => h.hotspot.line.to_string(),
    };
    let shown = || r.hotspots.iter().take(max_hotspots);
    let width = shown().map(|h| line_of(h).len()).max().unwrap_or(4).max(4);
    let with_z = r.hotspots.iter().any(|h| h.hotspot.z_mm.is_some());
    let _ = writeln!(
        s,
        "  rank  {:>width$}{}   time (s)     X (mm)     Y (mm){}   error (µm)  spike (µm)  cause",
        "line",
        if numbered { "  block" } else { "" },
        if with_z { "     Z (mm)" } else { "" }
    );
    for h in shown() {
        let hs = &h.hotspot;
        let block = match (numbered, h.block_number) {
            (false, _) => String::new(),
            (true, Some(n)) => format!("  {:>5}", format!("N{n}")),
            (true, None) => format!("  {:>5}", ""),
        };
        let line = line_of(h);
        let z = hs.z_mm.map_or(String::new(), |z| format!("  {z:>9.3}"));
        let _ = writeln!(
            s,
            "  {:>4}  {line:>width$}{block}  {:>9.3}  {:>9.3}  {:>9.3}{z}  {:>11.2}  {:>10.2}  {}",
            h.rank, hs.t_s, hs.x_mm, hs.y_mm, hs.error_um, hs.excess_um, h.label
        );
    }
    if r.hotspots.len() > max_hotspots {
        let _ = writeln!(
            s,
            "  … {} more (--json lists them all)",
            r.hotspots.len() - max_hotspots
        );
    }
    s
}
