//! A model's figures against the record: the residual statistics of the nominal and the
//! extended model (per axis and on the contour, on the samples each is compared at), the
//! places where the nominal model's residual is largest, and the series the plots draw.
//! The diagnosis summarises each extended model it weighs this way, and reports the last.

use super::z_axis::ZSeries;
use super::{Place, ResidualStats, Series};
use crate::analysis::contour::{ContourSeries, contour_errors, contour_errors_in_space};
use crate::compare::Context;
use crate::compare::residual::axis_residual;
use crate::machine::AxisName;
use crate::numeric::units::{mm_from_m, um_from_m};
use crate::plan::Commands;
use crate::trace::signal::sample;

/// The measured contour error and a model's, sample by sample, as they can be compared: in
/// size alone where either lies beyond a segment's end, where the error has no side.
fn comparable_contours(measured: &ContourSeries, model: &ContourSeries) -> [Vec<f64>; 2] {
    let n = measured.error_m.len().min(model.error_m.len());
    let (mut a, mut b) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let (m, p) = (measured.error_m[k], model.error_m[k]);
        if measured.at_vertex[k] || model.at_vertex[k] {
            a.push(m.abs());
            b.push(p.abs());
        } else {
            a.push(m);
            b.push(p);
        }
    }
    [a, b]
}

/// The commands, the record and both models at the compared samples, on the program's
/// clock.
fn series_at_samples(
    ctx: &Context,
    nominal: &[Vec<f64>; 2],
    extended: &[Vec<f64>; 2],
    offset: f64,
) -> Series {
    let m = ctx.measured;
    let mut s = Series::default();
    for &i in &ctx.samples {
        let t = ctx.prog_time(i, offset);
        s.t_s.push(t);
        for a in 0..2 {
            let axis = AxisName::BOTH[a];
            s.reference[a].push(ctx.command_at(axis, t).0);
            s.measured[a].push(if a == 0 { m.x_m[i] } else { m.y_m[i] });
            s.nominal[a].push(sample(&nominal[a], ctx.dt, t));
            s.extended[a].push(sample(&extended[a], ctx.dt, t));
        }
    }
    s
}

/// A model's figures against the record.
pub(super) struct Summary {
    /// The nominal model's residual statistics.
    pub(super) before: ResidualStats,
    /// The extended model's.
    pub(super) after: ResidualStats,
    /// Where the nominal model's residual is largest.
    pub(super) places: Vec<Place>,
    /// The series for plots.
    pub(super) series: Series,
}

/// Residual statistics before and after, the places of the largest residuals, and the
/// series for plots.
pub(super) fn summarize(
    ctx: &Context,
    nominal: &[Vec<f64>; 2],
    extended: &[Vec<f64>; 2],
    offset: f64,
    window_s: f64,
    z: Option<&ZSeries>,
) -> Summary {
    let mut s = series_at_samples(ctx, nominal, extended, offset);
    // Contour errors of the three paths against the program's geometry, on the plan's clock:
    // in space where Z was compared and the program moves in space, as `check` measures them.
    let view = plan_view(ctx, &s.t_s);
    let z = z.filter(|_| ctx.plan.segments.iter().any(|g| g.is_contour_in_space()));
    s.contour_in_space = z.is_some();
    let contour_of = |xy: &[Vec<f64>; 2], z: Option<&[f64]>| match z {
        Some(z) => contour_errors_in_space(&ctx.plan, &view, [&xy[0], &xy[1], z]),
        None => contour_errors(&ctx.plan, &view, &xy[0], &xy[1]),
    };
    let (cm, cn, ce) = (
        contour_of(&s.measured, z.map(|z| z.measured.as_slice())),
        contour_of(&s.nominal, z.map(|z| z.nominal.as_slice())),
        contour_of(&s.extended, z.map(|z| z.extended.as_slice())),
    );
    s.path_s_m = cm.path_s_m.clone();
    s.segment = cm.segment.clone();
    s.command_segment = view.segment.clone();
    s.reference_z = view.z.pos_m.clone();
    let (vs_nominal, vs_extended) = (comparable_contours(&cm, &cn), comparable_contours(&cm, &ce));
    let diff = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x - y).collect() };
    s.contour_residual = [
        diff(&vs_nominal[0], &vs_nominal[1]),
        diff(&vs_extended[0], &vs_extended[1]),
    ];
    // Where an axis holds and hunts the contour residual is no comparison either.
    for r in &mut s.contour_residual {
        for (k, v) in r.iter_mut().enumerate() {
            if !AxisName::BOTH.iter().all(|&a| ctx.compared(a, k)) {
                *v = f64::NAN;
            }
        }
    }
    let events = AxisName::BOTH.map(|a| ctx.event_masks(a, offset, window_s).1);
    let either_event: Vec<bool> = events[0]
        .iter()
        .zip(&events[1])
        .map(|(a, b)| *a || *b)
        .collect();
    let (dt, sigma) = (ctx.sample_dt_s, ctx.noise_sigma);
    // Each axis on the samples it is compared at (not where it holds and hunts), the
    // contour where both are.
    let compared = AxisName::BOTH.map(|a| {
        (0..s.t_s.len())
            .filter(|&k| ctx.compared(a, k))
            .collect::<Vec<usize>>()
    });
    let stats = |model: &[Vec<f64>; 2], [contour_measured, contour_model]: &[Vec<f64>; 2]| {
        let axis = |a: usize| {
            let pick = |v: &[f64]| -> Vec<f64> { compared[a].iter().map(|&k| v[k]).collect() };
            axis_residual(
                &pick(&s.measured[a]),
                &pick(&model[a]),
                &compared[a]
                    .iter()
                    .map(|&k| events[a][k])
                    .collect::<Vec<_>>(),
                dt,
                sigma,
            )
        };
        // The contour error where both are defined (rapids have none).
        let keep: Vec<usize> = (0..contour_measured.len())
            .filter(|&k| contour_measured[k].is_finite() && contour_model[k].is_finite())
            .filter(|&k| AxisName::BOTH.iter().all(|&a| ctx.compared(a, k)))
            .collect();
        let pick = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&k| v[k]).collect() };
        let event: Vec<bool> = keep.iter().map(|&k| either_event[k]).collect();
        let contour = axis_residual(
            &pick(contour_measured),
            &pick(contour_model),
            &event,
            dt,
            sigma,
        );
        ResidualStats {
            x: axis(0),
            y: axis(1),
            contour,
        }
    };
    let before = stats(&s.nominal, &vs_nominal);
    let after = stats(&s.extended, &vs_extended);
    let places = places_of(ctx, &s, &view.segment, z.map(|z| z.measured.as_slice()));
    Summary {
        before,
        after,
        places,
        series: s,
    }
}

