//! Averaging interface rings (RBE3-type): a reference point that follows the weighted mean
//! of a ring's nodes, turned by their weighted least-squares rotation, and adds no
//! stiffness.
//!
//! The ring's nodes `i` sit at `Xᵢ` from their weighted centre (`Σ wᵢ Xᵢ = 0`, `Σ wᵢ = 1`)
//! and move by `dᵢ`; its reference node `c` (a light body at the centre) by `(u_c, φ_c)`.
//! Three rows hold `c` to the ring:
//!
//! * **mean**, `u_c − Σ wᵢ dᵢ` in x and in y, linear;
//! * **rotation**, `φ_c − θ`, with `θ` the angle that minimises `Σ wᵢ |R(θ) Xᵢ − (xᵢ − x̄)|²`:
//!   `θ = atan2(B, A)`, `A = Σ wᵢ Xᵢ·(Xᵢ + dᵢ)`, `B = Σ wᵢ Xᵢ × dᵢ` (the mean drops out since
//!   `Σ wᵢ Xᵢ = 0`, so `A` and `B` are linear in `d`). It is read as
//!   `−atan2(B cos φ_c − A sin φ_c, A cos φ_c + B sin φ_c)`, the angle between the two
//!   frames, which does not wrap as the ring turns round. Its gradient on `dⱼ` is
//!   `−(A bⱼ − B aⱼ)/r²` with `aⱼ = wⱼ Xⱼ`, `bⱼ = wⱼ J Xⱼ`, `r² = A² + B²`, and its Hessian
//!   `−(θ_AA a aᵀ + θ_BB b bᵀ + θ_AB (a bᵀ + b aᵀ))` with `θ_AA = −θ_BB = 2AB/r⁴`,
//!   `θ_AB = (B² − A²)/r⁴`.
//!
//! The reference node's three coordinates are fixed by the ring's and nothing of the ring is
//! held: a free member keeps its modes. Loads and joints at the reference reach the ring's
//! nodes as `−Φ_qᵀλ`: a force spread by the weights, a moment as forces `∝ wᵢ J Xᵢ`.

use nalgebra::Vector2;

use crate::joint::planar::{dof, perp};

/// An averaging ring: its reference node, its nodes, their weights and offsets.
#[derive(Debug, Clone, PartialEq)]
pub struct Averaging {
    /// Its name (joints attach to it by it).
    pub name: String,
    /// The reference node (a light rigid body's, at the weighted centre).
    pub reference: usize,
    /// The ring's nodes.
    pub nodes: Vec<usize>,
    /// Their weights, summing to one.
    pub weights: Vec<f64>,
    /// Their reference positions less the weighted centre, `Xᵢ` (m).
    pub offsets: Vec<Vector2<f64>>,
}

/// Which row of a ring: the mean in x, in y, or the rotation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Component {
    /// `u_c − Σ wᵢ uᵢ`.
    MeanX,
    /// `v_c − Σ wᵢ vᵢ`.
    MeanY,
    /// `φ_c − θ`.
    Rotation,
}

impl Component {
    /// The ring's rows in order.
    pub const ALL: [Self; 3] = [Self::MeanX, Self::MeanY, Self::Rotation];
}

/// `A` and `B` of the rotation at a state.
struct Fit {
    a: f64,
    b: f64,
}

impl Averaging {
    /// A ring of `nodes` at reference `positions` with `weights` (any positive scale) on
    /// the `reference` node: offsets from the weighted centre, weights normalised.
    pub fn new(
        name: String,
        reference: usize,
        nodes: Vec<usize>,
        positions: &[Vector2<f64>],
        weights: &[f64],
    ) -> Self {
        let total: f64 = weights.iter().sum();
        let weights: Vec<f64> = weights.iter().map(|w| w / total).collect();
        let centre = weighted_centre(positions, &weights);
        Self {
            name,
            reference,
            nodes,
            offsets: positions.iter().map(|p| p - centre).collect(),
            weights,
        }
    }

