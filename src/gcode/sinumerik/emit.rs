//! The block written out as RS274/NGC: its G codes and the path mode they leave, its
//! words resolved against the position (and the frame), in the order of their meaning.

use super::super::error::GcodeErrorKind;
use super::frame::Framed;
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

/// What a block's path-mode codes did, for the code written after them.
#[derive(Clone, Copy)]
struct ModeCodes {
    /// `G9`: exact stop in this block only.
    exact_here: bool,
    /// The path mode changed (`G64`, `G641`, `G642`, or a new rounding distance).
    changed: bool,
    /// `G60` wrote its own `G61`: the mode needs no restoring on top of it.
    written: bool,
    /// Where the block's path-mode code is written (a restoring one goes with the block's
    /// first G code, or last).
    offset: usize,
}

/// A word as RS274/NGC reads it (none for a word it is not to see): a dwell's `F` as `P`,
/// `M17` as `M2`, an arc's radius scaled with the frame (`scale`, alike on X and Y).
fn rs274_word(letter: char, v: f64, dwell: bool, scale: Option<f64>) -> Option<(char, f64)> {
    Some(match (letter, dwell, scale) {
        // `G4 F2`: two seconds' dwell; RS274 gives it as P.
        ('F', true, _) => ('P', v),
        ('D', _, _) => return None,
        ('M', _, _) if v == 17.0 => ('M', 2.0),
        ('R', _, Some(scale)) => ('R', v * scale),
        (letter, _, _) => (letter, v),
    })
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
        self.call_repeats(&mut words)?;
        self.subprogram_return(&mut words, out);
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
        if dwell || self.words_rewritten(&words) {
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

    /// `L123 P3`: P is how many times the block's subprogram runs (taken out of the words).
    fn call_repeats(&mut self, words: &mut Vec<(usize, char, Value)>) -> Result<(), Failure> {
        let Some(call) = &mut self.call else {
            return Ok(());
        };
        let Some(k) = words.iter().position(|w| w.1 == 'P') else {
            return Ok(());
        };
        let (offset, _, value) = words.remove(k);
        call.repeat = match value {
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
        Ok(())
    }

    /// `M17` in a subprogram: the return to its caller (taken out of the words).
    fn subprogram_return(&mut self, words: &mut Vec<(usize, char, Value)>, out: &mut Rewritten) {
        if self.in_subprogram
            && let Some(k) = words
                .iter()
                .position(|(_, l, v)| *l == 'M' && matches!(v, Value::Number(x) if *x == 17.0))
        {
            words.remove(k);
            self.returned = true;
            out.plain = false;
        }
    }

    /// Whether the block's words read otherwise in RS274/NGC, or not at all, so that the
    /// line is rewritten: `AC`/`IC` values, `D`, `M17`, coordinates under a frame, and an
    /// increment that also travels a frame's change of offset.
    fn words_rewritten(&self, words: &[(usize, char, Value)]) -> bool {
        let framed = !self.frame.is_identity();
        let rewritten_word = |(_, l, v): &(usize, char, Value)| {
            !matches!(v, Value::Number(_))
                || *l == 'D'
                || (*l == 'M' && matches!(v, Value::Number(x) if *x == 17.0))
                || (framed && matches!(l, 'X' | 'Y' | 'Z' | 'I' | 'J' | 'R'))
        };
        let offset_left = |(_, l, _): &(usize, char, Value)| {
            "XYZ".find(*l).is_some_and(|a| {
                matches!((self.incremental_base[a], self.position[a]), (Some(b), Some(p)) if b != p)
            })
        };
        words.iter().any(rewritten_word) || (!self.absolute && words.iter().any(offset_left))
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
        let mut modes = ModeCodes {
            exact_here: false,
            changed: false,
            written: false,
            offset: g_codes.first().map_or(usize::MAX, |g| g.0),
        };
        let mut dwell = false;
        const REWRITTEN: [u32; 14] = [710, 71, 700, 70, 60, 9, 64, 641, 642, 500, 153, 4, 601, 602];
        if g_codes.iter().any(|(_, g)| REWRITTEN.contains(g)) {
            out.plain = false;
        }
        for &(offset, g) in g_codes {
            dwell |= g == 4;
            // On the 840D G70/G71 switch the geometric data alone; G700/G710 the feeds too.
            match g {
                70 | 71 => out.feed_in_basic_system = Some(true),
                700 | 710 => out.feed_in_basic_system = Some(false),
                _ => {}
            }
            if let Some(rs) = self.code(offset, g, &mut modes) {
                pieces.push((offset, rs));
            }
        }
        if self.rounding_distance(g_codes) {
            modes.changed = true;
        }
        self.path_mode_code(modes, pieces, out);
        dwell
    }

    /// One G code as RS274/NGC (none for a path-mode code written after the block's codes,
    /// and for `G500`), its modes taken on.
    fn code(&mut self, offset: usize, g: u32, modes: &mut ModeCodes) -> Option<Piece> {
        match g {
            710 | 71 => Some(Piece::Text("G21")),
            700 | 70 => Some(Piece::Text("G20")),
            60 => {
                self.path_mode = PathMode::ExactStop;
                self.rounding = None;
                modes.written = true;
                Some(Piece::Text("G61"))
            }
            9 | 64 | 641 | 642 => {
                match g {
                    9 => modes.exact_here = true,
                    64 => {
                        self.path_mode = PathMode::Continuous(None);
                        self.rounding = None;
                    }
                    _ => self.rounding = Some(g == 641),
                }
                modes.changed |= g != 9;
                modes.offset = offset;
                None
            }
            // The exact-stop window, fine or coarse: the machine file's one window serves.
            500 | 601 | 602 => None,
            153 => Some(Piece::Text("G53")),
            4 => Some(Piece::Text("G4")),
            90 | 91 => {
                self.absolute = g == 90;
                Some(Piece::G(g))
            }
            g => Some(Piece::G(g)),
        }
    }

    /// The rounding distance in force, should the block set one: `G641` rounds after a
    /// rapid by `ADISPOS`, after a feed move by `ADIS`; `G642` by the contour tolerance,
    /// after a rapid by `CTOLG0` where one is set (else by `CTOL`: the machine data's
    /// factor for G0 tolerances is taken as 1). Whether it changed the path mode.
    fn rounding_distance(&mut self, g_codes: &[(usize, u32)]) -> bool {
        let Some(is_641) = self.rounding else {
            return false;
        };
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
        let changed = matches!(self.path_mode, PathMode::Continuous(d) if d != distance);
        self.path_mode = PathMode::Continuous(distance);
        changed
    }

    /// The path-mode code the block needs: `G61` for a `G9` block, the mode it set, or the
    /// mode restored after a `G9` block.
    fn path_mode_code(
        &mut self,
        modes: ModeCodes,
        pieces: &mut Vec<(usize, Piece)>,
        out: &mut Rewritten,
    ) {
        if modes.exact_here || modes.changed || self.restore_mode {
            out.plain = false;
        }
        if modes.exact_here {
            if !modes.written {
                pieces.push((modes.offset, Piece::Text("G61")));
            }
            self.restore_mode = true;
        } else if modes.written && !modes.changed {
            self.restore_mode = false;
        } else if modes.changed || self.restore_mode {
            self.restore_mode = false;
            pieces.push((
                modes.offset,
                match self.path_mode {
                    PathMode::ExactStop => Piece::Text("G61"),
                    PathMode::Continuous(None) => Piece::Text("G64"),
                    PathMode::Continuous(Some(d)) => Piece::Blend(d),
                },
            ));
        }
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
        let mut framed = (!self.frame.is_identity()).then(Framed::default);
        // Where the block starts: an arc centre given absolute is taken from there.
        let start = self.position;
        for (offset, letter, value) in words {
            let mut v = self.coordinate(offset, letter, value, &start)?;
            if let Some(a) = "XYZ".find(letter) {
                let base = self.incremental_base[a].or(start[a]);
                self.position[a] = if self.absolute {
                    Some(v)
                } else {
                    base.map(|p| p + v)
                };
                self.incremental_base[a] = self.position[a];
                if let Some(f) = &mut framed {
                    f.axis(a, offset, if self.absolute { 0.0 } else { v });
                    continue;
                }
                // G91 without a frame: the increment, plus the offset a frame left behind.
                if let (false, Some(b), Some(p)) = (self.absolute, base, start[a])
                    && b != p
                {
                    v += b - p;
                }
            }
            if let Some(f) = &mut framed
                && (letter == 'I' || letter == 'J')
            {
                f.centre(offset, letter, v);
                continue;
            }
            let scale = framed.is_some().then(|| self.frame.scale[0].abs());
            if let Some((letter, v)) = rs274_word(letter, v, dwell, scale)
                && !out.plain
            {
                pieces.push((offset, Piece::Word(letter, v)));
            }
        }
        if let Some(f) = framed {
            self.framed_pieces(&f, start, pieces)?;
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
