//! Kinematic joints as algebraic constraints `Φ(q, t) = 0` with Lagrange multipliers
//! (paper Eq. 2–3).
//!
//! In planar absolute nodal coordinates every joint we offer is *linear* in `q`: a clamp
//! fixes a node's displacement and rotation, a pin its displacement, a hinge equates the
//! displacements of two coincident nodes, and a drive prescribes a rotation (absolute for
//! a pin, relative `φ_b − φ_a` for a hinge) to follow `θ(t) − θ(0)`. Hence `Φ_q` is
//! constant and the constraint Hessian `(Φ_qᵀλ)_q` vanishes, which keeps the iteration
//! matrix exact with no extra term.
//!
//! Sign convention: the residual is `r = M q̈ + f_int − f_ext + Φ_qᵀλ`, so the force a joint
//! applies to the structure is `−Φ_qᵀλ`; reactions and motor torques are reported that way.

use crate::motion::Motion;

/// Which joint, on which nodes.
#[derive(Debug, Clone, PartialEq)]
pub enum JointKind {
    /// Node fixed in position and rotation.
    Clamp {
        /// The clamped node.
        node: usize,
    },
    /// Node fixed in position; its rotation is free or driven (absolute).
    Pin {
        /// The pinned node.
        node: usize,
    },
    /// Two coincident nodes kept together; relative rotation free or driven.
    Hinge {
        /// `[a, b]`; a drive prescribes `φ_b − φ_a`.
        nodes: [usize; 2],
    },
}

/// A named joint, possibly driven.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name used in results and error messages.
    pub name: String,
    /// Kind and nodes.
    pub kind: JointKind,
    /// Motion law of the driven rotation, if any (not for clamps).
    pub drive: Option<Motion>,
}

/// One scalar constraint `Φ = Σ cₖ q_{dofₖ} − g(t)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstraintRow {
    /// `(dof, coefficient)` terms; a second term with coefficient 0 is unused.
    pub terms: [(usize, f64); 2],
    /// Index of the joint that owns the row.
    pub joint: usize,
    /// Whether `g(t) = θ(t) − θ(0)` of the joint's drive (otherwise `g = 0`).
    pub driven: bool,
}

/// Global DOF index of component `k` (0: x, 1: y, 2: φ) of `node`.
pub const fn dof(node: usize, k: usize) -> usize {
    3 * node + k
}

impl JointKind {
    /// The kind's name in a scene: `clamp`, `pin` or `hinge`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Clamp { .. } => "clamp",
            Self::Pin { .. } => "pin",
            Self::Hinge { .. } => "hinge",
        }
    }
}

impl Joint {
    /// The joint's constraint rows, the drive row last.
    pub fn rows(&self, joint: usize) -> Vec<ConstraintRow> {
        let single = |d: usize, driven| ConstraintRow {
            terms: [(d, 1.0), (d, 0.0)],
            joint,
            driven,
        };
        let pair = |a: usize, b: usize, driven| ConstraintRow {
            terms: [(a, 1.0), (b, -1.0)],
            joint,
            driven,
        };
        let driven = self.drive.is_some();
        match self.kind {
            JointKind::Clamp { node } => (0..3).map(|k| single(dof(node, k), false)).collect(),
            JointKind::Pin { node } => {
                let mut rows = vec![single(dof(node, 0), false), single(dof(node, 1), false)];
                if driven {
                    rows.push(single(dof(node, 2), true));
                }
                rows
            }
            JointKind::Hinge { nodes: [a, b] } => {
                let mut rows = vec![
                    pair(dof(a, 0), dof(b, 0), false),
                    pair(dof(a, 1), dof(b, 1), false),
                ];
                if driven {
                    rows.push(pair(dof(b, 2), dof(a, 2), true));
                }
                rows
            }
        }
    }

    /// Nodes the joint acts on.
    pub fn nodes(&self) -> Vec<usize> {
        match self.kind {
            JointKind::Clamp { node } | JointKind::Pin { node } => vec![node],
            JointKind::Hinge { nodes } => nodes.to_vec(),
        }
    }

    /// Whether the joint ties its node(s) to the ground.
    pub fn is_grounded(&self) -> bool {
        !matches!(self.kind, JointKind::Hinge { .. })
    }

    /// Prescribed value `g(t)` and its derivatives for a driven row, zero otherwise.
    pub fn prescribed(&self, row: &ConstraintRow, t: f64) -> [f64; 3] {
        match (&self.drive, row.driven) {
            (Some(m), true) => {
                let (now, start) = (m.at(t), m.at(0.0));
                [now.angle - start.angle, now.velocity, now.acceleration]
            }
            _ => [0.0; 3],
        }
    }
}

impl ConstraintRow {
    /// `Σ cₖ q_{dofₖ}`.
    pub fn apply(&self, q: &[f64]) -> f64 {
        self.terms.iter().map(|&(d, c)| c * q[d]).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Trapezoidal;

    #[test]
    fn driven_hinge_prescribes_relative_rotation_from_its_start() {
        let drive = Motion::Trapezoidal(Trapezoidal::new(1.0, 2.0, 2.0, 0.5, 0.0));
        let j = Joint {
            name: "elbow".into(),
            kind: JointKind::Hinge { nodes: [3, 7] },
            drive: Some(drive.clone()),
        };
        let rows = j.rows(0);
        assert_eq!(rows.len(), 3);
        let mut q = vec![0.0; 24];
        q[dof(7, 2)] = 0.4;
        q[dof(3, 2)] = 0.1;
        assert!((rows[2].apply(&q) - 0.3).abs() < 1e-15);
        let g = j.prescribed(&rows[2], 0.5);
        assert!((g[0] - (drive.at(0.5).angle - 1.0)).abs() < 1e-15);
        assert_eq!(j.prescribed(&rows[0], 0.5), [0.0; 3]);
    }
}
