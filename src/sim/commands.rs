//! What drives a simulated axis: its commanded position, velocity and acceleration, one
//! entry per interpolation cycle. The planner writes them, recorded commands are read into
//! them, and the simulator only reads them, so the type lives with its reader.

/// Commands of one axis, one entry per interpolation cycle.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AxisCommands {
    /// Position x_ref (m).
    pub pos_m: Vec<f64>,
    /// Velocity v_ref (m/s).
    pub vel_m_per_s: Vec<f64>,
    /// Acceleration a_ref (m/s²).
    pub acc_m_per_s2: Vec<f64>,
}

impl AxisCommands {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.pos_m.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.pos_m.is_empty()
    }

    /// The first `n` samples (all of them where there are fewer).
    pub(crate) fn first(&self, n: usize) -> AxisCommands {
        let n = n.min(self.len());
        AxisCommands {
            pos_m: self.pos_m[..n].to_vec(),
            vel_m_per_s: self.vel_m_per_s[..n].to_vec(),
            acc_m_per_s2: self.acc_m_per_s2[..n].to_vec(),
        }
    }

    /// Appends the samples of `next`.
    pub(crate) fn append(&mut self, next: &AxisCommands) {
        self.pos_m.extend_from_slice(&next.pos_m);
        self.vel_m_per_s.extend_from_slice(&next.vel_m_per_s);
        self.acc_m_per_s2.extend_from_slice(&next.acc_m_per_s2);
    }

    /// Appends one sample: position (m), velocity (m/s), acceleration (m/s²).
    pub fn push(&mut self, p: f64, v: f64, a: f64) {
        self.pos_m.push(p);
        self.vel_m_per_s.push(v);
        self.acc_m_per_s2.push(a);
    }

    /// A constant-velocity ramp from `x0` at speed `v` (the paper's test input), `n` samples.
    pub fn ramp(x0_m: f64, v_m_per_s: f64, dt_s: f64, n: usize) -> AxisCommands {
        let mut c = AxisCommands::default();
        for k in 0..n {
            c.push(x0_m + v_m_per_s * k as f64 * dt_s, v_m_per_s, 0.0);
        }
        c
    }
}
