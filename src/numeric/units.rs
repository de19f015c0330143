//! Unit conversions between the SI units used inside and the CNC units at the user's edges
//! (mm, mm/min, µm, m/min/mm). Every conversion in the crate goes through here.

/// Millimetres per inch (exact).
pub const MM_PER_INCH: f64 = 25.4;
/// Gravity used to turn friction coefficients into forces (m/s²). 9.81 rather than the
/// standard 9.80665: it is the value behind docs/model.md's f_c = 588.4 N and f_s − f_c = 76.5 N.
pub const GRAVITY_M_PER_S2: f64 = 9.81;

/// mm → m.
pub(crate) fn m_from_mm(mm: f64) -> f64 {
    mm * 1e-3
}

/// m → mm.
pub(crate) fn mm_from_m(m: f64) -> f64 {
    m * 1e3
}

/// m → µm.
pub(crate) fn um_from_m(m: f64) -> f64 {
    m * 1e6
}

/// µm → m.
pub(crate) fn m_from_um(um: f64) -> f64 {
    um * 1e-6
}

/// mm/min → m/s.
pub(crate) fn m_per_s_from_mm_per_min(mm_per_min: f64) -> f64 {
    mm_per_min / 60_000.0
}

/// m/s → mm/min.
pub(crate) fn mm_per_min_from_m_per_s(m_per_s: f64) -> f64 {
    m_per_s * 60_000.0
}

/// Position-loop gain: m/min/mm (the CNC's Kv, e.g. Siemens POSCTRL_GAIN) → 1/s.
/// 1 m/min of feed per mm of following error is (1/60 m/s) / (1e-3 m) = 16.667 1/s.
pub(crate) fn per_s_from_kv_m_per_min_per_mm(kv: f64) -> f64 {
    kv * 1000.0 / 60.0
}

/// Position-loop gain: 1/s → m/min/mm.
pub(crate) fn kv_m_per_min_per_mm_from_per_s(per_s: f64) -> f64 {
    per_s * 60.0 / 1000.0
}

/// ms → s.
pub(crate) fn s_from_ms(ms: f64) -> f64 {
    ms * 1e-3
}

/// mH → H.
pub(crate) fn h_from_mh(mh: f64) -> f64 {
    mh * 1e-3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kv_of_one_is_sixteen_point_six_seven_per_second() {
        assert!((per_s_from_kv_m_per_min_per_mm(1.0) - 16.666_666_666_666_668).abs() < 1e-12);
        // F/Kv: 500 mm/min at Kv = 1 lags 0.5 mm.
        let lag_m = m_per_s_from_mm_per_min(500.0) / per_s_from_kv_m_per_min_per_mm(1.0);
        assert!((mm_from_m(lag_m) - 0.5).abs() < 1e-12);
    }
}
