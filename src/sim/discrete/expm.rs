//! The exponentials of one matrix scaled by 2⁻⁰, 2⁻¹, … 2⁻ᴷ, sharing their work.
//!
//! Each exponential is the scaling-and-squaring method with Padé approximants of order 3, 5, 7,
//! 9 or 13 chosen from norms of the matrix's powers (Al-Mohy and Higham, SIAM J. Matrix Anal.
//! Appl. 31 (2009) 970–989), evaluated in the order nalgebra 0.34's `Matrix::exp` evaluates it,
//! so that each level's result is the one that function gives for that level's matrix.
//!
//! Scaling a matrix by a power of two is exact in binary floating point, and so is every
//! product and sum of scaled operands (each result is the unscaled one times a power of two,
//! rounded the same way) as long as nothing leaves the normal range. Hence:
//! - the powers M², M⁴, … of the level-k matrix are those of level 0 times 2^(−2k), 2^(−4k), …,
//!   so they are formed once, not at every level;
//! - where level k needs s squarings, its order-13 approximant is taken of M·2^−(k+s). The
//!   coarser levels usually choose s one larger per level, landing on the same matrix: its
//!   approximant is solved once, and level k − 1's exponential is level k's squared — the
//!   product the method would have formed anyway, not an extra one (where rounding picks
//!   another s, the scale 2^−(k+s) is another key, computed on its own).
//!
//! The only error this adds is where the normal range is left: an entry below ~10⁻³⁰⁸ (a
//! product of a power and a scale of up to 2⁻²⁴⁰) is rounded as a subnormal, an absolute
//! change of at most ~10⁻³²³ against entries of order one. The tests compare every level with
//! nalgebra's exponential of that level's matrix. Dynamics no machine has — an infinite
//! entry, or powers that overflow — give a map that is not finite at once (the simulation
//! reports it), rather than squarings without end.

use nalgebra::{SMatrix, SVector};

use super::super::model::NA;

/// A square matrix of the augmented state's size.
pub(super) type Square = SMatrix<f64, NA, NA>;

/// Denominators of the Padé approximants' coefficients (Higham 2005, table 10.4): the
/// approximant of order m is b_0 … b_m, the odd ones building U, the even ones V.
const B3: [f64; 4] = [120.0, 60.0, 12.0, 1.0];
const B5: [f64; 6] = [30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0];
const B7: [f64; 8] = [
    17_297_280.0,
    8_648_640.0,
    1_995_840.0,
    277_200.0,
    25_200.0,
    1_512.0,
    56.0,
    1.0,
];
const B9: [f64; 10] = [
    17_643_225_600.0,
    8_821_612_800.0,
    2_075_673_600.0,
    302_702_400.0,
    30_270_240.0,
    2_162_160.0,
    110_880.0,
    3_960.0,
    90.0,
    1.0,
];
const B13: [f64; 14] = [
    64_764_752_532_480_000.0,
    32_382_376_266_240_000.0,
    7_771_770_303_897_600.0,
    1_187_353_796_428_800.0,
    129_060_195_264_000.0,
    10_559_470_521_600.0,
    670_442_572_800.0,
    33_522_128_640.0,
    1_323_241_920.0,
    40_840_800.0,
    960_960.0,
    16_380.0,
    182.0,
    1.0,
];

/// Largest norm estimates for which the orders 3, 5, 7, 9 reach unit roundoff (Al-Mohy and
/// Higham 2009, table 3.1), and the one order 13 is scaled to.
const THETA: [f64; 4] = [
    1.495_585_217_958_292e-2,
    2.539_398_330_063_23e-1,
    9.504_178_996_162_932e-1,
    2.097_847_961_257_068e0,
];
const THETA_13: f64 = 4.25;

/// The most squarings an order-13 approximant is taken for: with a level's k ≤ 24 its scale
/// j = k + s ≤ 124 keeps 2^−6j (its sixth power's scaling) within the normal range.
const MAX_SCALE: i32 = 100;

/// 2^e, exactly (e within the normal range).
fn pow2(e: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&e));
    f64::from_bits(((1023 + e) as u64) << 52)
}

/// The largest column sum of absolute values.
fn one_norm(m: &Square) -> f64 {
    m.column_iter()
        .map(|c| c.iter().fold(0.0, |a, b| a + b.abs()))
        .fold(0.0, f64::max)
}

/// n! for n ≤ 34.
fn factorial(n: usize) -> u128 {
    (1..=n as u128).product()
}

