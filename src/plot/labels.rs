//! Where text goes on a plot so that no two labels overlap, none covers a marker, and none
//! is cut at the chart's edge: labels and legends are placed as boxes (pixels), estimated
//! generously from the font's size, and the first free place of a few candidates is taken.

/// A box in pixels: left, top, right, bottom.
pub type PixelBox = (i32, i32, i32, i32);

/// Width of a character as a share of the font's pixel size: DejaVu Sans averages about
/// 0.55 em; 0.62 leaves room for wide digits and "µ".
const CHAR_EM: f64 = 0.62;

/// The box a line of `text` in a `font_px` font takes with its top-left at `at`.
pub(crate) fn text_box(at: (i32, i32), text: &str, font_px: u32) -> PixelBox {
    let w = text_width(text, font_px);
    let h = font_px as i32 + 2;
    (at.0, at.1, at.0 + w, at.1 + h)
}

/// A generous width of `text` in a `font_px` font (px).
pub(crate) fn text_width(text: &str, font_px: u32) -> i32 {
    (CHAR_EM * f64::from(font_px) * text.chars().count() as f64).ceil() as i32
}

/// Whether two boxes share any pixel.
pub(crate) fn overlap(a: PixelBox, b: PixelBox) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Whether `inner` lies wholly inside `outer`.
pub(crate) fn inside(inner: PixelBox, outer: PixelBox) -> bool {
    inner.0 >= outer.0 && inner.1 >= outer.1 && inner.2 <= outer.2 && inner.3 <= outer.3
}

/// Half the size of a marker's box (px): markers are circles of radius 6–7.
const MARKER_HALF_PX: i32 = 8;

fn marker_box(p: (i32, i32)) -> PixelBox {
    (
        p.0 - MARKER_HALF_PX,
        p.1 - MARKER_HALF_PX,
        p.0 + MARKER_HALF_PX,
        p.1 + MARKER_HALF_PX,
    )
}

/// Where each marker's label goes (its top-left offset from the marker, px), in the order
/// given (the most important first): the first of a few places around the marker that
/// stays inside `bounds`, overlaps no label already placed, no marker and nothing in
/// `avoid`; `None` where every place is taken — that label is left out, its marker stays.
pub(crate) fn place_labels(
    at_px: &[(i32, i32)],
    labels: &[String],
    font_px: u32,
    bounds: PixelBox,
    avoid: &[PixelBox],
) -> Vec<Option<(i32, i32)>> {
    let mut taken: Vec<PixelBox> = avoid.to_vec();
    let markers: Vec<PixelBox> = at_px.iter().map(|&p| marker_box(p)).collect();
    at_px
        .iter()
        .zip(labels)
        .map(|(&at, label)| {
            let w = text_width(label, font_px);
            let h = font_px as i32 + 2;
            let gap = MARKER_HALF_PX + 2;
            let candidates = [
                (gap, -h - 4),
                (gap, 6),
                (-w - gap, -h - 4),
                (-w - gap, 6),
                (gap, -2 * h - 8),
                (-w - gap, h + 10),
                (-w / 2, -2 * h - 8),
                (-w / 2, h + 10),
                (gap, 2 * h + 12),
                (-w - gap, -2 * h - 8),
            ];
            let free = candidates.into_iter().find(|&(dx, dy)| {
                let b = text_box((at.0 + dx, at.1 + dy), label, font_px);
                inside(b, bounds)
                    && !taken.iter().any(|&t| overlap(b, t))
                    && !markers.iter().any(|&m| overlap(b, m))
            });
            if let Some((dx, dy)) = free {
                taken.push(text_box((at.0 + dx, at.1 + dy), label, font_px));
            }
            free
        })
        .collect()
}

/// The corner of `chart` (a box in px) for a legend of `size` (px): the first — upper
/// right, upper left, lower right, lower left — that covers none of `points` (px), else the
/// one that covers fewest. The legend is drawn under the data, so a point it must cover
/// still shows.
pub(crate) fn best_corner(chart: PixelBox, size: (i32, i32), points: &[(i32, i32)]) -> PixelBox {
    let pad = 10;
    let (w, h) = size;
    let corners = [
        (chart.2 - pad - w, chart.1 + pad),
        (chart.0 + pad, chart.1 + pad),
        (chart.2 - pad - w, chart.3 - pad - h),
        (chart.0 + pad, chart.3 - pad - h),
    ];
    let covered = |b: PixelBox| {
        points
            .iter()
            .filter(|&&p| overlap(b, (p.0 - 6, p.1 - 6, p.0 + 6, p.1 + 6)))
            .count()
    };
    corners
        .into_iter()
        .map(|(x, y)| (x, y, x + w, y + h))
        .min_by_key(|&b| covered(b))
        .expect("four corners")
}

