//! Prescribed motion laws `θ(t)` for driven joints, with their first two derivatives.
//!
//! A driven joint imposes `θ(t) − θ(0)` on a rotation (paper Section 4: an ideal motor
//! imposes a smooth joint trajectory). Two laws:
//!
//! * [`Trapezoidal`]: point-to-point with a trapezoidal velocity profile — constant
//!   acceleration `a` up to speed `v`, constant speed, deceleration `a` to rest (a
//!   triangular profile when the distance is too short to reach `v`);
//! * [`Table`]: user samples `(tᵢ, θᵢ)` joined by a clamped cubic spline, so velocity
//!   and acceleration are continuous; outside the table the motion continues with the
//!   end velocities (zero by default: at rest).

/// Angle, angular velocity and angular acceleration at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionState {
    /// `θ` (rad).
    pub angle: f64,
    /// `θ̇` (rad/s).
    pub velocity: f64,
    /// `θ̈` (rad/s²).
    pub acceleration: f64,
}

/// A motion law.
#[derive(Debug, Clone, PartialEq)]
pub enum Motion {
    /// Trapezoidal velocity profile.
    Trapezoidal(Trapezoidal),
    /// Interpolated table.
    Table(Table),
}

impl Motion {
    /// `θ`, `θ̇`, `θ̈` at time `t`.
    pub fn at(&self, t: f64) -> MotionState {
        match self {
            Self::Trapezoidal(law) => law.at(t),
            Self::Table(law) => law.at(t),
        }
    }

    /// When a point-to-point law stops accelerating, starts braking and has done its
    /// motion (s); `None` for a table, which goes on at its end velocity after its samples.
    pub fn phases(&self) -> Option<[f64; 3]> {
        match self {
            Self::Trapezoidal(law) => {
                let (t0, ta, tt) = (law.t0, law.t_acc, law.duration);
                Some([t0 + ta, t0 + tt - ta, t0 + tt])
            }
            Self::Table(_) => None,
        }
    }

    /// Times where the law is not smooth (its acceleration or jerk jumps), where a
    /// variable step should end: the phase changes of a trapezoidal law, a table's knots.
    pub fn kinks(&self) -> Vec<f64> {
        match self {
            Self::Trapezoidal(law) => {
                let (t0, ta, tt) = (law.t0, law.t_acc, law.duration);
                vec![t0, t0 + ta, t0 + tt - ta, t0 + tt]
            }
            Self::Table(law) => law.t.clone(),
        }
    }
}

/// Point-to-point motion with a trapezoidal (or triangular) velocity profile.
#[derive(Debug, Clone, PartialEq)]
pub struct Trapezoidal {
    start: f64,
    direction: f64,
    acceleration: f64,
    /// Peak speed actually reached.
    peak: f64,
    /// Start time of the motion.
    t0: f64,
    /// Duration of the acceleration (and deceleration) phase.
    t_acc: f64,
    /// Total duration.
    duration: f64,
}

impl Trapezoidal {
    /// From `start` to `end` (rad) with `acceleration` (rad/s², > 0) and maximum `speed`
    /// (rad/s, > 0), beginning at `t0` (s). Callers validate the positivity.
    pub fn new(start: f64, end: f64, acceleration: f64, speed: f64, t0: f64) -> Self {
        let distance = (end - start).abs();
        let (peak, t_acc, duration) = if distance * acceleration >= speed * speed {
            (
                speed,
                speed / acceleration,
                distance / speed + speed / acceleration,
            )
        } else {
            let t_acc = (distance / acceleration).sqrt();
            (acceleration * t_acc, t_acc, 2.0 * t_acc)
        };
        let direction = if end >= start { 1.0 } else { -1.0 };
        Self {
            start,
            direction,
            acceleration,
            peak,
            t0,
            t_acc,
            duration,
        }
    }

    /// Duration of the motion (s).
    pub fn duration(&self) -> f64 {
        self.duration
    }

