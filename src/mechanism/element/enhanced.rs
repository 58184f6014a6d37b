//! The enhanced assumed strain of a four-node cell: four incompatible modes that free the
//! plain cell of its locking in bending, condensed out at element level.
//!
//! Simo & Rifai (1990, "A class of mixed assumed strain methods and the method of
//! incompatible modes", IJNME 29) enhance the compatible strain by a field `Ẽ = Γ(ξ) α`
//! orthogonal to constant stresses; with the incompatible modes `1 − ξ²`, `1 − η²` in
//! each direction and the Jacobian frozen at the centre (Taylor, Beresford & Wilson 1976,
//! QM6), their gradients are
//!
//! ```text
//! g̃₁ = (j₀ / j(ξ)) J₀⁻ᵀ [ξ, 0]ᵀ,   g̃₂ = (j₀ / j(ξ)) J₀⁻ᵀ [0, η]ᵀ,
//! ```
//!
//! and `Ẽ = sym(Σ_k α̃_k g̃_kᵀ)`, `α̃_k ∈ ℝ²`, four parameters `α`. `Σ_gp w j Γ = j₀ J₀⁻ᵀ
//! Σ_gp w [ξ, η] = 0` on 2 × 2 Gauss points: the enhancement is orthogonal to any constant
//! stress, so the patch test passes on any parallelogram-distorted mesh and a constant
//! strain field keeps `α = 0`. In total-Lagrangian form the enhancement is added to the
//! Green–Lagrange strain (Büchter, Ramm & Roehl 1994; Klinkel & Wagner 1997):
//!
//! ```text
//! E(u, α) = E_c(u) + Γ α,   S = C E,   U(u, α) = Σ_gp V ½ Eᵀ C E.
//! ```
//!
//! `h = ∂U/∂α = K_αα α + Σ_gp V Γᵀ C E_c(u)` with the constant `K_αα = Σ_gp V Γᵀ C Γ`: for a
//! St. Venant–Kirchhoff material `h = 0` is linear in `α`, so the local Newton solve from
//! `α = 0` is exact in its one step at any strain,
//!
//! ```text
//! α(u) = −K_αα⁻¹ Σ_gp V Γᵀ C E_c(u),   A = ∂α/∂u = −K_αα⁻¹ K_αu,   K_αu = Σ_gp V Γᵀ C B(u),
//! ```
//!
//! and the cell is a pure function of `u` (no state kept between evaluations). The
//! condensed energy `Ū(u) = U(u, α(u))` has the force `f = ∂U/∂u` (`h = 0`) and the exact
//! tangent `K_uu − K_uα K_αα⁻¹ K_αu`; the strain's derivative is `B̄ = B + Γ A`. A design
//! scales `K_uu`, `K_uα` and `K_αα` alike, so `α` does not depend on it and the pseudo-loads
//! of densities stay `s'(x) f`.

use nalgebra::{Matrix2, SMatrix, Vector2, Vector3};

/// The enhanced strain operator `Γ` at a Gauss point, on `[E₁₁, E₂₂, 2E₁₂]`.
pub type Modes = SMatrix<f64, 3, 4>;
/// The derivative `A = ∂α/∂u` of the condensed parameters.
pub type Condensed = SMatrix<f64, 4, 8>;

/// The four enhanced modes of a cell and their static condensation.
#[derive(Debug, Clone, PartialEq)]
pub struct Enhancement {
    /// `Γ` at each Gauss point.
    modes: [Modes; 4],
    /// `V Γᵀ C` at each Gauss point (N/m² m³ = J).
    weighted: [SMatrix<f64, 4, 3>; 4],
    /// `K_αα⁻¹` (1/J).
    compliance: SMatrix<f64, 4, 4>,
}

/// A cell's enhancement cannot be condensed: `K_αα` is singular (a degenerate cell).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Singular;

