//! A function of one variable given by points: linear in between, held beyond the ends —
//! what a compensation table holds, and what the model's learned terms (a position map, a
//! friction map, a friction curve over speed) are.

/// Points (argument, value), arguments increasing; empty means zero everywhere.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lookup {
    points: Vec<(f64, f64)>,
}

impl Lookup {
    /// The function through `points` (arguments increasing, as the machine file's
    /// validation requires).
    pub(crate) fn new(points: Vec<(f64, f64)>) -> Lookup {
        Lookup { points }
    }

    /// From parallel lists of arguments and values, each scaled (to SI).
    pub(crate) fn scaled(at: &[f64], values: &[f64], at_scale: f64, value_scale: f64) -> Lookup {
        Lookup::new(
            at.iter()
                .zip(values)
                .map(|(&p, &v)| (p * at_scale, v * value_scale))
                .collect(),
        )
    }

    /// Whether it is zero everywhere.
    pub(crate) fn is_empty(&self) -> bool {
        self.points.iter().all(|p| p.1 == 0.0)
    }

    /// Its value at `p`.
    pub(crate) fn at(&self, p: f64) -> f64 {
        let m = &self.points;
        match m.partition_point(|&(at, _)| at <= p) {
            _ if m.is_empty() => 0.0,
            0 => m[0].1,
            i if i == m.len() => m[i - 1].1,
            i => {
                let ((p0, e0), (p1, e1)) = (m[i - 1], m[i]);
                e0 + (e1 - e0) * (p - p0) / (p1 - p0)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_between_points_and_held_beyond() {
        let f = Lookup::new(vec![(0.0, 1.0), (2.0, 3.0), (4.0, -1.0)]);
        assert_eq!(f.at(-5.0), 1.0);
        assert_eq!(f.at(1.0), 2.0);
        assert_eq!(f.at(3.0), 1.0);
        assert_eq!(f.at(9.0), -1.0);
        assert_eq!(Lookup::default().at(1.0), 0.0);
    }
}
