//! The block written out as RS274/NGC: its G codes and the path mode they leave, its
//! words resolved against the position (and the frame), in the order of their meaning.

use super::super::error::GcodeErrorKind;
use super::words::{CENTRE_AC_IC, OPENING_ANGLE, Value};
use super::{Failure, Rewritten, Translator, refuse};

/// The continuous-path mode a program set, which a `G9` block interrupts for itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum PathMode {
    /// `G60`.
    ExactStop,
    /// `G64`, or `G641`/`G642` with their distance (mm or inch, as the program's unit).
    Continuous(Option<f64>),
}

/// A piece of the rewritten line, written out only when the line is rewritten.
pub(super) enum Piece {
    Text(&'static str),
    G(u32),
    Word(char, f64),
    Blend(f64),
}

impl Translator {
    /// Writes the block's codes and words as RS274/NGC, in its order of meaning.
    pub(super) fn emit(
        &mut self,
        g_codes: Vec<(usize, u32)>,
        words: Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        if g_codes.is_empty() && words.is_empty() {
            if let Some(change) = self.frame_change.take() {
                self.change_frame(change, Vec::new())?;
            }
            return Ok(());
        }
        // The 840D starts in exact stop (G60) unless its machine data say otherwise.
        if std::mem::take(&mut self.first_block) {
            self.restore_mode = true;
        }
        let mut pieces: Vec<(usize, Piece)> = Vec::new();
        let dwell = self.emit_codes(&g_codes, &mut pieces, out);
        let mut words = words;
        if let Some(call) = &mut self.call {
            // `L123 P3`: P is how many times the subprogram runs.
            if let Some(k) = words.iter().position(|w| w.1 == 'P') {
                let (offset, _, value) = words.remove(k);
                let n = match value {
                    Value::Number(n) if n >= 1.0 && n.fract() == 0.0 && n <= 1e6 => n as u32,
                    _ => {
                        return Err((
                            offset,
                            GcodeErrorKind::Invalid(
                                "P: the number of runs is a whole number from 1 up".into(),
                            ),
                        ));
                    }
                };
                call.repeat = n;
            }
        }
        if self.in_subprogram
            && let Some(k) = words
                .iter()
                .position(|(_, l, v)| *l == 'M' && matches!(v, Value::Number(x) if *x == 17.0))
        {
            words.remove(k);
            self.returned = true;
            out.plain = false;
        }
        if let Some(change) = self.frame_change.take() {
            words = self.change_frame(change, words)?;
        }
        self.motion_under_frame(&g_codes, &words, &mut pieces, out)?;
        self.rotary_positioning(&mut words, out)?;
        if let Some(k) = words.iter().position(|w| w.1 == OPENING_ANGLE) {
            let (offset, _, value) = words.remove(k);
            out.plain = false;
            self.opening_angle(offset, value, &mut words)?;
        }
        let framed = !self.frame.is_identity();
        // Words RS274/NGC reads otherwise, or not at all: the line is rewritten.
        let rewritten_word = |(_, l, v): &(usize, char, Value)| {
            !matches!(v, Value::Number(_))
                || *l == 'D'
                || (*l == 'M' && matches!(v, Value::Number(x) if *x == 17.0))
                || (framed && matches!(l, 'X' | 'Y' | 'Z' | 'I' | 'J' | 'R'))
        };
        // An increment that also travels a frame's change of offset is rewritten.
        let offset_left = |(_, l, _): &(usize, char, Value)| {
            "XYZ".find(*l).is_some_and(|a| {
                matches!((self.incremental_base[a], self.position[a]), (Some(b), Some(p)) if b != p)
            })
        };
        if dwell
            || words.iter().any(rewritten_word)
            || (!self.absolute && words.iter().any(offset_left))
        {
            out.plain = false;
        }
        self.emit_words(words, dwell, &mut pieces, out)?;
        if g_codes.iter().any(|&(_, g)| g == 53 || g == 153) {
            self.position = [None; 3];
            self.incremental_base = [None; 3];
        }
        if !out.plain {
            write_pieces(pieces, out);
        }
        Ok(())
    }