impl Enhancement {
    /// The enhancement of a cell whose centre has Jacobian `centre` (`J₀`, `J_ij = ∂X_i/∂ξ_j`),
    /// at Gauss points `(ξ, η)` of Jacobian determinant `det` and volume `V = w t det J`, in
    /// the plane-stress elasticity `elasticity` (`C`).
    ///
    /// # Errors
    /// [`Singular`] if `J₀` or `K_αα` cannot be inverted.
    pub fn new(
        centre: &Matrix2<f64>,
        points: [(f64, f64, f64, f64); 4],
        elasticity: &SMatrix<f64, 3, 3>,
    ) -> Result<Self, Singular> {
        let j0 = centre.determinant();
        let inverse = centre.try_inverse().filter(|_| j0 > 0.0).ok_or(Singular)?;
        let modes = points.map(|(xi, eta, det, _)| {
            let scale = j0 / det;
            let g = [Vector2::new(xi, 0.0), Vector2::new(0.0, eta)]
                .map(|n| inverse.transpose() * n * scale);
            mode_operator(&g)
        });
        let weighted: [SMatrix<f64, 4, 3>; 4] =
            std::array::from_fn(|p| modes[p].transpose() * elasticity * points[p].3);
        let stiffness: SMatrix<f64, 4, 4> = (0..4).map(|p| weighted[p] * modes[p]).sum();
        let compliance = stiffness.cholesky().ok_or(Singular)?.inverse();
        Ok(Self {
            modes,
            weighted,
            compliance,
        })
    }

    /// The condensed parameters `α(u) = −K_αα⁻¹ Σ V Γᵀ C E_c` of compatible strains `strains`.
    pub fn parameters(&self, strains: &[Vector3<f64>; 4]) -> SMatrix<f64, 4, 1> {
        let h: SMatrix<f64, 4, 1> = (0..4).map(|p| self.weighted[p] * strains[p]).sum();
        -(self.compliance * h)
    }

    /// The compatible strains `strains` enhanced in place by `Γ α(u)`.
    pub fn enhance(&self, strains: &mut [Vector3<f64>; 4]) {
        let alpha = self.parameters(strains);
        for (e, gamma) in strains.iter_mut().zip(&self.modes) {
            *e += gamma * alpha;
        }
    }

    /// `K_αu = Σ V Γᵀ C B` of the compatible strains' derivatives `operators` (`B`).
    pub fn coupling(&self, operators: &[SMatrix<f64, 3, 8>; 4]) -> Condensed {
        (0..4).map(|p| self.weighted[p] * operators[p]).sum()
    }

    /// `A = ∂α/∂u = −K_αα⁻¹ K_αu`.
    pub fn rate(&self, coupling: &Condensed) -> Condensed {
        -(self.compliance * coupling)
    }

    /// `Γ` at Gauss point `p`.
    pub fn modes(&self, p: usize) -> &Modes {
        &self.modes[p]
    }

    /// `V C Γ_p K_αα⁻¹ r` at Gauss point `p`: the stress whose geometric stiffness carries
    /// the change of `A` (the damping's `∂f_d/∂q`) for the parameters' residual `r`.
    pub fn back_stress(&self, p: usize, r: &SMatrix<f64, 4, 1>) -> Vector3<f64> {
        self.weighted[p].transpose() * (self.compliance * r)
    }

    /// `Σ_gp V Γᵀ s` of stresses `s` (Pa) at the Gauss points.
    pub fn residual(&self, stresses: &[Vector3<f64>; 4], volumes: [f64; 4]) -> SMatrix<f64, 4, 1> {
        (0..4)
            .map(|p| self.modes[p].transpose() * stresses[p] * volumes[p])
            .sum()
    }
}

/// `Γ` from the modes' gradients `g̃₁`, `g̃₂`: column `2k + i` is the Voigt strain of the
/// displacement gradient `e_i g̃_kᵀ` at the reference (`B` at `F = I`).
fn mode_operator(g: &[Vector2<f64>; 2]) -> Modes {
    let mut gamma = Modes::zeros();
    for (k, gk) in g.iter().enumerate() {
        gamma[(0, 2 * k)] = gk.x;
        gamma[(2, 2 * k)] = gk.y;
        gamma[(1, 2 * k + 1)] = gk.y;
        gamma[(2, 2 * k + 1)] = gk.x;
    }
    gamma
}