    fn at(&self, t: f64) -> MotionState {
        let (a, v, ta, tt) = (self.acceleration, self.peak, self.t_acc, self.duration);
        let tau = (t - self.t0).clamp(0.0, tt);
        let (s, sd, sdd) = if t < self.t0 {
            (0.0, 0.0, 0.0)
        } else if tau < ta {
            (0.5 * a * tau * tau, a * tau, a)
        } else if tau <= tt - ta {
            (0.5 * a * ta * ta + v * (tau - ta), v, 0.0)
        } else {
            let rest = tt - tau;
            let full = 0.5 * a * ta * ta + v * (tt - 2.0 * ta) + 0.5 * a * ta * ta;
            let decel = if t - self.t0 > tt { 0.0 } else { -a };
            (full - 0.5 * a * rest * rest, a * rest, decel)
        };
        let k = self.direction;
        MotionState {
            angle: self.start + k * s,
            velocity: k * sd,
            acceleration: k * sdd,
        }
    }
}

/// A parameter of a [`Trapezoidal`] law.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LawParameter {
    /// Where it ends, `θ_end`.
    End,
    /// Its acceleration `a`.
    Acceleration,
    /// Its top speed `v` (no effect on a triangular profile).
    Speed,
}

impl Trapezoidal {
    /// `∂(θ, θ̇, θ̈)/∂p` at `t` for `p` one of its parameters (the start and `t0` held): with
    /// `s(τ)` the travel, `τ = t − t0`, `t_a` the acceleration phase and `T` the duration,
    /// `s = ½aτ²` while accelerating, `vτ − v²/2a` at speed, `D − ½a(T − τ)²` while
    /// decelerating (`T = D/v + v/a`, or `2√(D/a)` for a triangular profile), `D` after.
    pub fn rate(&self, t: f64, p: LawParameter) -> MotionState {
        let (a, v, ta, tt) = (self.acceleration, self.peak, self.t_acc, self.duration);
        let distance = tt * v - v * ta; // D, from T = D/v + t_a (t_a = v/a or the triangle's)
        let triangular = (tt - 2.0 * ta).abs() <= 1e-12 * tt;
        // ∂t_a/∂p and ∂T/∂p.
        let (ta_p, tt_p) = match (p, triangular) {
            (LawParameter::End, false) => (0.0, 1.0 / v),
            (LawParameter::Acceleration, false) => (-v / (a * a), -v / (a * a)),
            (LawParameter::Speed, false) => (1.0 / a, -distance / (v * v) + 1.0 / a),
            (LawParameter::End, true) => (ta / (2.0 * distance), ta / distance),
            (LawParameter::Acceleration, true) => (-ta / (2.0 * a), -ta / a),
            (LawParameter::Speed, true) => (0.0, 0.0),
        };
        let a_p = f64::from(u8::from(p == LawParameter::Acceleration));
        let d_p = f64::from(u8::from(p == LawParameter::End));
        let tau = t - self.t0;
        let (s, sd, sdd) = if tau < 0.0 {
            (0.0, 0.0, 0.0)
        } else if tau < ta {
            (0.5 * a_p * tau * tau, a_p * tau, a_p)
        } else if tau <= tt - ta {
            // s = ½ a t_a² + v(τ − t_a) with v = a t_a.
            let v_p = a_p * ta + a * ta_p;
            (
                0.5 * a_p * ta * ta + a * ta * ta_p + v_p * (tau - ta) - v * ta_p,
                v_p,
                0.0,
            )
        } else if tau <= tt {
            let rest = tt - tau;
            (
                d_p - 0.5 * a_p * rest * rest - a * rest * tt_p,
                a_p * rest + a * tt_p,
                -a_p,
            )
        } else {
            (d_p, 0.0, 0.0)
        };
        // The end moves the travel along the direction; the others scale it.
        let k = if p == LawParameter::End {
            1.0
        } else {
            self.direction
        };
        MotionState {
            angle: k * s,
            velocity: k * sd,
            acceleration: k * sdd,
        }
    }
}

/// Clamped cubic spline through `(tᵢ, θᵢ)` with prescribed end velocities.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    t: Vec<f64>,
    theta: Vec<f64>,
    /// Second derivatives at the knots.
    curvature: Vec<f64>,
    end_velocities: [f64; 2],
}

impl Table {
    /// Spline through the samples; `t` strictly increasing with at least two entries
    /// (validated by the caller).
    pub fn new(t: Vec<f64>, theta: Vec<f64>, end_velocities: [f64; 2]) -> Self {
        let curvature = clamped_spline_curvatures(&t, &theta, end_velocities);
        Self {
            t,
            theta,
            curvature,
            end_velocities,
        }
    }

