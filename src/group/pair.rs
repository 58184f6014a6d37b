//! Two anchors — each a point of a body or of the ground — and the vectors a joint or a
//! force element measures between them, with their derivatives on the two nodes' increments
//! (right-trivialized, `δq = q ε̃`):
//!
//! | measure | value | gradient on its node `(u, θ)` | `∂(Jᵀc)/∂θ` | `α̈ − J v̇` |
//! |---|---|---|---|---|
//! | a constant `e` | `e` | — | — | 0 |
//! | an axis `u` of a body | `R u` | `[0, −R ũ]` | `ũ (Rᵀc)~` | `R Ω̃Ω̃ u` |
//! | a point `a` of a body | `x + R a` | `[I, −R ã]` | `ã (Rᵀc)~` | `R Ω̃Ω̃ a` |
//! | the gap `p_B − p_A` | | the points' | the points' | the points' |
//!
//! (and, for a damper along the gap, `∂(J v)/∂θ = −R (Ω × a)~` of each point), and the dot
//! product of two measures, whose gradient is `J_αᵀβ + J_βᵀα` and Hessian
//! `H_α[β] + H_β[α] + J_αᵀJ_β + J_βᵀJ_α`. Local unknowns are A's node's six then B's.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::group::so3::hat;
use crate::group::{six, split, Frame};

/// A joint's local unknowns: its two nodes' six each.
pub(crate) const LOCAL: usize = 12;

pub(crate) type Jacobian = SMatrix<f64, 3, LOCAL>;
/// Derivatives on the local unknowns, `12 × 12`.
pub(crate) type Stiffness = SMatrix<f64, LOCAL, LOCAL>;

/// A node's configuration and rates as a pair reads them; the ground's is the identity at
/// rest.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Side {
    pub x: Vector3<f64>,
    pub r: Matrix3<f64>,
    pub omega: Vector3<f64>,
    /// The linear velocity, inertial frame.
    pub u: Vector3<f64>,
}

impl Side {
    fn read(node: Option<usize>, q: &[f64], v: Option<&[f64]>) -> Self {
        let Some(n) = node else {
            return Self {
                x: Vector3::zeros(),
                r: Matrix3::identity(),
                omega: Vector3::zeros(),
                u: Vector3::zeros(),
            };
        };
        let f = Frame::read(q, n);
        let (u, omega) = v.map_or((Vector3::zeros(), Vector3::zeros()), |v| split(&six(v, n)));
        Self {
            x: f.x,
            r: f.rotation(),
            omega,
            u,
        }
    }
}

/// A vector between the anchors (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Measure {
    Constant(Vector3<f64>),
    /// An axis of side 0 (A) or 1 (B), in that side's frame.
    Axis(usize, Vector3<f64>),
    /// The gap `p_B − p_A`.
    Gap,
}

/// A measure's value, Jacobian, velocity `J v` and `α̈ − J v̇`.
pub(crate) struct Evaluated {
    pub value: Vector3<f64>,
    pub jacobian: Jacobian,
    pub rate: Vector3<f64>,
    pub term: Vector3<f64>,
}

/// Two anchors: their nodes (`None`: the ground) and points (in the nodes' frames, the
/// ground's in the inertial one).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Pair {
    pub nodes: [Option<usize>; 2],
    pub arms: [Vector3<f64>; 2],
}

