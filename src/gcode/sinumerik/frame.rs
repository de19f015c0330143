//! The programmable frames (`TRANS`, `ROT`, `SCALE`, `MIRROR` and their additive forms):
//! the workpiece's coordinates turned, shifted, scaled and mirrored into the program's.

use super::super::error::GcodeErrorKind;
use super::emit::Piece;
use super::words::Value;
use super::{Failure, Rewritten, Translator, refuse};
use crate::path::Plane;

/// A programmable frame: a point p of the workpiece is at `shift + rotation(angle)·S·p` in
/// the program's coordinates, S the scale per axis (negative where mirrored) — the 840D's
/// order of a frame's parts: translation, rotation, scale, mirror.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Frame {
    shift: [f64; 3],
    angle_deg: f64,
    pub(super) scale: [f64; 3],
}

impl Default for Frame {
    fn default() -> Self {
        Frame {
            shift: [0.0; 3],
            angle_deg: 0.0,
            scale: [1.0; 3],
        }
    }
}

impl Frame {
    pub(super) fn is_identity(&self) -> bool {
        *self == Frame::default()
    }

    /// A vector of the workpiece (an increment, an arc's centre offset) in the program's
    /// coordinates.
    pub(super) fn turn(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let (x, y) = (self.scale[0] * x, self.scale[1] * y);
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        [c * x - s * y, s * x + c * y]
    }

    /// A point of the workpiece in the program's coordinates.
    pub(super) fn place(&self, p: [f64; 3]) -> [f64; 3] {
        let [x, y] = self.turn([p[0], p[1]]);
        [
            x + self.shift[0],
            y + self.shift[1],
            self.scale[2] * p[2] + self.shift[2],
        ]
    }

    /// The workpiece point at the program's point `p`.
    fn back(&self, p: [f64; 3]) -> [f64; 3] {
        let (x, y) = (p[0] - self.shift[0], p[1] - self.shift[1]);
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let (x, y) = (c * x + s * y, -s * x + c * y);
        [
            x / self.scale[0],
            y / self.scale[1],
            (p[2] - self.shift[2]) / self.scale[2],
        ]
    }

    /// Whether one of X and Y is mirrored (not both: that is a half turn), so that a
    /// clockwise arc of the workpiece runs counter-clockwise in the program.
    fn mirrored(&self) -> bool {
        self.scale[0] * self.scale[1] < 0.0
    }

    /// Whether the frame only shifts (no rotation, scale or mirror): an arc in G18 or G19,
    /// whose centre words include K, stays as written.
    fn only_shifts(&self) -> bool {
        self.angle_deg == 0.0 && self.scale == [1.0; 3]
    }

    /// Whether X and Y are scaled alike, so that an arc stays an arc.
    fn round(&self) -> bool {
        (self.scale[0].abs() - self.scale[1].abs()).abs() <= 1e-12 * self.scale[0].abs()
    }

    /// This frame after the instruction `change` with its arguments (`angle_deg`: the
    /// rotation's, from `RPL=` or Z): a replacing instruction starts from no frame, an
    /// additive one from this.
    fn changed(self, change: FrameChange, args: &FrameArguments, angle_deg: f64) -> Frame {
        let old = self;
        let FrameArguments { values, given } = *args;
        let per_axis = |f: &dyn Fn(usize) -> f64| [f(0), f(1), f(2)];
        match change {
            FrameChange::Trans => Frame {
                shift: values,
                ..Frame::default()
            },
            FrameChange::ATrans => {
                let [x, y] = old.turn([values[0], values[1]]);
                Frame {
                    shift: [
                        old.shift[0] + x,
                        old.shift[1] + y,
                        old.shift[2] + old.scale[2] * values[2],
                    ],
                    ..old
                }
            }
            FrameChange::Rot => Frame {
                angle_deg,
                ..Frame::default()
            },
            FrameChange::ARot => Frame {
                angle_deg: old.angle_deg + angle_deg,
                ..old
            },
            FrameChange::Scale => Frame {
                scale: per_axis(&|a| if given[a] { values[a] } else { 1.0 }),
                ..Frame::default()
            },
            FrameChange::AScale => Frame {
                scale: per_axis(&|a| old.scale[a] * if given[a] { values[a] } else { 1.0 }),
                ..old
            },
            FrameChange::Mirror => Frame {
                scale: per_axis(&|a| if given[a] { -1.0 } else { 1.0 }),
                ..Frame::default()
            },
            FrameChange::AMirror => Frame {
                scale: per_axis(&|a| old.scale[a] * if given[a] { -1.0 } else { 1.0 }),
                ..old
            },
        }
    }
}