/// Where the nominal model's residual on X, on Y and on the contour is largest and clear
/// of the noise; `segment` gives each sample's plan segment, `z_m` the measured Z where the
/// contour is measured in space.
fn places_of(ctx: &Context, s: &Series, segment: &[u32], z_m: Option<&[f64]>) -> Vec<Place> {
    // An axis's residual where it is compared (not where it holds and hunts).
    let diff = |a: AxisName| -> Vec<f64> {
        (0..s.t_s.len())
            .map(|k| {
                if ctx.compared(a, k) {
                    s.measured[a.index()][k] - s.nominal[a.index()][k]
                } else {
                    f64::NAN
                }
            })
            .collect()
    };
    let mut places = Vec::new();
    for (what, r) in [
        ("x", diff(AxisName::X)),
        ("y", diff(AxisName::Y)),
        ("contour", s.contour_residual[0].clone()),
    ] {
        // Only residuals well clear of the noise are places worth naming.
        let clear: Vec<f64> = r
            .iter()
            .map(|v| {
                if v.abs() > 5.0 * ctx.noise_sigma {
                    *v
                } else {
                    f64::NAN
                }
            })
            .collect();
        for k in largest(&clear, &s.t_s, PLACES_PER_SERIES, 0.5) {
            places.push(Place {
                what: what.into(),
                t_s: s.t_s[k],
                t_record_s: ctx.measured.time_s(ctx.samples[k]),
                x_mm: mm_from_m(s.measured[0][k]),
                y_mm: mm_from_m(s.measured[1][k]),
                z_mm: z_m.map(|z| mm_from_m(z[k])).filter(|z| z.is_finite()),
                line: ctx.plan.segments[segment[k] as usize].line,
                residual_um: um_from_m(r[k]),
            });
        }
    }
    places
}

/// Places listed per residual series.
const PLACES_PER_SERIES: usize = 5;

/// Indices of the `count` largest |v| (finite), at least `apart_s` apart in time.
fn largest(v: &[f64], t_s: &[f64], count: usize, apart_s: f64) -> Vec<usize> {
    let mut order: Vec<usize> = (0..v.len()).filter(|&k| v[k].is_finite()).collect();
    order.sort_by(|&a, &b| v[b].abs().total_cmp(&v[a].abs()));
    let mut chosen: Vec<usize> = Vec::new();
    for k in order {
        if chosen.len() == count {
            break;
        }
        if chosen.iter().all(|&c| (t_s[c] - t_s[k]).abs() >= apart_s) {
            chosen.push(k);
        }
    }
    chosen
}

/// The commands sampled at the given simulation times (for the contour search).
fn plan_view(ctx: &Context, times: &[f64]) -> Commands {
    let pc = &ctx.commands;
    let mut v = Commands {
        dt_s: pc.dt_s,
        ..Default::default()
    };
    for &t in times {
        let k = (t / pc.dt_s).round().clamp(0.0, (pc.len() - 1) as f64) as usize;
        v.x.pos_m.push(sample(&pc.x.pos_m, pc.dt_s, t));
        v.y.pos_m.push(sample(&pc.y.pos_m, pc.dt_s, t));
        v.x.vel_m_per_s.push(pc.x.vel_m_per_s[k]);
        v.y.vel_m_per_s.push(pc.y.vel_m_per_s[k]);
        v.x.acc_m_per_s2.push(pc.x.acc_m_per_s2[k]);
        v.y.acc_m_per_s2.push(pc.y.acc_m_per_s2[k]);
        v.z.pos_m.push(pc.z.pos_m[k]);
        v.z.vel_m_per_s.push(pc.z.vel_m_per_s[k]);
        v.z.acc_m_per_s2.push(pc.z.acc_m_per_s2[k]);
        v.segment.push(pc.segment[k]);
    }
    v
}
