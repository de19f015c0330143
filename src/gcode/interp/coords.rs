//! Coordinate systems: the work offsets (`G54`…, set by `G10`), `G92`/`G52` shifts, the
//! systems' XY rotation, machine coordinates (`G53`) and the home positions (`G28`/`G30`).

use super::{IResult, Interpreter, err};
use crate::gcode::error::GcodeErrorKind;
use crate::path::Motion;

impl Interpreter {
    /// Offset of the active work coordinate system plus G92 (mm).
    fn offset_mm(&self) -> [f64; 3] {
        let w = self.work_offsets_mm[self.coord_index];
        [
            w[0] + self.g92_mm[0],
            w[1] + self.g92_mm[1],
            w[2] + self.g92_mm[2],
        ]
    }

    /// Where the tool stands in the active system's coordinates, in the program's unit: the
    /// inverse of [`Interpreter::program_to_machine`].
    pub(crate) fn program_position(&self) -> [f64; 3] {
        let (sin, cos) = self.rotation_deg[self.coord_index].to_radians().sin_cos();
        let o = self.offset_mm();
        let d = [0, 1, 2].map(|i| self.pos_mm[i] - o[i]);
        [cos * d[0] + sin * d[1], -sin * d[0] + cos * d[1], d[2]].map(|v| v / self.mm_per_unit)
    }

    /// Program coordinates (mm, active system) → machine coordinates (mm): rotate about the
    /// system's origin, then offset, as LinuxCNC's canonical layer does.
    pub(super) fn program_to_machine(&self, p: [f64; 3]) -> [f64; 3] {
        let (sin, cos) = self.rotation_deg[self.coord_index].to_radians().sin_cos();
        let o = self.offset_mm();
        [
            cos * p[0] - sin * p[1] + o[0],
            sin * p[0] + cos * p[1] + o[1],
            p[2] + o[2],
        ]
    }

    /// Machine coordinates (mm) → program coordinates of the active system (mm).
    pub(super) fn machine_to_program(&self, m: [f64; 3]) -> [f64; 3] {
        let (sin, cos) = self.rotation_deg[self.coord_index].to_radians().sin_cos();
        let o = self.offset_mm();
        let (x, y) = (m[0] - o[0], m[1] - o[1]);
        [cos * x + sin * y, -sin * x + cos * y, m[2] - o[2]]
    }

    /// The block's X/Y/Z values in program millimetres, unnamed axes taken from `base`.
    fn block_point_mm(&self, base: [f64; 3], incremental: bool) -> [f64; 3] {
        let mut p = base;
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = self.block.get(letter) {
                let v_mm = v * self.mm_per_unit;
                p[i] = if incremental { p[i] + v_mm } else { v_mm };
            }
        }
        p
    }

    pub(super) fn g10(&mut self, offset: u32) -> IResult<()> {
        let l = self.block.get(b'L').map(|v| v.round() as i64);
        match l {
            Some(1 | 10 | 11) => Ok(()), // tool table: no effect on the XY path
            Some(l @ (2 | 20)) => {
                let p = self.block.get(b'P').map_or(0, |p| p.round() as i64);
                let index = match p {
                    0 => self.coord_index,
                    1..=9 => p as usize - 1,
                    _ => {
                        let msg = format!("G10 P{p}: no such coordinate system");
                        return err(offset, GcodeErrorKind::Invalid(msg));
                    }
                };
                if l == 2 {
                    self.g10_l2(index);
                } else {
                    self.g10_l20(index);
                }
                Ok(())
            }
            _ => err(
                offset,
                GcodeErrorKind::Invalid("G10 needs L1, L2, L10, L11 or L20".into()),
            ),
        }
    }

    /// G10 L2: set a system's origin (and rotation, R degrees) directly.
    fn g10_l2(&mut self, index: usize) {
        let origin = self.block_point_mm(self.work_offsets_mm[index], false);
        self.work_offsets_mm[index] = origin;
        if let Some(r) = self.block.get(b'R') {
            self.rotation_deg[index] = r;
        }
    }

    /// G10 L20: set a system's origin so that the current point has the given coordinates.
    fn g10_l20(&mut self, index: usize) {
        let saved = self.coord_index;
        self.coord_index = index;
        let wanted = self.block_point_mm(self.machine_to_program(self.pos_mm), false);
        let (sin, cos) = self.rotation_deg[index].to_radians().sin_cos();
        let rotated = [
            cos * wanted[0] - sin * wanted[1],
            sin * wanted[0] + cos * wanted[1],
            wanted[2],
        ];
        for (i, r) in rotated.iter().enumerate() {
            self.work_offsets_mm[index][i] = self.pos_mm[i] - self.g92_mm[i] - r;
        }
        self.coord_index = saved;
    }

    pub(super) fn g92(&mut self, offset: u32) -> IResult<()> {
        if !self.block.has_axis_words() {
            return err(
                offset,
                GcodeErrorKind::Invalid("G92 needs at least one axis word".into()),
            );
        }
        // Choose the G92 offset that gives the current point the named coordinates.
        let wanted = self.block_point_mm(self.machine_to_program(self.pos_mm), false);
        self.g92_mm = [0.0; 3];
        let unshifted = self.program_to_machine(wanted);
        for (i, u) in unshifted.iter().enumerate() {
            self.g92_mm[i] = self.pos_mm[i] - u;
        }
        self.g92_saved_mm = self.g92_mm;
        Ok(())
    }

    pub(super) fn g52(&mut self) {
        for (i, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = self.block.get(letter) {
                self.g92_mm[i] = v * self.mm_per_unit;
            }
        }
        self.g92_saved_mm = self.g92_mm;
    }

    /// G28/G30: a rapid to the optional intermediate point, then the named axes (all when
    /// none is named) to the stored home.
    pub(super) fn go_home(&mut self, code: u16) {
        let home = if code == 280 {
            self.opts.g28_home_mm
        } else {
            self.opts.g30_home_mm
        };
        let named = [b'X', b'Y', b'Z'].map(|l| self.block.get(l).is_some());
        if named.iter().any(|&n| n) {
            let via = self.target_mm(false);
            self.push_line(via, Motion::Rapid);
        }
        // The home position is in machine coordinates.
        let mut end = self.pos_mm;
        for i in 0..3 {
            if named[i] || !named.iter().any(|&n| n) {
                end[i] = home[i];
            }
        }
        self.push_line(end, Motion::Rapid);
    }

    /// The block's target point in machine coordinates (mm). Under G53 the values are
    /// machine coordinates themselves.
    pub(super) fn target_mm(&self, machine_coords: bool) -> [f64; 3] {
        if machine_coords {
            return self.block_point_mm(self.pos_mm, false);
        }
        let here = self.machine_to_program(self.pos_mm);
        self.program_to_machine(self.block_point_mm(here, !self.absolute))
    }
}