    /// Rotary axes (`A`, `B`, `C`): the model has none, and the XY path is the machine's. A
    /// rotary axis positioned in a rapid, or in a block that moves no linear axis, leaves the
    /// path alone: it is taken out and noted (once). Turning while a feed move runs along
    /// X, Y or Z machines a path this cannot follow, and is refused.
    fn rotary_positioning(
        &mut self,
        words: &mut Vec<(usize, char, Value)>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        let is_rotary = |w: &(usize, char, Value)| matches!(w.1, 'A' | 'B' | 'C');
        let Some(&(offset, axis, _)) = words.iter().find(|w| is_rotary(w)) else {
            return Ok(());
        };
        let linear = words
            .iter()
            .any(|w| matches!(w.1, 'X' | 'Y' | 'Z' | 'I' | 'J' | 'R' | OPENING_ANGLE));
        if linear && self.motion != Some(0) {
            return Err(refuse(
                offset,
                &axis.to_string(),
                "a rotary axis turning during a feed move: the model has X, Y and Z only",
            ));
        }
        out.plain = false;
        if !std::mem::replace(&mut self.rotary_noted, true) {
            out.warnings.push(format!(
                "{axis}: a rotary axis positioned (here and wherever else the program positions \
                 one in a rapid or on its own): not modelled; the XY path is taken as the \
                 machine's"
            ));
        }
        words.retain(|w| !is_rotary(w));
        Ok(())
    }

    /// An arc given by its opening angle `AR=` (degrees): with its end point, the radius
    /// that spans it (`R`, negative above 180°); with its centre, the end point the angle
    /// reaches from the start, counter-clockwise on `G3`, clockwise on `G2`.
    fn opening_angle(
        &self,
        offset: usize,
        value: Value,
        words: &mut Vec<(usize, char, Value)>,
    ) -> Result<(), Failure> {
        let invalid = |what: &str| (offset, GcodeErrorKind::Invalid(format!("AR: {what}")));
        let Value::Number(angle) = value else {
            return Err(invalid("the opening angle is a plain number"));
        };
        if !(angle > 0.0 && angle < 360.0) {
            return Err(invalid("the opening angle lies between 0 and 360°"));
        }
        let ccw = match self.motion {
            Some(3) => true,
            Some(2) => false,
            _ => return Err(invalid("an opening angle belongs to a G2 or G3 arc")),
        };
        // In the working plane: its first and second axes (X and Y in G17, Z and X in G18,
        // Y and Z in G19) and their centre words.
        let [a0, a1, _] = self.plane.axes();
        let axis_letter = |a: usize| b"XYZ"[a] as char;
        let centre_letter = |a: usize| b"IJK"[a] as char;
        let [Some(x0), Some(y0)] = [self.position[a0], self.position[a1]] else {
            return Err(invalid("the arc's start is not known yet"));
        };
        let has = |l: char| words.iter().any(|w| w.1 == l);
        let end_given = has(axis_letter(a0)) || has(axis_letter(a1));
        let centre_given = has(centre_letter(a0)) || has(centre_letter(a1));
        let half = (angle / 2.0).to_radians();
        if end_given && !centre_given && !has('R') {
            let start = self.position;
            let mut end = [x0, y0];
            for (o, l, v) in words.iter() {
                if let Some(k) = [a0, a1].iter().position(|&a| axis_letter(a) == *l) {
                    let v = self.coordinate(*o, *l, *v, &start)?;
                    end[k] = if self.absolute { v } else { [x0, y0][k] + v };
                }
            }
            let chord = (end[0] - x0).hypot(end[1] - y0);
            if chord == 0.0 {
                return Err(invalid("an arc to its own start needs its centre"));
            }
            let radius = chord / 2.0 / half.sin();
            let signed = if angle > 180.0 { -radius } else { radius };
            words.push((offset, 'R', Value::Number(signed)));
            return Ok(());
        }
        if centre_given && !end_given && !has('R') {
            let start = self.position;
            let mut centre = [x0, y0];
            for (o, l, v) in words.iter() {
                if let Some(k) = [a0, a1].iter().position(|&a| centre_letter(a) == *l) {
                    centre[k] += self.coordinate(*o, *l, *v, &start)?;
                }
            }
            let turn = if ccw { angle } else { -angle }.to_radians();
            let (s, c) = turn.sin_cos();
            let (dx, dy) = (x0 - centre[0], y0 - centre[1]);
            let end = [centre[0] + c * dx - s * dy, centre[1] + s * dx + c * dy];
            words.push((offset, axis_letter(a0), Value::Absolute(end[0])));
            words.push((offset, axis_letter(a1), Value::Absolute(end[1])));
            return Ok(());
        }
        Err(invalid(
            "give the arc's end point or its centre in the working plane with it, not both, \
             nor CR=",
        ))
    }