/// How many extra squarings keep the order-m approximant's rounding below unit roundoff
/// (Al-Mohy and Higham 2009, algorithm 3.1's ℓ): from the 1-norm of |M|^(2m+1), found by
/// products with a vector of ones.
fn extra_squarings(m: &Square, order: usize) -> u64 {
    let abs_t = m.map(f64::abs).transpose();
    let mut v = SVector::<f64, NA>::repeat(1.0);
    for _ in 0..2 * order + 1 {
        v = abs_t * v;
    }
    let abs_norm = v.max();
    if abs_norm == 0.0 {
        return 0;
    }
    let f = factorial(order);
    let c_recip = factorial(2 * order) / (f * f) * factorial(2 * order + 1);
    let alpha = abs_norm / one_norm(m) / c_recip as f64;
    let value = ((alpha / 2_f64.powf(-53.0)).log2() / (2.0 * order as f64)).ceil();
    if value > 0.0 { value as u64 } else { 0 }
}

/// [P; Q] ↦ Q⁻¹P with P = U + V, Q = V − U: the approximant itself. A singular Q (only from
/// non-finite dynamics) gives non-finite entries, which the simulation reports.
fn solve(u: Square, v: Square) -> Square {
    let p = u + v;
    let q = v - u;
    q.lu().solve(&p).unwrap_or_else(|| Square::repeat(f64::NAN))
}

/// One matrix's exponentials at every dyadic scale, each computed when first asked for.
pub(super) struct DyadicExp {
    /// The level-0 matrix and its powers M², M⁴, M⁶, M⁸, M¹⁰ as formed.
    a: Square,
    powers: [Option<Square>; 5],
    /// Order-13 approximants by the scale 2^−j they were taken at, each with its squares.
    squared: Vec<(i32, Vec<Square>)>,
    /// The squarings formed, those let go included.
    squarings: usize,
    /// The approximant's order each level took (0 where the map is not finite), as asked.
    #[cfg(test)]
    pub(super) orders: Vec<(usize, usize)>,
}

impl DyadicExp {
    pub(super) fn new(a: Square) -> Self {
        DyadicExp {
            a,
            powers: [None; 5],
            squared: Vec::new(),
            squarings: 0,
            #[cfg(test)]
            orders: Vec::new(),
        }
    }

    /// The squarings formed so far (shared by the levels that needed them).
    #[cfg(test)]
    pub(super) fn squarings(&self) -> usize {
        self.squarings
    }

    /// Lets go of the shared powers, approximants and squares (most of the memory: some
    /// 15 to 100 kB), where no level is asked for again. A level asked for after all forms
    /// them again from the matrix, as it would have the first time.
    pub(super) fn release(&mut self) {
        self.powers = [None; 5];
        self.squared = Vec::new();
    }

    /// Whether the shared products are held.
    #[cfg(test)]
    pub(super) fn holds_products(&self) -> bool {
        self.powers.iter().any(Option::is_some) || !self.squared.is_empty()
    }

    /// M^(2i+2) of level 0, formed as the method forms it (M⁴ = M²·M², M⁶ = M⁴·M²,
    /// M⁸ = M⁶·M², M¹⁰ = M⁶·M⁴).
    fn power(&mut self, i: usize) -> Square {
        if let Some(p) = self.powers[i] {
            return p;
        }
        let p = match i {
            0 => self.a * self.a,
            1 => self.power(0) * self.power(0),
            2 => self.power(1) * self.power(0),
            3 => self.power(2) * self.power(0),
            _ => self.power(2) * self.power(1),
        };
        self.powers[i] = Some(p);
        p
    }

    /// M^(2i+2) of level k.
    fn scaled_power(&mut self, i: usize, k: i32) -> Square {
        self.power(i) * pow2(-(2 * i as i32 + 2) * k)
    }

    /// ‖M^(2i+2)‖₁^(1/(2i+2)) of level k.
    fn norm_root(&mut self, i: usize, k: i32) -> f64 {
        let root = [0.25, 1.0 / 6.0, 1.0 / 8.0, 1.0 / 10.0][i - 1];
        (one_norm(&self.power(i)) * pow2(-(2 * i as i32 + 2) * k)).powf(root)
    }

    /// exp(M·2^−k); not finite where M is not, or where its norm (above ~10²³ at the
    /// finest level, no machine's dynamics) would need more squarings than the exact scalings
    /// by powers of two allow.
    pub(super) fn at(&mut self, k: usize) -> Square {
        let (e, _order) = self.with_order(k);
        #[cfg(test)]
        self.orders.push((k, _order));
        e
    }