    fn at(&self, t: f64) -> MotionState {
        let n = self.t.len();
        if t <= self.t[0] || t >= self.t[n - 1] {
            let (i, v) = if t <= self.t[0] {
                (0, self.end_velocities[0])
            } else {
                (n - 1, self.end_velocities[1])
            };
            return MotionState {
                angle: self.theta[i] + v * (t - self.t[i]),
                velocity: v,
                acceleration: 0.0,
            };
        }
        let k = self.t.partition_point(|&tk| tk <= t) - 1;
        let h = self.t[k + 1] - self.t[k];
        let (a, b) = ((self.t[k + 1] - t) / h, (t - self.t[k]) / h);
        let (m0, m1) = (self.curvature[k], self.curvature[k + 1]);
        let (y0, y1) = (self.theta[k], self.theta[k + 1]);
        MotionState {
            angle: a * y0 + b * y1 + ((a.powi(3) - a) * m0 + (b.powi(3) - b) * m1) * h * h / 6.0,
            velocity: (y1 - y0) / h - (3.0 * a * a - 1.0) * h * m0 / 6.0
                + (3.0 * b * b - 1.0) * h * m1 / 6.0,
            acceleration: a * m0 + b * m1,
        }
    }
}

/// Knot second derivatives `Mᵢ` of the clamped cubic spline: the tridiagonal system
/// `hᵢ₋₁Mᵢ₋₁ + 2(hᵢ₋₁ + hᵢ)Mᵢ + hᵢMᵢ₊₁ = 6(Δᵢ − Δᵢ₋₁)` with end rows from `θ'(t₀)`, `θ'(tₙ)`,
/// solved by the Thomas algorithm.
fn clamped_spline_curvatures(t: &[f64], y: &[f64], v: [f64; 2]) -> Vec<f64> {
    let n = t.len();
    let h: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let slope: Vec<f64> = (0..n - 1).map(|i| (y[i + 1] - y[i]) / h[i]).collect();
    let (mut sub, mut diag, mut sup, mut rhs) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    diag[0] = 2.0 * h[0];
    sup[0] = h[0];
    rhs[0] = 6.0 * (slope[0] - v[0]);
    for i in 1..n - 1 {
        sub[i] = h[i - 1];
        diag[i] = 2.0 * (h[i - 1] + h[i]);
        sup[i] = h[i];
        rhs[i] = 6.0 * (slope[i] - slope[i - 1]);
    }
    sub[n - 1] = h[n - 2];
    diag[n - 1] = 2.0 * h[n - 2];
    rhs[n - 1] = 6.0 * (v[1] - slope[n - 2]);
    for i in 1..n {
        let w = sub[i] / diag[i - 1];
        diag[i] -= w * sup[i - 1];
        rhs[i] -= w * rhs[i - 1];
    }
    let mut m = vec![0.0; n];
    m[n - 1] = rhs[n - 1] / diag[n - 1];
    for i in (0..n - 1).rev() {
        m[i] = (rhs[i] - sup[i] * m[i + 1]) / diag[i];
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The rates to the end, acceleration and speed against central differences of the
    /// law rebuilt, on trapezoidal and triangular profiles, forwards and backwards, in
    /// every phase and after.
    #[test]
    fn law_rates_equal_central_differences() {
        let laws = [
            (0.2, 1.4, 3.0, 1.5),
            (1.5, 0.2, 3.0, 1.5),
            (1.0, 0.7, 4.0, 2.0),
            (0.5, 0.6, 2.0, 5.0),
        ];
        for (start, end, acc, speed) in laws {
            let law = |p: LawParameter, h: f64| {
                let (mut e, mut a, mut v) = (end, acc, speed);
                match p {
                    LawParameter::End => e += h,
                    LawParameter::Acceleration => a += h,
                    LawParameter::Speed => v += h,
                }
                Trapezoidal::new(start, e, a, v, 0.1)
            };
            let base = law(LawParameter::End, 0.0);
            let times: Vec<f64> = (0..60).map(|k| 0.013 + k as f64 * 0.031).collect();
            for p in [
                LawParameter::End,
                LawParameter::Acceleration,
                LawParameter::Speed,
            ] {
                let h = 1e-6;
                for &t in &times {
                    let (up, down) = (law(p, h).at(t), law(p, -h).at(t));
                    let rate = base.rate(t, p);
                    let fd = [
                        (up.angle - down.angle) / (2.0 * h),
                        (up.velocity - down.velocity) / (2.0 * h),
                    ];
                    assert!((rate.angle - fd[0]).abs() < 1e-6, "{p:?} angle at {t}");
                    assert!((rate.velocity - fd[1]).abs() < 1e-5, "{p:?} rate at {t}");
                }
            }
        }
    }

    /// Central differences of the angle reproduce velocity and acceleration.
    fn assert_consistent(m: &Motion, times: &[f64]) {
        let eps = 1e-5;
        for &t in times {
            let (p, c, q) = (m.at(t + eps), m.at(t), m.at(t - eps));
            let v = (p.angle - q.angle) / (2.0 * eps);
            let a = (p.velocity - q.velocity) / (2.0 * eps);
            assert!(
                (v - c.velocity).abs() < 1e-7,
                "t = {t}: velocity {} vs {v}",
                c.velocity
            );
            assert!(
                (a - c.acceleration).abs() < 1e-6,
                "t = {t}: acceleration {} vs {a}",
                c.acceleration
            );
        }
    }

    #[test]
    fn trapezoidal_reference_motion() {
        // Paper Section 4: π/3 → π/2, 2 rad/s², 0.5 rad/s: T = (π/6)/0.5 + 0.5/2.
        let law = Trapezoidal::new(PI / 3.0, PI / 2.0, 2.0, 0.5, 0.0);
        assert!((law.duration() - ((PI / 6.0) / 0.5 + 0.25)).abs() < 1e-14);
        let m = Motion::Trapezoidal(law.clone());
        assert_eq!(m.at(0.1).acceleration, 2.0);
        assert_eq!(m.at(0.6).velocity, 0.5);
        assert!((m.at(1.3).angle - PI / 2.0).abs() < 1e-14);
        assert!((m.at(5.0).angle - PI / 2.0).abs() < 1e-14);
        assert_eq!(m.at(5.0).velocity, 0.0);
        assert_consistent(&m, &[0.05, 0.2, 0.7, 1.1, 1.25]);
        // Velocity is continuous across the phase changes.
        for tb in [0.25, law.duration() - 0.25] {
            assert!((m.at(tb - 1e-9).velocity - m.at(tb + 1e-9).velocity).abs() < 1e-8);
        }
    }

    #[test]
    fn short_moves_are_triangular() {
        let m = Motion::Trapezoidal(Trapezoidal::new(1.0, 0.9, 2.0, 5.0, 0.5));
        let t_acc = (0.1f64 / 2.0).sqrt();
        assert!((m.at(0.5 + t_acc).velocity + 2.0 * t_acc).abs() < 1e-12);
        assert!((m.at(10.0).angle - 0.9).abs() < 1e-14);
        assert_consistent(&m, &[0.6, 0.5 + 1.5 * t_acc]);
    }

    #[test]
    fn table_spline_interpolates_with_continuous_acceleration() {
        let t = vec![0.0, 0.3, 0.5, 1.0, 1.4];
        let y = vec![0.0, 0.2, 0.1, 0.6, 0.6];
        let m = Motion::Table(Table::new(t.clone(), y.clone(), [0.0, 0.0]));
        for (ti, yi) in t.iter().zip(&y) {
            assert!((m.at(*ti).angle - yi).abs() < 1e-14);
        }
        assert!(m.at(0.0).velocity.abs() < 1e-12 && m.at(1.4).velocity.abs() < 1e-12);
        for &tk in &t[1..4] {
            let jump = m.at(tk + 1e-10).acceleration - m.at(tk - 1e-10).acceleration;
            assert!(jump.abs() < 1e-6, "acceleration jumps by {jump} at {tk}");
        }
        assert_consistent(&m, &[0.1, 0.4, 0.77, 1.2]);
    }

    #[test]
    fn table_reproduces_a_cubic_exactly() {
        let f = |t: f64| 0.5 + t - 2.0 * t * t + 0.7 * t.powi(3);
        let df = |t: f64| 1.0 - 4.0 * t + 2.1 * t * t;
        let t: Vec<f64> = (0..6)
            .map(|i| 0.2 * i as f64 + 0.03 * (i * i) as f64)
            .collect();
        let y = t.iter().map(|&ti| f(ti)).collect();
        let m = Motion::Table(Table::new(t.clone(), y, [df(t[0]), df(t[5])]));
        for s in [0.05, 0.33, 0.61, 0.99, 1.4] {
            assert!((m.at(s).angle - f(s)).abs() < 1e-12);
        }
    }
}