    /// The block's G codes as RS274/NGC and the path mode they leave; whether the block
    /// dwells.
    fn emit_codes(
        &mut self,
        g_codes: &[(usize, u32)],
        pieces: &mut Vec<(usize, Piece)>,
        out: &mut Rewritten,
    ) -> bool {
        let (mut exact_here, mut mode_changed, mut dwell) = (false, false, false);
        // A `G60` writes its own `G61`: the mode needs no restoring on top of it.
        let mut mode_written = false;
        // Where the block's path-mode code was written (a restoring one goes with the
        // block's first G code, or last).
        let mut mode_offset = g_codes.first().map_or(usize::MAX, |g| g.0);
        const REWRITTEN: [u32; 12] = [710, 71, 700, 70, 60, 9, 64, 641, 642, 500, 153, 4];
        if g_codes.iter().any(|(_, g)| REWRITTEN.contains(g)) {
            out.plain = false;
        }
        for &(offset, g) in g_codes {
            let rs = match g {
                710 | 71 => Some(Piece::Text("G21")),
                700 | 70 => Some(Piece::Text("G20")),
                60 => {
                    self.path_mode = PathMode::ExactStop;
                    self.rounding = None;
                    mode_written = true;
                    Some(Piece::Text("G61"))
                }
                9 | 64 | 641 | 642 => {
                    match g {
                        9 => exact_here = true,
                        64 => {
                            self.path_mode = PathMode::Continuous(None);
                            self.rounding = None;
                        }
                        _ => self.rounding = Some(g == 641),
                    }
                    mode_changed |= g != 9;
                    mode_offset = offset;
                    None
                }
                500 => None,
                153 => Some(Piece::Text("G53")),
                4 => {
                    dwell = true;
                    Some(Piece::Text("G4"))
                }
                90 | 91 => {
                    self.absolute = g == 90;
                    Some(Piece::G(g))
                }
                g => Some(Piece::G(g)),
            };
            if let Some(rs) = rs {
                pieces.push((offset, rs));
            }
        }
        // The rounding distance in force, should the block set one: `G641` rounds after a
        // rapid by `ADISPOS`, after a feed move by `ADIS`; `G642` by the contour tolerance,
        // after a rapid by `CTOLG0` where one is set (else by `CTOL`: the machine data's
        // factor for G0 tolerances is taken as 1).
        if let Some(is_641) = self.rounding {
            let rapid = g_codes
                .iter()
                .rev()
                .find(|g| g.1 <= 3)
                .map(|g| g.1)
                .or(self.motion)
                == Some(0);
            let distance = match (is_641, rapid) {
                (true, true) => self.adispos,
                (true, false) => self.adis,
                (false, true) => self.ctol_g0.or(self.ctol),
                (false, false) => self.ctol,
            };
            if matches!(self.path_mode, PathMode::Continuous(d) if d != distance) {
                mode_changed = true;
            }
            self.path_mode = PathMode::Continuous(distance);
        }
        if exact_here || mode_changed || self.restore_mode {
            out.plain = false;
        }
        if exact_here {
            if !mode_written {
                pieces.push((mode_offset, Piece::Text("G61")));
            }
            self.restore_mode = true;
        } else if mode_written && !mode_changed {
            self.restore_mode = false;
        } else if mode_changed || self.restore_mode {
            self.restore_mode = false;
            pieces.push((
                mode_offset,
                match self.path_mode {
                    PathMode::ExactStop => Piece::Text("G61"),
                    PathMode::Continuous(None) => Piece::Text("G64"),
                    PathMode::Continuous(Some(d)) => Piece::Blend(d),
                },
            ));
        }
        dwell
    }