    /// The DOFs row `c` acts on: the reference node's first, then the ring's (x or y of
    /// each for a mean, both of each for the rotation).
    pub fn dofs(&self, c: Component) -> impl Iterator<Item = usize> + '_ {
        let own = match c {
            Component::MeanX => dof(self.reference, 0),
            Component::MeanY => dof(self.reference, 1),
            Component::Rotation => dof(self.reference, 2),
        };
        let per_node: &[usize] = match c {
            Component::MeanX => &[0],
            Component::MeanY => &[1],
            Component::Rotation => &[0, 1],
        };
        std::iter::once(own).chain(
            self.nodes
                .iter()
                .flat_map(move |&n| per_node.iter().map(move |&k| dof(n, k))),
        )
    }

    /// The number of DOFs of row `c`.
    pub fn len(&self, c: Component) -> usize {
        match c {
            Component::MeanX | Component::MeanY => 1 + self.nodes.len(),
            Component::Rotation => 1 + 2 * self.nodes.len(),
        }
    }

    fn fit(&self, q: &[f64]) -> Fit {
        let (mut a, mut b) = (0.0, 0.0);
        for ((&n, &w), x) in self.nodes.iter().zip(&self.weights).zip(&self.offsets) {
            let d = Vector2::new(q[dof(n, 0)], q[dof(n, 1)]);
            a += w * x.dot(&(x + d));
            b += w * (x.x * d.y - x.y * d.x);
        }
        Fit { a, b }
    }

    /// The value of row `c` at `q`, and its gradient on [`Averaging::dofs`] through
    /// `gradient(local index, value)`.
    pub fn evaluate(&self, c: Component, q: &[f64], mut gradient: impl FnMut(usize, f64)) -> f64 {
        match c {
            Component::MeanX | Component::MeanY => {
                let k = if c == Component::MeanX { 0 } else { 1 };
                gradient(0, 1.0);
                let mut value = q[dof(self.reference, k)];
                for (i, (&n, &w)) in self.nodes.iter().zip(&self.weights).enumerate() {
                    gradient(1 + i, -w);
                    value -= w * q[dof(n, k)];
                }
                value
            }
            Component::Rotation => {
                let Fit { a, b } = self.fit(q);
                let r2 = a * a + b * b;
                gradient(0, 1.0);
                for (i, (&w, x)) in self.weights.iter().zip(&self.offsets).enumerate() {
                    let g = -(a * w * perp(*x) - b * w * x) / r2;
                    gradient(1 + 2 * i, g.x);
                    gradient(2 + 2 * i, g.y);
                }
                let (s, co) = q[dof(self.reference, 2)].sin_cos();
                -(b * co - a * s).atan2(a * co + b * s)
            }
        }
    }

    /// Adds `weight · ∂²Φ/∂q²` of row `c` at `q` through `add(local i, local j, value)`
    /// (nothing for a mean: it is linear).
    pub fn add_hessian(
        &self,
        c: Component,
        q: &[f64],
        weight: f64,
        mut add: impl FnMut(usize, usize, f64),
    ) {
        if c != Component::Rotation {
            return;
        }
        let Fit { a, b } = self.fit(q);
        let r4 = (a * a + b * b).powi(2);
        let (aa, ab) = (2.0 * a * b / r4, (b * b - a * a) / r4);
        // The local DOF 1 + 2 i + k: the k-th component of aᵢ = wᵢ Xᵢ and bᵢ = wᵢ J Xᵢ.
        let terms = |l: usize| {
            let (i, k) = ((l - 1) / 2, (l - 1) % 2);
            let w = self.weights[i];
            (w * self.offsets[i][k], w * perp(self.offsets[i])[k])
        };
        let n = self.len(c);
        for i in 1..n {
            let (ai, bi) = terms(i);
            for j in 1..n {
                let (aj, bj) = terms(j);
                let h = aa * (ai * aj - bi * bj) + ab * (ai * bj + bi * aj);
                add(i, j, -weight * h);
            }
        }
    }
}

