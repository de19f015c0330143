//! The table of G and M codes: which modal group each belongs to, and which are accepted,
//! refused (with the reason) or unknown. Codes are keyed by ten times their number, so that
//! `G90.1` is 901 and `G64` is 640.

/// What the interpreter does with a code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CodeClass {
    /// Understood; `group` is its modal group (0 = non-modal).
    Accepted {
        /// RS274/NGC modal group.
        group: u8,
    },
    /// Refused: it changes the XY path or its timing in a way the predictor does not model.
    Refused(&'static str),
    /// Not an RS274/NGC code.
    Unknown,
}

const CANNED: &str = "canned cycles are not supported: expand the cycle into explicit moves";
const CUTTER_COMP: &str =
    "cutter radius compensation changes the path: post the program with compensation applied";
const PROBE: &str = "probing moves depend on contact and cannot be predicted";
const THREAD: &str = "spindle-synchronised motion (threading) is not supported";
const SPLINE: &str = "spline and NURBS moves are not supported";

/// Classifies a G code (number × 10).
pub(crate) fn classify_g(code10: u16) -> CodeClass {
    use CodeClass::{Accepted, Refused, Unknown};
    match code10 {
        0 | 10 | 20 | 30 | 800 => Accepted { group: 1 },
        40 | 100 | 280 | 281 | 300 | 301 | 530 | 920 | 921 | 922 | 923 | 520 => {
            Accepted { group: 0 }
        }
        170 | 180 | 190 => Accepted { group: 2 },
        900 | 910 => Accepted { group: 3 },
        901 | 911 => Accepted { group: 4 },
        940 => Accepted { group: 5 },
        200 | 210 => Accepted { group: 6 },
        400 => Accepted { group: 7 },
        430 | 431 | 432 | 490 => Accepted { group: 8 },
        980 | 990 => Accepted { group: 10 },
        540..=590 if code10.is_multiple_of(10) => Accepted { group: 12 },
        591..=593 => Accepted { group: 12 },
        610 | 611 | 640 => Accepted { group: 13 },
        960 | 970 => Accepted { group: 14 },
        80 => Accepted { group: 15 },
        690 => Accepted { group: 16 },
        150 => Accepted { group: 17 },
        50 | 51 | 52 | 53 | 60 => Refused(SPLINE),
        70 => Refused("lathe diameter mode (G7) is not supported"),
        160 => Refused("polar coordinates (G16) are not supported"),
        310 | 382..=385 => Refused(PROBE),
        330 | 331 | 760 => Refused(THREAD),
        410 | 411 | 420 | 421 => Refused(CUTTER_COMP),
        500 | 510 => Refused("scaling (G50/G51) is not supported"),
        680 => Refused("coordinate rotation (G68) is not supported"),
        700..=720 if code10.is_multiple_of(10) => Refused(
            "G70–G72 are lathe finishing/roughing cycles (dialects that mean inch/metric by \
             G70/G71 should use G20/G21)",
        ),
        730 | 740 | 810..=890 if code10.is_multiple_of(10) => Refused(CANNED),
        930 => Refused("inverse-time feed (G93) is not supported"),
        950 => Refused("feed per revolution (G95) is not supported: the spindle is not modelled"),
        _ => Unknown,
    }
}

/// Classifies an M code (number × 10; M codes are whole numbers).
pub(crate) fn classify_m(code10: u16) -> CodeClass {
    use CodeClass::{Accepted, Refused, Unknown};
    if !code10.is_multiple_of(10) {
        return Unknown;
    }
    match code10 / 10 {
        0 | 1 | 2 | 30 | 60 => Accepted { group: 4 },
        6 | 61 => Accepted { group: 6 },
        3..=5 => Accepted { group: 7 },
        7..=9 => Accepted { group: 8 },
        48..=53 => Accepted { group: 9 },
        62..=65 | 67 | 68 => Accepted { group: 5 },
        100..=199 => Accepted { group: 10 },
        66 => Refused("M66 waits on an input for an unknown time"),
        70..=73 => Refused("saving and restoring modal state (M70–M73) is not supported"),
        98 | 99 => Refused("M98/M99 subprogram calls are not supported"),
        96 => Refused("M96 interrupts the program with a macro at an input: its path is unknown"),
        97 => Refused("M97 calls a subprogram of this file (a local subroutine): not supported"),
        _ => Unknown,
    }
}

/// Whole-number M codes the table does not know, with the lines they stand on: a machine's
/// own switching functions (clamps, doors, chip conveyors — M10, M11, M300), taken as not
/// moving the axes and listed in one warning, never silently. Codes that move or wait are
/// in the table as refused.
#[derive(Debug, Clone, Default)]
pub(crate) struct UnknownMCodes {
    seen: std::collections::BTreeMap<u16, Vec<u32>>,
}