/// The points of a polyline (px) every few pixels along it, so that a legend placed clear
/// of them is clear of the line, not only of its vertices.
pub(crate) fn along_polyline(points: &[(i32, i32)]) -> Vec<(i32, i32)> {
    let mut out = Vec::with_capacity(points.len());
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) / 6).clamp(1, 400);
        for k in 0..steps {
            let t = f64::from(k) / f64::from(steps);
            out.push((
                a.0 + (f64::from(b.0 - a.0) * t).round() as i32,
                a.1 + (f64::from(b.1 - a.1) * t).round() as i32,
            ));
        }
    }
    out.extend(points.last());
    out
}

/// The size (px) of a legend listing `entries` in a `font_px` font: a 24 px swatch between
/// 10 px gaps, the longest entry and a 10 px margin; a row per entry and 8 px above and below.
pub(crate) fn legend_size(entries: &[String], font_px: u32) -> (i32, i32) {
    let longest = entries
        .iter()
        .map(|e| text_width(e, font_px))
        .max()
        .unwrap_or(0);
    let row = font_px as i32 + 8;
    (longest + 54, row * entries.len() as i32 + 16)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_of_clustered_markers_never_overlap_nor_leave_the_chart() {
        // Ten hotspots, eight of them within a few pixels of one another (a corner hit
        // twice, the steady lag all round a circle), one by the chart's right edge.
        let at: Vec<(i32, i32)> = (0..10)
            .map(|i| match i {
                0..8 => (400 + 3 * i, 300 + 2 * i),
                8 => (800, 50),
                _ => (1190, 400),
            })
            .collect();
        let labels: Vec<String> = (0..10).map(|i| format!("{}: L{}", i + 1, 13 + i)).collect();
        let bounds = (0, 0, 1200, 800);
        let placed = place_labels(&at, &labels, 15, bounds, &[]);
        let boxes: Vec<PixelBox> = placed
            .iter()
            .zip(&at)
            .zip(&labels)
            .filter_map(|((o, &a), l)| o.map(|o| text_box((a.0 + o.0, a.1 + o.1), l, 15)))
            .collect();
        for (i, a) in boxes.iter().enumerate() {
            assert!(inside(*a, bounds), "{a:?}");
            for b in &boxes[i + 1..] {
                assert!(!overlap(*a, *b), "{a:?} overlaps {b:?}");
            }
            for &m in &at {
                assert!(
                    !overlap(*a, marker_box(m)),
                    "{a:?} covers the marker at {m:?}"
                );
            }
        }
        // The first ranks are always labelled; the far ones too, the edge one to its left.
        assert!(placed[0].is_some() && placed[1].is_some());
        assert!(placed[8].is_some());
        assert!(placed[9].is_some_and(|o| o.0 < 0), "{:?}", placed[9]);
    }

    #[test]
    fn a_legend_goes_where_no_point_is() {
        let chart = (100, 50, 1100, 750);
        let size = legend_size(&["max contour error".into(), "RMS".into()], 14);
        // Points along the top right (the last settings of a sweep): upper left is free.
        let points: Vec<(i32, i32)> = (0..10).map(|i| (700 + 40 * i, 60 + 5 * i)).collect();
        let b = best_corner(chart, size, &points);
        assert!(b.0 < 200 && b.1 < 100, "{b:?}");
        for p in &points {
            assert!(!overlap(b, (p.0 - 6, p.1 - 6, p.0 + 6, p.1 + 6)));
        }
        // A line from the lower left to the upper right, drawn by its two ends only: the
        // legend keeps clear of the whole line, not of its ends.
        let line = along_polyline(&[(110, 740), (1090, 60)]);
        let b = best_corner(chart, size, &line);
        assert!(
            line.iter()
                .all(|p| !overlap(b, (p.0 - 6, p.1 - 6, p.0 + 6, p.1 + 6)))
        );
        // Points in every corner, more in some: the corner with fewest.
        let crowded = [
            (1050, 70),
            (1040, 75),
            (150, 70),
            (160, 72),
            (1050, 730),
            (150, 730),
            (155, 735),
        ];
        let b = best_corner(chart, size, &crowded);
        assert!(b.0 > 600 && b.1 > 400, "{b:?}");
    }
}