/// `Σ wᵢ pᵢ` for weights summing to one.
pub fn weighted_centre(positions: &[Vector2<f64>], weights: &[f64]) -> Vector2<f64> {
    positions
        .iter()
        .zip(weights)
        .map(|(p, w)| p * *w)
        .sum::<Vector2<f64>>()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Five nodes with unequal weights, their reference node 5.
    fn ring() -> Averaging {
        let positions = [
            Vector2::new(0.3, 0.1),
            Vector2::new(0.1, 0.4),
            Vector2::new(-0.2, 0.2),
            Vector2::new(-0.1, -0.3),
            Vector2::new(0.25, -0.2),
        ];
        Averaging::new(
            "r".into(),
            5,
            vec![0, 1, 2, 3, 4],
            &positions,
            &[1.0, 2.0, 0.5, 1.5, 1.0],
        )
    }

    fn gradient(ring: &Averaging, c: Component, q: &[f64]) -> Vec<f64> {
        let mut g = vec![0.0; ring.len(c)];
        ring.evaluate(c, q, |i, v| g[i] += v);
        g
    }

    /// A state of the ring turned by `angle` about a point and shifted, its reference
    /// turned by `spin`, with the nodes' own displacements `wobble`.
    fn state(ring: &Averaging, angle: f64, spin: f64, wobble: f64) -> Vec<f64> {
        let mut q = vec![0.0; 18];
        let (s, c) = angle.sin_cos();
        for (i, x) in ring.offsets.iter().enumerate() {
            let turned = Vector2::new(c * x.x - s * x.y, s * x.x + c * x.y);
            let d = turned - x + Vector2::new(0.2, -0.1);
            q[dof(i, 0)] = d.x + wobble * (0.3 * i as f64).sin();
            q[dof(i, 1)] = d.y + wobble * (0.7 * i as f64).cos();
        }
        q[dof(5, 0)] = 0.05;
        q[dof(5, 1)] = -0.02;
        q[dof(5, 2)] = spin;
        q
    }

    /// A rigid motion of the ring by any angle, even past a half turn: the mean moves by
    /// the shift, the rotation row reads `φ_c − angle`.
    #[test]
    fn a_rigid_motion_is_read_exactly() {
        let ring = ring();
        for angle in [0.0, 0.4, 2.9, -3.1, 5.0] {
            let q = state(&ring, angle, angle + 0.01, 0.0);
            let mean_x = ring.evaluate(Component::MeanX, &q, |_, _| {});
            let mean_y = ring.evaluate(Component::MeanY, &q, |_, _| {});
            let rotation = ring.evaluate(Component::Rotation, &q, |_, _| {});
            assert!((mean_x - (0.05 - 0.2)).abs() < 1e-14, "{mean_x}");
            assert!((mean_y - (-0.02 + 0.1)).abs() < 1e-14, "{mean_y}");
            assert!((rotation - 0.01).abs() < 1e-13, "{angle}: {rotation}");
        }
    }

    /// Gradients are central differences of the values and Hessians of the gradients, at
    /// a large turn and a deformed ring.
    #[test]
    fn gradients_and_hessians_equal_central_differences() {
        let ring = ring();
        let q = state(&ring, 2.5, 2.3, 0.05);
        for c in Component::ALL {
            let dofs: Vec<usize> = ring.dofs(c).collect();
            let g = gradient(&ring, c, &q);
            let mut h = vec![0.0; dofs.len() * dofs.len()];
            ring.add_hessian(c, &q, 1.0, |i, j, v| h[i * dofs.len() + j] += v);
            let eps = 1e-6;
            for (j, &d) in dofs.iter().enumerate() {
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[d] += eps;
                qm[d] -= eps;
                let value = |q: &[f64]| ring.evaluate(c, q, |_, _| {});
                let fd = (value(&qp) - value(&qm)) / (2.0 * eps);
                assert!((fd - g[j]).abs() < 1e-8, "{c:?} ∂/∂{d}: {} vs {fd}", g[j]);
                let (gp, gm) = (gradient(&ring, c, &qp), gradient(&ring, c, &qm));
                for i in 0..dofs.len() {
                    let fd = (gp[i] - gm[i]) / (2.0 * eps);
                    let hij = h[i * dofs.len() + j];
                    assert!((fd - hij).abs() < 1e-7, "{c:?} H[{i}][{j}]: {hij} vs {fd}");
                }
            }
        }
    }
}
