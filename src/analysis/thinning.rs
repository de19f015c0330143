//! A series of unknown length kept in bounded memory: cut into equal stretches, each kept as
//! its most telling sample (the largest error, the farthest radius), the stretches doubling
//! whenever the kept points reach their limit. Plots and circular-test figures built from it
//! keep every spike of a run of any length.

/// A series thinned to at most `2 × limit` points, each the sample of largest weight among
/// `stride` consecutive ones.
#[derive(Debug, Clone)]
pub struct PeakThinned<T> {
    points: Vec<T>,
    limit: usize,
    stride: usize,
    pending: Option<(T, f64)>,
    in_pending: usize,
    weight: fn(&T) -> f64,
}

impl<T: Copy> PeakThinned<T> {
    /// An empty series of at most about `limit` points, samples ranked by `weight` (NaN
    /// ranks lowest).
    pub(crate) fn new(limit: usize, weight: fn(&T) -> f64) -> Self {
        PeakThinned {
            points: Vec::new(),
            limit: limit.max(1),
            stride: 1,
            pending: None,
            in_pending: 0,
            weight,
        }
    }

    /// Takes the next sample.
    pub(crate) fn push(&mut self, p: T) {
        let w = self.rank(&p);
        if self.pending.is_none_or(|(_, best)| w > best) {
            self.pending = Some((p, w));
        }
        self.in_pending += 1;
        if self.in_pending < self.stride {
            return;
        }
        self.points.extend(self.pending.take().map(|(p, _)| p));
        self.in_pending = 0;
        if self.points.len() >= 2 * self.limit {
            let merged = self
                .points
                .chunks(2)
                .map(|pair| match pair {
                    [a, b] if self.rank(b) > self.rank(a) => *b,
                    _ => pair[0],
                })
                .collect();
            self.points = merged;
            self.stride *= 2;
        }
    }

    /// Samples stood for by each point.
    #[cfg(test)]
    pub(crate) fn stride(&self) -> usize {
        self.stride
    }

    /// The kept points, the last stretch's included even if incomplete.
    pub(crate) fn into_points(mut self) -> Vec<T> {
        self.points.extend(self.pending.take().map(|(p, _)| p));
        self.points
    }

    fn rank(&self, p: &T) -> f64 {
        let w = (self.weight)(p);
        if w.is_nan() { f64::NEG_INFINITY } else { w }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_series_keeps_its_spike_and_a_bounded_length() {
        let mut s = PeakThinned::new(100, |v: &(usize, f64)| v.1.abs());
        for k in 0..100_000 {
            let v = if k == 54_321 {
                -7.0
            } else {
                (k as f64 * 0.01).sin()
            };
            s.push((k, v));
        }
        // Doubled each time 200 points fill up: at 200, 400, … 51,200 samples.
        assert_eq!(s.stride(), 512);
        let points = s.into_points();
        assert!(points.len() <= 200, "{}", points.len());
        assert!(points.contains(&(54_321, -7.0)));
        // In order, one per stretch.
        assert!(points.windows(2).all(|w| w[1].0 > w[0].0));
    }

    #[test]
    fn a_short_series_is_kept_whole() {
        let mut s = PeakThinned::new(100, |v: &f64| *v);
        (0..150).for_each(|k| s.push(k as f64));
        assert_eq!(
            s.into_points(),
            (0..150).map(|k| k as f64).collect::<Vec<_>>()
        );
    }
}