/// `B̄ = B + Γ A`, the enhanced strain's derivative at a Gauss point.
pub fn enhanced_operator(
    b: &SMatrix<f64, 3, 8>,
    gamma: &Modes,
    rate: &Condensed,
) -> SMatrix<f64, 3, 8> {
    b + gamma * rate
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector, Rotation2};

    use super::*;
    use crate::mechanism::element::quad::tests::{corners, steel, strained};
    use crate::mechanism::element::quad::{CellKind, PlaneMaterial, Quad, Vector8};

    const KINDS: [CellKind; 2] = [CellKind::Plain, CellKind::Enhanced];

    /// The displacement of the field `X ↦ (R(angle) − I) X + shift + H X` at corners `x`.
    fn field(x: &[Vector2<f64>], angle: f64, h: &Matrix2<f64>) -> Vec<f64> {
        let r = Rotation2::new(angle);
        x.iter()
            .flat_map(|p| {
                let d = r * (p + h * p) - p + Vector2::new(0.3, -0.2);
                [d.x, d.y]
            })
            .collect()
    }

    fn local(u: &[f64], nodes: &[usize; 4]) -> Vector8 {
        Vector8::from_fn(|i, _| u[2 * nodes[i / 2] + i % 2])
    }

    /// A mesh: node positions and cells on them.
    struct Mesh {
        nodes: Vec<Vector2<f64>>,
        cells: Vec<(Quad, [usize; 4])>,
    }

    impl Mesh {
        /// `nx × ny` cells on `[0, length] × [−height/2, height/2]`, node `(i, j)` numbered
        /// `j (nx + 1) + i`, each interior node moved by `distortion` times
        /// a cell's size in a fixed pattern.
        fn grid(
            (nx, ny): (usize, usize),
            (length, height): (f64, f64),
            material: PlaneMaterial,
            kind: CellKind,
            distortion: f64,
        ) -> Self {
            let (dx, dy) = (length / nx as f64, height / ny as f64);
            let mut nodes = Vec::new();
            for j in 0..=ny {
                for i in 0..=nx {
                    let mut p = Vector2::new(i as f64 * dx, j as f64 * dy - height / 2.0);
                    if i > 0 && i < nx && j > 0 && j < ny {
                        let k = (3 * i + 5 * j) as f64;
                        p += Vector2::new(k.sin() * dx, (1.3 * k).cos() * dy) * distortion;
                    }
                    nodes.push(p);
                }
            }
            let mut cells = Vec::new();
            for j in 0..ny {
                for i in 0..nx {
                    let n = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                        .map(|(a, b)| b * (nx + 1) + a);
                    let quad = Quad::new(n.map(|k| nodes[k]), material, kind).unwrap();
                    cells.push((quad, n));
                }
            }
            Self { nodes, cells }
        }

        /// The node at `(i, j)` of an `nx`-wide grid.
        fn at(nx: usize, i: usize, j: usize) -> usize {
            j * (nx + 1) + i
        }

        /// Internal force and tangent at nodal displacements `u`.
        fn assemble(&self, u: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
            let n = 2 * self.nodes.len();
            let (mut f, mut k) = (DVector::zeros(n), DMatrix::zeros(n, n));
            for (quad, nodes) in &self.cells {
                let (fe, ke) = quad.internal_force_and_tangent(&local(u, nodes));
                let dofs: [usize; 8] = std::array::from_fn(|i| 2 * nodes[i / 2] + i % 2);
                for (a, &da) in dofs.iter().enumerate() {
                    f[da] += fe[a];
                    for (b, &db) in dofs.iter().enumerate() {
                        k[(da, db)] += ke[(a, b)];
                    }
                }
            }
            (f, k)
        }

        /// `K u = f` at the reference on the DOFs not in `held` (held at zero).
        fn solve_linear(&self, f: &DVector<f64>, held: &[usize]) -> DVector<f64> {
            let (_, k) = self.assemble(&vec![0.0; 2 * self.nodes.len()]);
            let free: Vec<usize> = (0..f.len()).filter(|d| !held.contains(d)).collect();
            let kff = DMatrix::from_fn(free.len(), free.len(), |a, b| k[(free[a], free[b])]);
            let ff = DVector::from_fn(free.len(), |a, _| f[free[a]]);
            let uf = kff.cholesky().expect("positive definite").solve(&ff);
            let mut u = DVector::zeros(f.len());
            for (a, &d) in free.iter().enumerate() {
                u[d] = uf[a];
            }
            u
        }
    }

    /// Force against energy, tangent against force, by central differences, at a small and
    /// a large strain, on a distorted cell of either kind; the tangent symmetric.
    #[test]
    fn tangent_and_force_are_exact_derivatives_of_the_condensed_energy() {
        for kind in KINDS {
            let quad = Quad::new(corners(), steel(0.01), kind).unwrap();
            for scale in [1e-3, 0.2] {
                let u = strained(scale);
                let (f, k) = quad.internal_force_and_tangent(&u);
                assert!((f - quad.internal_force(&u)).amax() <= 1e-12 * f.amax());
                let h = 1e-7 * scale.max(0.01);
                for j in 0..8 {
                    let e = Vector8::from_fn(|i, _| if i == j { h } else { 0.0 });
                    let (up, um) = (u + e, u - e);
                    let column = (quad.internal_force(&up) - quad.internal_force(&um)) / (2.0 * h);
                    let error = (column - k.column(j)).amax();
                    assert!(
                        error < 1e-6 * k.amax(),
                        "{kind:?} {scale} column {j}: {error}"
                    );
                    let de = (quad.strain_energy(&up) - quad.strain_energy(&um)) / (2.0 * h);
                    assert!((de - f[j]).abs() < 1e-6 * f.amax(), "{kind:?} energy {j}");
                }
                assert!((k - k.transpose()).amax() < 1e-9 * k.amax(), "symmetric");
            }
        }
    }

    /// The condensed `α(u)` makes the energy stationary in `α` (`h = 0`) and a minimum: any
    /// other `α` stores more energy; the enhanced cell is softer than the plain one.
    #[test]
    fn the_condensed_parameters_minimize_the_energy() {
        let (x, material) = (corners(), steel(0.01));
        let plain = Quad::new(x, material, CellKind::Plain).unwrap();
        let enhanced = Quad::new(x, material, CellKind::Enhanced).unwrap();
        let u = strained(0.05);
        let compatible = plain.strains(&u);
        let c = material.elasticity();
        assert!(enhanced.strain_energy(&u) < plain.strain_energy(&u));
        // The enhanced stress does no work on the modes: h = Σ V Γᵀ S = 0.
        let e = enhanced.strains(&u);
        let volumes = plain.von_mises(&u).map(|(_, share)| share * plain.volume());
        let stresses: [Vector3<f64>; 4] = std::array::from_fn(|p| c * e[p]);
        let g = 1.0 / 3.0_f64.sqrt();
        let natural = [(-g, -g), (g, -g), (g, g), (-g, g)];
        let at = std::array::from_fn(|p| {
            let det = volumes[p] / material.thickness;
            (natural[p].0, natural[p].1, det, volumes[p])
        });
        let j0 = {
            let d = |a: usize, b: usize| x[a] - x[b];
            // J₀ = ¼ [x₂ + x₃ − x₁ − x₄, x₃ + x₄ − x₁ − x₂] (columns ∂/∂ξ, ∂/∂η).
            Matrix2::from_columns(&[(d(1, 0) + d(2, 3)) * 0.25, (d(3, 0) + d(2, 1)) * 0.25])
        };
        let enhancement = Enhancement::new(&j0, at, &c).unwrap();
        let residual = enhancement.residual(&stresses, volumes);
        let scale = (0..4).map(|p| stresses[p].amax() * volumes[p]).sum::<f64>() / 0.1;
        assert!(residual.amax() < 1e-12 * scale, "h = {residual}");
        // The parameters from the compatible strains reproduce the enhanced strains.
        let alpha = enhancement.parameters(&compatible);
        for p in 0..4 {
            let diff = (compatible[p] + enhancement.modes(p) * alpha - e[p]).amax();
            assert!(diff < 1e-14, "{diff}");
        }
    }

    /// No force, energy or damping in a rigid motion, at every angle.
    #[test]
    fn rigid_motion_gives_no_force_at_any_angle() {
        let (x, material) = (corners(), steel(0.01));
        let quad = Quad::new(x, material, CellKind::Enhanced).unwrap();
        let unit = material.young * material.thickness * 0.1;
        for k in 0..=64 {
            let angle = 2.0 * std::f64::consts::PI * f64::from(k) / 64.0;
            let u = Vector8::from_column_slice(&field(&x, angle, &Matrix2::zeros()));
            let f = quad.internal_force(&u);
            assert!(
                f.amax() < 1e-12 * unit,
                "angle {angle}: {}",
                f.amax() / unit
            );
            assert!(quad.strain_energy(&u).abs() < 1e-24 * unit * 0.1);
        }
    }

    /// The enhanced damping's force against its derivatives by central differences at a
    /// large strain, `∂f_d/∂q̇ = β K` (condensed) at the reference, none in a rigid spin.
    #[test]
    fn damping_derivatives_are_exact_and_rigid_motion_is_not_damped() {
        let x = corners();
        let quad = Quad::new(x, steel(0.01), CellKind::Enhanced).unwrap();
        let (u, v) = (strained(0.2), strained(3.0).map(f64::sin));
        let d = quad.damping(&u, &v);
        let h = 1e-7;
        let exact = d.symmetric + d.skew;
        for j in 0..8 {
            let e = Vector8::from_fn(|i, _| if i == j { h } else { 0.0 });
            let fq =
                (quad.damping(&(u + e), &v).force - quad.damping(&(u - e), &v).force) / (2.0 * h);
            let fv =
                (quad.damping(&u, &(v + e)).force - quad.damping(&u, &(v - e)).force) / (2.0 * h);
            let error = (exact.column(j) - fq).amax();
            assert!(error <= 1e-6 * exact.amax(), "∂f_d/∂q column {j}: {error}");
            assert!((d.rate.column(j) - fv).amax() <= 1e-7 * d.rate.amax());
        }
        assert!((d.symmetric - d.symmetric.transpose()).amax() <= 1e-12 * d.symmetric.amax());
        let k = quad.internal_force_and_tangent(&Vector8::zeros()).1;
        let rate = quad.damping(&Vector8::zeros(), &v).rate;
        assert!((rate - k * 1e-4).amax() <= 1e-12 * rate.amax());
        for angle in [0.3, 2.0, 5.5] {
            let turned = Vector8::from_column_slice(&field(&x, angle, &Matrix2::zeros()));
            let spin = Vector8::from_fn(|i, _| {
                let p = x[i / 2] + Vector2::new(turned[2 * (i / 2)], turned[2 * (i / 2) + 1]);
                7.0 * if i % 2 == 0 { -p.y } else { p.x }
            });
            let f = quad.damping(&turned, &spin).force;
            assert!(
                f.amax() <= 1e-9 * d.force.amax(),
                "angle {angle}: {}",
                f.amax()
            );
        }
    }

    /// Von Mises stresses' gradients of the enhanced cell against central differences.
    #[test]
    fn von_mises_gradients_are_exact() {
        let quad = Quad::new(corners(), steel(0.01), CellKind::Enhanced).unwrap();
        let u = strained(1e-3);
        let h = 1e-9;
        for (k, (_, gradient, _)) in quad.von_mises_and_gradient(&u).into_iter().enumerate() {
            for j in 0..8 {
                let e = Vector8::from_fn(|i, _| if i == j { h } else { 0.0 });
                let fd =
                    (quad.von_mises(&(u + e))[k].0 - quad.von_mises(&(u - e))[k].0) / (2.0 * h);
                assert!((fd - gradient[j]).abs() < 1e-6 * gradient.amax(), "{k} {j}");
            }
        }
    }

    /// The patch test on a distorted 3 × 3 mesh, at finite strain and rotation: a linear
    /// field gives its Green–Lagrange strain at every Gauss point of every cell (`α = 0`),
    /// and the interior nodes no resultant force.
    #[test]
    fn a_distorted_patch_reproduces_a_constant_stress_exactly() {
        let h = Matrix2::new(0.08, 0.03, -0.02, -0.05);
        let ((nx, ny), size) = ((3, 3), (0.3, 0.3));
        for kind in KINDS {
            let mesh = Mesh::grid((nx, ny), size, steel(0.01), kind, 0.2);
            let u = field(&mesh.nodes, 0.7, &h);
            let f = h + Matrix2::identity();
            let e = (f.transpose() * f - Matrix2::identity()) * 0.5;
            let expected = Vector3::new(e[(0, 0)], e[(1, 1)], 2.0 * e[(0, 1)]);
            for (quad, nodes) in &mesh.cells {
                for strain in quad.strains(&local(&u, nodes)) {
                    assert!((strain - expected).amax() < 1e-14, "{kind:?}: {strain}");
                }
            }
            let (force, _) = mesh.assemble(&u);
            let scale = force.amax();
            for (i, j) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
                let n = Mesh::at(nx, i, j);
                let r = force[2 * n].abs().max(force[2 * n + 1].abs());
                assert!(r < 1e-12 * scale, "{kind:?} node ({i}, {j}): {r}");
            }
        }
    }

    /// Pure bending of a rectangular mesh by a linearly varying end traction: the enhanced
    /// cell gives the exact plane-stress field `u = −κxy`, `v = κ(x² + νy²)/2` at every node
    /// (to round-off) on cells five times as long as high; the plain cell is far too stiff.
    #[test]
    fn pure_bending_is_exact_on_rectangles() {
        let (length, height, material) = (1.0, 0.1, steel(0.01));
        let ((nx, ny), kappa) = ((4, 2), 1e-3);
        let mut tips = Vec::new();
        for kind in KINDS {
            let mesh = Mesh::grid((nx, ny), (length, height), material, kind, 0.0);
            // σ_xx = −E κ y on the end edge, as consistent nodal loads.
            let mut f = DVector::zeros(2 * mesh.nodes.len());
            for j in 0..ny {
                let (a, b) = (Mesh::at(nx, nx, j), Mesh::at(nx, nx, j + 1));
                let (ya, yb) = (mesh.nodes[a].y, mesh.nodes[b].y);
                let traction = |y: f64| -material.young * kappa * y * material.thickness;
                let l = yb - ya;
                f[2 * a] += l * (2.0 * traction(ya) + traction(yb)) / 6.0;
                f[2 * b] += l * (traction(ya) + 2.0 * traction(yb)) / 6.0;
            }
            let mut held: Vec<usize> = (0..=ny).map(|j| 2 * Mesh::at(nx, 0, j)).collect();
            held.push(2 * Mesh::at(nx, 0, ny / 2) + 1);
            let u = mesh.solve_linear(&f, &held);
            let nu = material.poisson;
            let scale = kappa * length * length / 2.0;
            let error = mesh
                .nodes
                .iter()
                .enumerate()
                .map(|(n, p)| {
                    let exact = [
                        -kappa * p.x * p.y,
                        kappa * (p.x * p.x + nu * p.y * p.y) / 2.0,
                    ];
                    (u[2 * n] - exact[0])
                        .abs()
                        .max((u[2 * n + 1] - exact[1]).abs())
                })
                .fold(0.0, f64::max);
            tips.push((u[2 * Mesh::at(nx, nx, ny / 2) + 1] / scale, error / scale));
        }
        let ((plain, _), (enhanced, error)) = (tips[0], tips[1]);
        assert!(error < 1e-10, "enhanced: {error}");
        assert!((enhanced - 1.0).abs() < 1e-10 && plain < 0.5, "{tips:?}");
    }

    /// A block of `n × n` square cells with rollers on its left and bottom edges and its
    /// top edge moved uniformly to the stretch `λ`, free to bulge on the right (Poisson's
    /// ratio `poisson`). The homogeneous uniaxial state is an equilibrium of either cell
    /// (`α = 0`); returned: the first stretch, from `λ = 1` in steps of `step` (bisected),
    /// where the smallest eigenvalue of the tangent on the free DOFs reaches zero, or 0 if
    /// none in 80 steps.
    fn critical_stretch(n: usize, kind: CellKind, poisson: f64, step: f64) -> f64 {
        let material = PlaneMaterial {
            poisson,
            ..steel(0.01)
        };
        let mesh = Mesh::grid((n, n), (1.0, 1.0), material, kind, 0.0);
        let nu = material.poisson;
        let smallest = |stretch: f64| {
            // Plane stress, S₁₁ = 0: E₁₁ = −ν E₂₂.
            let lateral = (1.0 - nu * (stretch * stretch - 1.0)).sqrt();
            let h = Matrix2::new(lateral - 1.0, 0.0, 0.0, stretch - 1.0);
            let shifted: Vec<Vector2<f64>> = mesh
                .nodes
                .iter()
                .map(|p| p + Vector2::new(0.0, 0.5))
                .collect();
            let u = field(&shifted, 0.0, &h);
            let u: Vec<f64> = u.chunks(2).flat_map(|d| [d[0] - 0.3, d[1] + 0.2]).collect();
            let (_, k) = mesh.assemble(&u);
            let held = |d: usize| {
                let (node, c) = (d / 2, d % 2);
                let (i, j) = (node % (n + 1), node / (n + 1));
                (c == 0 && i == 0) || (c == 1 && (j == 0 || j == n))
            };
            let free: Vec<usize> = (0..k.nrows()).filter(|&d| !held(d)).collect();
            let kff = DMatrix::from_fn(free.len(), free.len(), |a, b| k[(free[a], free[b])]);
            kff.symmetric_eigenvalues().min() / material.young
        };
        // The first stretch from λ = 1 down in steps of 0.01 where the smallest eigenvalue
        // is negative, then bisected; 0 if none down to λ = 0.2.
        let Some(first) = (1..=80)
            .map(|k| 1.0 + step * f64::from(k))
            .find(|&s| smallest(s) < 0.0)
        else {
            return 0.0;
        };
        let (mut stable, mut unstable) = (first - step, first);
        while (stable - unstable).abs() > 1e-6 {
            let mid = 0.5 * (stable + unstable);
            if smallest(mid) > 0.0 {
                stable = mid;
            } else {
                unstable = mid;
            }
        }
        stable
    }

    /// Hourglassing under large compression (Wriggers & Reese 1996 found it in enhanced
    /// elements): on 2 × 2, 4 × 4 and 8 × 8 blocks neither cell loses stability before 35 %
    /// compression (measured: λ = 0.587 … 0.637 for ν = 0.3 and 0.45), nor up to 50 %
    /// tension. Both lose it where the converging meshes do (a surface instability of the
    /// St. Venant–Kirchhoff block, its critical stretch rising with the mesh towards
    /// 0.63–0.64), the enhanced cell at most 0.031 before the plain one on the same mesh and
    /// closer to the finer meshes' value, the gap closing as the mesh is refined: no
    /// spurious instability of its own in homogeneous compression.
    #[test]
    fn a_compressed_block_has_no_hourglass_instability_before_the_materials() {
        for nu in [0.3, 0.45] {
            let mut gaps = Vec::new();
            let mut previous = (0.0, 0.0);
            for n in [2, 4, 8] {
                let plain = critical_stretch(n, CellKind::Plain, nu, -0.01);
                let enhanced = critical_stretch(n, CellKind::Enhanced, nu, -0.01);
                assert!(
                    0.55 < plain && plain <= enhanced && enhanced < 0.65,
                    "{nu} {n}"
                );
                assert!(
                    plain > previous.0 && enhanced > previous.1,
                    "{nu} {n}: refined"
                );
                previous = (plain, enhanced);
                gaps.push(enhanced - plain);
            }
            assert!(gaps[0] < 0.035 && gaps[2] < gaps[0] / 2.0, "{nu}: {gaps:?}");
            for kind in KINDS {
                assert_eq!(critical_stretch(4, kind, nu, 0.00625), 0.0, "tension");
            }
        }
    }
}