/// Lines listed per code in the warning.
const LINES_LISTED: usize = 5;

impl UnknownMCodes {
    /// Notes M code `code10` (number × 10) on `line`.
    pub(crate) fn note(&mut self, code10: u16, line: u32) {
        let lines = self.seen.entry(code10).or_default();
        if lines.last() != Some(&line) {
            lines.push(line);
        }
    }

    /// The one warning listing them, with their lines; `None` when there were none.
    pub(crate) fn warning(&self) -> Option<String> {
        if self.seen.is_empty() {
            return None;
        }
        let listed: Vec<String> = self
            .seen
            .iter()
            .map(|(&code, lines)| {
                let mut shown: Vec<String> = lines
                    .iter()
                    .take(LINES_LISTED)
                    .map(u32::to_string)
                    .collect();
                if lines.len() > LINES_LISTED {
                    shown.push(format!("… {} in all", lines.len()));
                }
                let word = if lines.len() == 1 { "line" } else { "lines" };
                format!("{} ({word} {})", code_name('M', code), shown.join(", "))
            })
            .collect();
        Some(format!(
            "M codes this reader does not know, taken as the machine's own switching \
             functions that neither move nor hold the axes: {} — if one moves an axis or \
             waits, the prediction does not follow it",
            listed.join(", ")
        ))
    }
}

/// Writes a code as the user would: `G90.1`, `M3`.
pub(crate) fn code_name(letter: char, code10: u16) -> String {
    if code10.is_multiple_of(10) {
        format!("{letter}{}", code10 / 10)
    } else {
        format!("{letter}{}.{}", code10 / 10, code10 % 10)
    }
}

/// A short description of a code that is accepted but does not change the XY path, for the
/// plan's summary.
pub(crate) fn accepted_note(letter: char, code10: u16) -> Option<&'static str> {
    let note = match (letter, code10) {
        ('G', 400) => "cutter compensation off (no effect)",
        ('G', 430..=432) => "tool length offset (Z only; taken as zero)",
        ('G', 490) => "tool length offset cancelled",
        ('G', 800) => "canned cycle cancel",
        ('G', 80) => "lathe radius mode (no effect on a mill)",
        ('G', 150) => "polar coordinates off (no effect)",
        ('G', 690) => "coordinate rotation cancel (no effect)",
        ('G', 960 | 970) => "spindle speed mode (spindle not modelled)",
        ('G', 980 | 990) => "canned cycle return mode (no effect)",
        ('G', 540..=593) => "work offset selected (zero unless configured)",
        ('G', 920..=923) | ('G', 520) => "coordinate offset (G92/G52) applied",
        ('G', 530) => "move in machine coordinates",
        ('G', 280 | 300) => "return to home (a rapid to the configured home)",
        ('G', 281 | 301) => "home position stored",
        ('G', 100) => "coordinate system data set",
        ('M', 30 | 40 | 50) => "spindle (not modelled)",
        ('M', 60 | 610) => "tool change (taken as instantaneous)",
        ('M', 70..=90) => "coolant (not modelled)",
        ('M', 480..=530) => "override switches (assumed at 100 %)",
        ('M', 620..=680) => "digital/analog output (no motion)",
        ('M', 1000..=1990) => "user M code (assumed not to move the axes)",
        ('M', 0 | 10 | 600) => "program pause (a stop on the path)",
        _ => return None,
    };
    Some(note)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refused_codes_have_reasons_and_accepted_have_groups() {
        assert!(matches!(classify_g(410), CodeClass::Refused(_)));
        assert!(matches!(classify_g(830), CodeClass::Refused(_)));
        assert_eq!(classify_g(901), CodeClass::Accepted { group: 4 });
        assert_eq!(classify_g(592), CodeClass::Accepted { group: 12 });
        assert_eq!(classify_g(555), CodeClass::Unknown);
        assert_eq!(classify_m(3000), CodeClass::Unknown);
        assert_eq!(code_name('G', 901), "G90.1");
        // Subprogram calls and interrupts move the axes where the reader cannot follow.
        for m in [96, 97, 98, 99] {
            assert!(matches!(classify_m(10 * m), CodeClass::Refused(_)), "M{m}");
        }
    }

    #[test]
    fn unknown_m_codes_are_listed_once_with_their_lines() {
        let mut u = UnknownMCodes::default();
        assert_eq!(u.warning(), None);
        for (code, line) in [(100, 12), (110, 14), (100, 40), (100, 40), (3000, 9)] {
            u.note(code, line);
        }
        let text = u.warning().unwrap();
        assert!(
            text.contains("M10 (lines 12, 40), M11 (line 14), M300 (line 9)"),
            "{text}"
        );
        for l in 0..8 {
            u.note(100, 100 + l);
        }
        assert!(u.warning().unwrap().contains("… 10 in all"));
    }
}