    /// [`DyadicExp::at`] and the order of the approximant taken (0 where it is not finite).
    fn with_order(&mut self, k: usize) -> (Square, usize) {
        let not_finite = (Square::repeat(f64::NAN), 0);
        if !self.a.iter().all(|v| v.is_finite()) {
            return not_finite;
        }
        let k = k as i32;
        let m = self.a * pow2(-k);
        let d4 = self.norm_root(1, k);
        let d6 = self.norm_root(2, k);
        let eta_1 = d4.max(d6);
        if eta_1 < THETA[0] && extra_squarings(&m, 3) == 0 {
            return (self.low_order(&m, k, &B3), 3);
        }
        if eta_1 < THETA[1] && extra_squarings(&m, 5) == 0 {
            return (self.low_order(&m, k, &B5), 5);
        }
        let d8 = self.norm_root(3, k);
        let eta_3 = d6.max(d8);
        if eta_3 < THETA[2] && extra_squarings(&m, 7) == 0 {
            return (self.low_order(&m, k, &B7), 7);
        }
        if eta_3 < THETA[3] && extra_squarings(&m, 9) == 0 {
            return (self.low_order(&m, k, &B9), 9);
        }
        let eta_4 = d8.max(self.norm_root(4, k));
        let eta_5 = eta_3.min(eta_4);
        if !eta_5.is_finite() {
            // Finite entries whose powers overflow: no number of squarings brings them back.
            return not_finite;
        }
        let mut s = if eta_5 == 0.0 {
            0
        } else {
            let l2 = (eta_5 / THETA_13).log2().ceil();
            if l2 < 0.0 { 0 } else { l2 as u64 }
        };
        s = s.saturating_add(extra_squarings(&(m * 2_f64.powf(-(s as f64))), 13));
        // The order-13 matrix's scale 2^−j enters as 2^−6j in its sixth power: j stays where
        // that is a normal number.
        if s > MAX_SCALE as u64 {
            return not_finite;
        }
        (self.squared_order13(k + s as i32, s as usize), 13)
    }

    /// The approximant of order 3, 5, 7 or 9 (its coefficients `b`) at level k: U = M·Σ
    /// b_(2i+1) M^(2i), V = Σ b_(2i) M^(2i), summed from the highest power down.
    fn low_order(&mut self, m: &Square, k: i32, b: &[f64]) -> Square {
        let ident = Square::identity();
        let highest = b.len() / 2 - 1;
        let mut u_sum = self.scaled_power(highest - 1, k) * b[2 * highest + 1];
        let mut v_sum = self.scaled_power(highest - 1, k) * b[2 * highest];
        for i in (1..highest).rev() {
            let p = self.scaled_power(i - 1, k);
            u_sum += p * b[2 * i + 1];
            v_sum += p * b[2 * i];
        }
        let u = m * (u_sum + ident * b[1]);
        let v = v_sum + ident * b[0];
        solve(u, v)
    }

    /// The order-13 approximant at the scale 2^−j squared s times.
    fn squared_order13(&mut self, j: i32, s: usize) -> Square {
        let at = match self.squared.iter().position(|(scale, _)| *scale == j) {
            Some(at) => at,
            None => {
                let x = self.order13(j);
                self.squared.push((j, vec![x]));
                self.squared.len() - 1
            }
        };
        let squares = &mut self.squared[at].1;
        while squares.len() <= s {
            let x = *squares.last().expect("never empty");
            squares.push(x * x);
            self.squarings += 1;
        }
        squares[s]
    }

    /// The order-13 approximant of M·2^−j, with the powers of its matrix scaled from level 0's.
    fn order13(&mut self, j: i32) -> Square {
        let b = &B13;
        let ident = Square::identity();
        let mb = self.a * pow2(-j);
        let mb2 = self.scaled_power(0, j);
        let mb4 = self.scaled_power(1, j);
        let mb6 = self.scaled_power(2, j);
        let u2 = mb6 * (mb6 * b[13] + mb4 * b[11] + mb2 * b[9]);
        let u = mb * (u2 + mb6 * b[7] + mb4 * b[5] + mb2 * b[3] + ident * b[1]);
        let v2 = mb6 * (mb6 * b[12] + mb4 * b[10] + mb2 * b[8]);
        let v = v2 + mb6 * b[6] + mb4 * b[4] + mb2 * b[2] + ident * b[0];
        solve(u, v)
    }
}