impl Pair {
    /// The nodes the pair holds, with their place (0: A, 1: B) among its local unknowns.
    pub fn local_nodes(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..2).filter_map(|s| self.nodes[s].map(|n| (s, n)))
    }

    pub fn sides(&self, q: &[f64], v: Option<&[f64]>) -> [Side; 2] {
        [
            Side::read(self.nodes[0], q, v),
            Side::read(self.nodes[1], q, v),
        ]
    }

    /// A point's value, Jacobian on its side's columns, velocity and `p̈ − J v̇`.
    pub fn point(&self, sides: &[Side; 2], s: usize) -> Evaluated {
        let (side, a) = (&sides[s], &self.arms[s]);
        let ra = side.r * a;
        let mut jacobian = Jacobian::zeros();
        if self.nodes[s].is_some() {
            jacobian
                .fixed_view_mut::<3, 3>(0, 6 * s)
                .copy_from(&Matrix3::identity());
            jacobian
                .fixed_view_mut::<3, 3>(0, 6 * s + 3)
                .copy_from(&(-side.r * hat(a)));
        }
        Evaluated {
            value: side.x + ra,
            jacobian,
            rate: side.u + side.r * side.omega.cross(a),
            term: side.r * side.omega.cross(&side.omega.cross(a)),
        }
    }

    pub fn evaluate(&self, m: &Measure, sides: &[Side; 2]) -> Evaluated {
        match m {
            Measure::Constant(e) => Evaluated {
                value: *e,
                jacobian: Jacobian::zeros(),
                rate: Vector3::zeros(),
                term: Vector3::zeros(),
            },
            Measure::Axis(s, u) => {
                let side = &sides[*s];
                let mut jacobian = Jacobian::zeros();
                if self.nodes[*s].is_some() {
                    jacobian
                        .fixed_view_mut::<3, 3>(0, 6 * s + 3)
                        .copy_from(&(-side.r * hat(u)));
                }
                Evaluated {
                    value: side.r * u,
                    jacobian,
                    rate: side.r * side.omega.cross(u),
                    term: side.r * side.omega.cross(&side.omega.cross(u)),
                }
            }
            Measure::Gap => {
                let (a, b) = (self.point(sides, 0), self.point(sides, 1));
                Evaluated {
                    value: b.value - a.value,
                    jacobian: b.jacobian - a.jacobian,
                    rate: b.rate - a.rate,
                    term: b.term - a.term,
                }
            }
        }
    }

    /// A measure's derivative to a move of the anchors' points at the rates `arms` (each in
    /// its side's frame, the ground's inertial) at fixed `q` and `v`: the gap's is the gap
    /// of the points `R a'` with nothing of the nodes' places, `R a'` in value, `[0, −R ã']`
    /// in Jacobian, `R (Ω × a')` in rate and `R Ω̃Ω̃ a'` in `p̈ − J v̇`; the other measures do
    /// not move.
    pub fn evaluate_rate(
        &self,
        m: &Measure,
        sides: &[Side; 2],
        arms: &[Vector3<f64>; 2],
    ) -> Evaluated {
        let mut out = Evaluated {
            value: Vector3::zeros(),
            jacobian: Jacobian::zeros(),
            rate: Vector3::zeros(),
            term: Vector3::zeros(),
        };
        if *m != Measure::Gap {
            return out;
        }
        for (s, sign) in [(0, -1.0), (1, 1.0)] {
            let (side, a) = (&sides[s], &arms[s]);
            out.value += side.r * a * sign;
            out.rate += side.r * side.omega.cross(a) * sign;
            out.term += side.r * side.omega.cross(&side.omega.cross(a)) * sign;
            if self.nodes[s].is_some() {
                out.jacobian
                    .fixed_view_mut::<3, 3>(0, 6 * s + 3)
                    .copy_from(&(-side.r * hat(a) * sign));
            }
        }
        out
    }

    /// The derivative of [`Pair::product`] of `alpha` and `beta` to a move of the anchors'
    /// points at the rates `arms` ([`Pair::evaluate_rate`]) at fixed `q` and `v`.
    pub fn product_rate(
        &self,
        alpha: &Measure,
        beta: &Measure,
        sides: &[Side; 2],
        arms: &[Vector3<f64>; 2],
    ) -> Product {
        let (a, b) = (self.evaluate(alpha, sides), self.evaluate(beta, sides));
        let (da, db) = (
            self.evaluate_rate(alpha, sides, arms),
            self.evaluate_rate(beta, sides, arms),
        );
        Product {
            value: da.value.dot(&b.value) + a.value.dot(&db.value),
            gradient: da.jacobian.transpose() * b.value
                + a.jacobian.transpose() * db.value
                + db.jacobian.transpose() * a.value
                + b.jacobian.transpose() * da.value,
            rate: da.rate.dot(&b.value)
                + a.rate.dot(&db.value)
                + da.value.dot(&b.rate)
                + a.value.dot(&db.rate),
            term: da.term.dot(&b.value)
                + a.term.dot(&db.value)
                + 2.0 * (da.rate.dot(&b.rate) + a.rate.dot(&db.rate))
                + da.value.dot(&b.term)
                + a.value.dot(&db.term),
        }
    }

    /// `∂(J v)/∂q` of the gap at fixed `v`: `±[0, −R (Ω × a)~]` on each anchor's node.
    pub fn gap_rate_jacobian(&self, sides: &[Side; 2]) -> Jacobian {
        let mut d = Jacobian::zeros();
        for (s, sign) in [(0, -1.0), (1, 1.0)] {
            if self.nodes[s].is_some() {
                let side = &sides[s];
                let block = -side.r * hat(&side.omega.cross(&self.arms[s])) * sign;
                d.fixed_view_mut::<3, 3>(0, 6 * s + 3).copy_from(&block);
            }
        }
        d
    }

    /// `∂(J_mᵀ c)/∂q` of measure `m` at fixed `c`, added into `k` times `scale`.
    pub fn add_hessian(
        &self,
        m: &Measure,
        sides: &[Side; 2],
        c: &Vector3<f64>,
        scale: f64,
        k: &mut Stiffness,
    ) {
        let mut rotation = |s: usize, v: &Vector3<f64>, sign: f64| {
            if self.nodes[s].is_some() {
                let block = hat(v) * hat(&(sides[s].r.transpose() * c)) * (sign * scale);
                let mut view = k.fixed_view_mut::<3, 3>(6 * s + 3, 6 * s + 3);
                view += block;
            }
        };
        match m {
            Measure::Constant(_) => {}
            Measure::Axis(s, u) => rotation(*s, u, 1.0),
            Measure::Gap => {
                rotation(1, &self.arms[1], 1.0);
                rotation(0, &self.arms[0], -1.0);
            }
        }
    }

    /// The dot product `α · β` of two measures: its value, gradient `J_αᵀβ + J_βᵀα`, rate
    /// and `b = (α̈ − J_α v̇)·β + 2 α̇·β̇ + α·(β̈ − J_β v̇)`.
    pub fn product(&self, alpha: &Measure, beta: &Measure, sides: &[Side; 2]) -> Product {
        self.product_and_hessian(alpha, beta, sides, None)
    }

    /// [`Pair::product`], and with `hessian = Some((scale, k))` its Hessian times `scale`
    /// added into `k` ([`Pair::add_product_hessian`]), from one evaluation of the measures.
    pub fn product_and_hessian(
        &self,
        alpha: &Measure,
        beta: &Measure,
        sides: &[Side; 2],
        hessian: Option<(f64, &mut Stiffness)>,
    ) -> Product {
        let (a, b) = (self.evaluate(alpha, sides), self.evaluate(beta, sides));
        if let Some((scale, k)) = hessian {
            self.add_evaluated_hessian((alpha, &a), (beta, &b), sides, scale, k);
        }
        Product {
            value: a.value.dot(&b.value),
            gradient: a.jacobian.transpose() * b.value + b.jacobian.transpose() * a.value,
            rate: a.rate.dot(&b.value) + a.value.dot(&b.rate),
            term: a.term.dot(&b.value) + 2.0 * a.rate.dot(&b.rate) + a.value.dot(&b.term),
        }
    }

    /// The Hessian of `α · β`, `H_α[β] + H_β[α] + J_αᵀJ_β + J_βᵀJ_α`, times `scale`, into `k`.
    pub fn add_product_hessian(
        &self,
        alpha: &Measure,
        beta: &Measure,
        sides: &[Side; 2],
        scale: f64,
        k: &mut Stiffness,
    ) {
        let (a, b) = (self.evaluate(alpha, sides), self.evaluate(beta, sides));
        self.add_evaluated_hessian((alpha, &a), (beta, &b), sides, scale, k);
    }

    /// [`Pair::add_product_hessian`] of the measures `alpha` and `beta` evaluated as `a` and `b`.
    fn add_evaluated_hessian(
        &self,
        (alpha, a): (&Measure, &Evaluated),
        (beta, b): (&Measure, &Evaluated),
        sides: &[Side; 2],
        scale: f64,
        k: &mut Stiffness,
    ) {
        self.add_hessian(alpha, sides, &b.value, scale, k);
        self.add_hessian(beta, sides, &a.value, scale, k);
        // A constant's Jacobian is zero, and `J_βᵀJ_α` is `J_αᵀJ_β`'s transpose.
        if !matches!(alpha, Measure::Constant(_)) && !matches!(beta, Measure::Constant(_)) {
            let product = a.jacobian.tr_mul(&b.jacobian) * scale;
            *k += product + product.transpose();
        }
    }
}

/// A product's value, gradient, rate and `b`.
pub(crate) struct Product {
    pub value: f64,
    pub gradient: SVector<f64, LOCAL>,
    pub rate: f64,
    pub term: f64,
}