/// A block's coordinates under a frame, written once all its words are read: where X or Y,
/// Z, and the centre's I and J are first given, and the increments (workpiece coordinates,
/// in `G91`).
#[derive(Default)]
pub(super) struct Framed {
    xy: Option<usize>,
    z: Option<usize>,
    ij: Option<(usize, [f64; 2])>,
    increment: [f64; 3],
}

impl Framed {
    /// Axis `a`'s word at `offset`, with its increment (0 in `G90`).
    pub(super) fn axis(&mut self, a: usize, offset: usize, increment: f64) {
        self.increment[a] = increment;
        let first = if a == 2 { &mut self.z } else { &mut self.xy };
        first.get_or_insert(offset);
    }

    /// The centre's `I` or `J` at `offset`.
    pub(super) fn centre(&mut self, offset: usize, letter: char, v: f64) {
        let slot = self.ij.get_or_insert((offset, [0.0; 2]));
        slot.1[usize::from(letter == 'J')] = v;
    }
}

/// A frame instruction: `TRANS`, `ROT`, `SCALE` and `MIRROR` replace the programmable frame,
/// `ATRANS`, `AROT`, `ASCALE` and `AMIRROR` add to it (in its own coordinates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum FrameChange {
    Trans,
    ATrans,
    Rot,
    ARot,
    Scale,
    AScale,
    Mirror,
    AMirror,
}

impl Translator {
    /// The motion code the interpreter is to hold for this block under the frame: a
    /// mirrored frame turns a clockwise arc of the workpiece counter-clockwise, so `G2` is
    /// written `G3` and back — in the block that names it, and in a block that moves on the
    /// modal arc whenever the interpreter holds the other one. An arc under a scale that
    /// differs on X and Y (an ellipse) is refused.
    pub(super) fn motion_under_frame(
        &mut self,
        g_codes: &[(usize, u32)],
        words: &[(usize, char, Value)],
        pieces: &mut Vec<(usize, Piece)>,
        out: &mut Rewritten,
    ) -> Result<(), Failure> {
        let named = g_codes.iter().copied().find(|&(_, g)| g <= 3);
        if let Some((_, g)) = named {
            self.motion = Some(g);
        }
        for &(_, g) in g_codes {
            match g {
                17 => self.plane = Plane::Xy,
                18 => self.plane = Plane::Zx,
                19 => self.plane = Plane::Yz,
                _ => {}
            }
        }
        let moving = words
            .iter()
            .find(|w| matches!(w.1, 'X' | 'Y' | 'I' | 'J' | 'R'))
            .map(|w| w.0);
        let arc = matches!(self.motion, Some(2 | 3));
        let moving_in_space = words
            .iter()
            .find(|w| matches!(w.1, 'X' | 'Y' | 'Z' | 'I' | 'J' | 'K' | 'R'))
            .map(|w| w.0);
        if let Some(offset) = moving_in_space
            && arc
            && self.plane != Plane::Xy
            && !self.frame.only_shifts()
        {
            return Err(refuse(
                offset,
                &format!("G{}", self.motion.unwrap_or(2)),
                "an arc in G18/G19 under a frame that rotates, scales or mirrors: the frames \
                 here turn and scale the XY plane only",
            ));
        }
        if let Some(offset) = moving
            && arc
            && !self.frame.round()
        {
            return Err(refuse(
                offset,
                &format!("G{}", self.motion.unwrap_or(2)),
                "an arc under a scale that differs on X and Y is an ellipse, which G2/G3 \
                 cannot describe",
            ));
        }
        let wanted = match self.motion {
            Some(g @ (2 | 3)) if self.frame.mirrored() => Some(5 - g),
            m => m,
        };
        if let Some((offset, g)) = named {
            if Some(g) != wanted {
                out.plain = false;
                for piece in pieces.iter_mut() {
                    if piece.0 == offset && matches!(piece.1, Piece::G(code) if code == g) {
                        piece.1 = Piece::G(wanted.unwrap_or(g));
                    }
                }
            }
            self.emitted_motion = wanted;
        } else if let (Some(offset), Some(w)) = (moving, wanted)
            && self.emitted_motion != wanted
        {
            out.plain = false;
            pieces.push((offset, Piece::G(w)));
            self.emitted_motion = wanted;
        }
        Ok(())
    }

