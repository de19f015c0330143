//! Signals sampled at a uniform step, evaluated between their samples: how a simulated trace
//! is read at a measurement's instants (by `diagnose`) and at a record's own clock (by
//! `synth`).

/// A signal sampled every `dt` at time `t`: cubic (Catmull–Rom) between samples, held
/// before the first and after the last.
pub(crate) fn sample(v: &[f64], dt: f64, t: f64) -> f64 {
    let n = v.len();
    if n == 0 {
        return 0.0;
    }
    let u = t / dt;
    if u <= 0.0 {
        return v[0];
    }
    let i = u.floor() as usize;
    if i + 1 >= n {
        return v[n - 1];
    }
    let f = u - i as f64;
    let p0 = v[i.saturating_sub(1)];
    let (p1, p2) = (v[i], v[i + 1]);
    let p3 = v[(i + 2).min(n - 1)];
    p1 + 0.5
        * f
        * (p2 - p0 + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)))
}
