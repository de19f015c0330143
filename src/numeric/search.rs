//! One-dimensional minimisation.

/// Golden-section minimum of `f` on [a, b] to a bracket of `tol`.
pub(crate) fn golden_section(mut a: f64, mut b: f64, tol: f64, f: &dyn Fn(f64) -> f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > tol {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_a_parabola_minimum_to_its_tolerance() {
        // Near a smooth minimum the values differ by the square of the distance: ties in
        // f64 below about √ε·|x| end the ranking there, whatever the bracket.
        let x = golden_section(-3.0, 5.0, 1e-9, &|x| (x - 1.25) * (x - 1.25) + 7.0);
        assert!((x - 1.25).abs() < 1e-7, "{x}");
        // A minimum at the bracket's wall is approached, not missed.
        let x = golden_section(0.0, 1.0, 1e-9, &|x| x);
        assert!(x < 1e-8, "{x}");
    }
}