    /// The block's target (workpiece coordinates, as tracked) in the program's.
    pub(super) fn framed_target(&self, offset: usize) -> Result<[f64; 3], Failure> {
        let [Some(x), Some(y), Some(z)] = self.position else {
            return Err((
                offset,
                GcodeErrorKind::Invalid(
                    "a move under a frame needs X, Y and Z set before it (the frame turns \
                     them together)"
                        .into(),
                ),
            ));
        };
        Ok(self.frame.place([x, y, z]))
    }

    /// The block's coordinates under the frame, in the program's: X and Y both, Z, and the
    /// centre's I and J turned; an increment from where the block starts (`start`) to its end.
    pub(super) fn framed_pieces(
        &self,
        framed: &Framed,
        start: [Option<f64>; 3],
        pieces: &mut Vec<(usize, Piece)>,
    ) -> Result<(), Failure> {
        let increment = framed.increment;
        if let Some(offset) = framed.xy {
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
        if let Some(offset) = framed.z {
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
        if let Some((offset, ij)) = framed.ij {
            let [i, j] = self.frame.turn(ij);
            pieces.push((offset, Piece::Word('I', i)));
            pieces.push((offset, Piece::Word('J', j)));
        }
        Ok(())
    }

    /// Applies a frame instruction whose arguments are the block's X, Y, Z and `RPL=`;
    /// the block's other words.
    pub(super) fn change_frame(
        &mut self,
        change: FrameChange,
        mut words: Vec<(usize, char, Value)>,
    ) -> Result<Vec<(usize, char, Value)>, Failure> {
        let args = frame_arguments(change, &words)?;
        words.retain(|w| !matches!(w.1, 'X' | 'Y' | 'Z'));
        let angle_deg = self.rpl.take().unwrap_or(args.values[2]);
        // The workpiece position where the axes are, kept across the change.
        let at = match self.position {
            [Some(x), Some(y), Some(z)] => Some(self.frame.place([x, y, z])),
            _ => None,
        };
        self.frame = self.frame.changed(change, &args, angle_deg);
        if let Some(p) = at {
            // The same point of the machine, in the new frame's workpiece coordinates.
            self.position = self.frame.back(p).map(Some);
        }
        Ok(words)
    }
}

/// A frame instruction's X, Y, Z values, and which of them the block gives.
#[derive(Clone, Copy)]
struct FrameArguments {
    values: [f64; 3],
    given: [bool; 3],
}

/// The frame instruction's arguments among the block's words, its X, Y and Z: plain
/// numbers, a rotation about Z only, no zero scale.
fn frame_arguments(
    change: FrameChange,
    words: &[(usize, char, Value)],
) -> Result<FrameArguments, Failure> {
    let mut args = FrameArguments {
        values: [0.0; 3],
        given: [false; 3],
    };
    for &(offset, letter, value) in words {
        let axis = match letter {
            'X' => 0,
            'Y' => 1,
            'Z' => 2,
            _ => continue,
        };
        let Value::Number(v) = value else {
            return Err(refuse(
                offset,
                "AC/IC",
                "a frame's values are plain numbers",
            ));
        };
        if matches!(change, FrameChange::Rot | FrameChange::ARot) && axis != 2 {
            return Err(refuse(
                offset,
                &format!("{letter}{v}"),
                "a rotation about X or Y leaves the XY plane",
            ));
        }
        if matches!(change, FrameChange::Scale | FrameChange::AScale)
            && !(v.is_finite() && v != 0.0)
        {
            return Err((
                offset,
                GcodeErrorKind::Invalid(format!("{letter}{v}: a scale factor is not 0")),
            ));
        }
        args.values[axis] = v;
        args.given[axis] = true;
    }
    Ok(args)
}
