//! Rows that are one place: where the contour error is a plateau along a stretch (the
//! radius loss all round a circle, a mismatch's offset along a line), the events that flag
//! it several times give near-identical rows. They are merged into the largest of them,
//! with the stretch they cover, so that the list names each place once.

use serde::Serialize;

use super::hotspot::Hotspot;

/// The stretch a merged row stands for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Extent {
    /// How many rows were merged into this one.
    pub places: usize,
    /// Time of the first (s).
    pub from_t_s: f64,
    /// Time of the last (s).
    pub to_t_s: f64,
    /// Source line of the first.
    pub from_line: u32,
    /// Source line of the last.
    pub to_line: u32,
}

impl Extent {
    /// The extent of one row.
    pub(crate) fn of(h: &Hotspot) -> Extent {
        Extent {
            places: 1,
            from_t_s: h.t_s,
            to_t_s: h.t_s,
            from_line: h.line,
            to_line: h.line,
        }
    }

    /// This extent grown by `other`.
    fn join(self, other: Extent) -> Extent {
        let (from_t_s, from_line) = if other.from_t_s < self.from_t_s {
            (other.from_t_s, other.from_line)
        } else {
            (self.from_t_s, self.from_line)
        };
        let (to_t_s, to_line) = if other.to_t_s > self.to_t_s {
            (other.to_t_s, other.to_line)
        } else {
            (self.to_t_s, self.to_line)
        };
        Extent {
            places: self.places + other.places,
            from_t_s,
            to_t_s,
            from_line,
            to_line,
        }
    }
}

/// Two errors are near-identical within 3 % of the larger or 0.05 µm, and of one sign: a
/// plateau's entry seen a few samples early, or its level where friction leaves a little
/// on it, against the level itself.
fn near_identical(a_um: f64, b_um: f64) -> bool {
    a_um.signum() == b_um.signum()
        && (a_um - b_um).abs() <= (0.03 * a_um.abs().max(b_um.abs())).max(0.05)
}

/// Merges the rows of one stretch with one plateau cause and near-identical errors into the
/// largest of them (its place, the others' extent); spikes stay rows of their own.
pub(crate) fn merge_plateaus(spots: &mut Vec<Hotspot>) {
    spots.sort_by_key(|h| h.sample);
    let mut kept: Vec<Hotspot> = Vec::with_capacity(spots.len());
    for h in spots.drain(..) {
        let same = kept.iter_mut().rev().find(|k| {
            h.cause.is_plateau()
                && k.cause == h.cause
                && k.stretch == h.stretch
                && near_identical(k.error_um, h.error_um)
        });
        match same {
            Some(k) => {
                let extent = k.extent.unwrap_or_else(|| Extent::of(k));
                let grown = extent.join(h.extent.unwrap_or_else(|| Extent::of(&h)));
                if h.error_um.abs() > k.error_um.abs() {
                    *k = h;
                }
                k.extent = Some(grown);
            }
            None => kept.push(h),
        }
    }
    *spots = kept;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::hotspot_cause::Cause;
    use crate::machine::AxisName;

    fn spot(sample: usize, error_um: f64, cause: Cause, stretch: u32) -> Hotspot {
        Hotspot {
            sample,
            t_s: sample as f64 * 0.1,
            x_mm: 0.0,
            y_mm: 0.0,
            z_mm: None,
            line: 10 + sample as u32,
            error_um,
            path_mm: 0.0,
            excess_um: 0.0,
            cause,
            extent: None,
            stretch,
        }
    }

    #[test]
    fn a_plateau_flagged_often_is_one_row_and_spikes_stay_apart() {
        let lag = Cause::SteadyLag;
        let reversal = Cause::AxisReversal { axis: AxisName::X };
        let mut spots = vec![
            spot(1, 5.04, lag, 0),
            spot(2, 5.07, lag, 0),
            spot(3, 3.20, reversal, 0),
            spot(4, 5.04, lag, 0),
            spot(5, 3.20, reversal, 0),
            // The other circle: its own stretch.
            spot(6, 5.04, lag, 1),
            // Of the other sign: not the same plateau.
            spot(7, -5.04, lag, 1),
            // 10 % larger: a plateau of its own.
            spot(8, 5.6, lag, 1),
            // 4 % smaller than the first's largest: apart.
            spot(9, 4.85, lag, 0),
        ];
        merge_plateaus(&mut spots);
        assert_eq!(spots.len(), 7, "{spots:#?}");
        let first = &spots[0];
        assert_eq!(first.error_um, 5.07);
        let e = first.extent.unwrap();
        assert_eq!((e.places, e.from_line, e.to_line), (3, 11, 14));
        assert!((e.from_t_s - 0.1).abs() < 1e-12 && (e.to_t_s - 0.4).abs() < 1e-12);
        assert_eq!(spots.iter().filter(|h| h.cause == reversal).count(), 2);
        assert!(spots[3..].iter().all(|h| h.extent.is_none()));
        assert_eq!(spots.last().unwrap().error_um, 4.85);
    }
}