    /// The block's words as RS274/NGC: coordinates resolved against the position and, under
    /// a frame, written turned and shifted (X and Y both, once either is given; I and J
    /// turned) into the program's coordinates.
    fn emit_words(
        &mut self,
        words: Vec<(usize, char, Value)>,
        dwell: bool,
        pieces: &mut Vec<(usize, Piece)>,
        out: &Rewritten,
    ) -> Result<(), Failure> {
        let framed = !self.frame.is_identity();
        let mut framed_xy: Option<usize> = None;
        let mut framed_z: Option<usize> = None;
        let mut framed_ij: Option<(usize, [f64; 2])> = None;
        // Where the block starts: an arc centre given absolute is taken from there.
        let start = self.position;
        // Under a frame in G91: the block's increments (workpiece coordinates).
        let mut increment = [0.0f64; 3];
        for (offset, letter, value) in words {
            let axis = "XYZ".find(letter);
            let mut v = self.coordinate(offset, letter, value, &start)?;
            if let Some(a) = axis {
                let base = self.incremental_base[a].or(start[a]);
                self.position[a] = if self.absolute {
                    Some(v)
                } else {
                    base.map(|p| p + v)
                };
                self.incremental_base[a] = self.position[a];
                if framed {
                    increment[a] = if self.absolute { 0.0 } else { v };
                    let first = if a == 2 {
                        &mut framed_z
                    } else {
                        &mut framed_xy
                    };
                    first.get_or_insert(offset);
                    continue;
                }
                // G91 without a frame: the increment, plus the offset a frame left behind.
                if let (false, Some(b), Some(p)) = (self.absolute, base, start[a])
                    && b != p
                {
                    v += b - p;
                }
            }
            if framed && (letter == 'I' || letter == 'J') {
                let slot = framed_ij.get_or_insert((offset, [0.0; 2]));
                slot.1[usize::from(letter == 'J')] = v;
                continue;
            }
            let (letter, v) = match (letter, dwell) {
                // `G4 F2`: two seconds' dwell; RS274 gives it as P.
                ('F', true) => ('P', v),
                ('D', _) => continue,
                ('M', _) if v == 17.0 => ('M', 2.0),
                // An arc's radius scaled with the frame (alike on X and Y, or refused).
                ('R', _) if framed => ('R', v * self.frame.scale[0].abs()),
                other => (other.0, v),
            };
            if !out.plain {
                pieces.push((offset, Piece::Word(letter, v)));
            }
        }
        if let Some(offset) = framed_xy {
            let [x, y] = if self.absolute {
                let p = self.framed_target(offset)?;
                [p[0], p[1]]
            } else if let (Ok(to), [Some(x), Some(y), Some(z)]) =
                (self.framed_target(offset), start)
            {
                // From where the block starts to its end, both in the program's coordinates.
                let from = self.frame.place([x, y, z]);
                [to[0] - from[0], to[1] - from[1]]
            } else {
                self.frame.turn([increment[0], increment[1]])
            };
            pieces.push((offset, Piece::Word('X', x)));
            pieces.push((offset, Piece::Word('Y', y)));
        }
        if let Some(offset) = framed_z {
            let z = if self.absolute {
                self.framed_target(offset)?[2]
            } else if let (Ok(to), [Some(x), Some(y), Some(z)]) =
                (self.framed_target(offset), start)
            {
                to[2] - self.frame.place([x, y, z])[2]
            } else {
                increment[2]
            };
            pieces.push((offset, Piece::Word('Z', z)));
        }
        if let Some((offset, ij)) = framed_ij {
            let [i, j] = self.frame.turn(ij);
            pieces.push((offset, Piece::Word('I', i)));
            pieces.push((offset, Piece::Word('J', j)));
        }
        Ok(())
    }

    /// A word's value in the block's mode: `AC`/`IC` resolved against the position (or,
    /// for an arc centre, the block's start `start`).
    fn coordinate(
        &self,
        offset: usize,
        letter: char,
        value: Value,
        start: &[Option<f64>; 3],
    ) -> Result<f64, Failure> {
        let axis = "XYZ".find(letter);
        let centre = "IJK".find(letter);
        Ok(match (value, axis) {
            (Value::Number(v), _) => v,
            // A centre is incremental to the start already; `AC` gives it absolute.
            (Value::Incremental(v), None) if centre.is_some() => v,
            (Value::Absolute(v), None) if centre.is_some() => {
                let c = centre.unwrap_or(0);
                let at = start[c].ok_or_else(|| unknown_position(offset, letter))?;
                v - at
            }
            (Value::Absolute(_) | Value::Incremental(_), None) => {
                return Err(refuse(offset, &format!("{letter}=AC/IC"), CENTRE_AC_IC));
            }
            (Value::Absolute(v), Some(a)) if !self.absolute => {
                let at = self.position[a].ok_or_else(|| unknown_position(offset, letter))?;
                v - at
            }
            (Value::Incremental(v), Some(a)) if self.absolute => {
                let at = self.incremental_base[a]
                    .or(self.position[a])
                    .ok_or_else(|| unknown_position(offset, letter))?;
                at + v
            }
            (Value::Absolute(v) | Value::Incremental(v), Some(_)) => v,
        })
    }
}

/// The pieces of a rewritten line, in the order written (a stable sort keeps a mode code
/// after the code it follows).
fn write_pieces(mut pieces: Vec<(usize, Piece)>, out: &mut Rewritten) {
    pieces.sort_by_key(|p| p.0);
    for (offset, piece) in pieces {
        let text = match piece {
            Piece::Text(t) => t.to_string(),
            Piece::G(g) => format!("G{g}"),
            // Rounded to 0.1 nm: a turned coordinate's last bits are not the program's.
            Piece::Word(letter, v) => format!("{letter}{}", (v * 1e7).round() / 1e7 + 0.0),
            Piece::Blend(d) => format!("G64 P{d}"),
        };
        out.push(offset, &text);
    }
}

fn unknown_position(offset: usize, letter: char) -> Failure {
    (
        offset,
        GcodeErrorKind::Invalid(format!(
            "{letter}=AC()/IC() against a position the program has not set yet"
        )),
    )
}
