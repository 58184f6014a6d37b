//! Rigid clusters of a mechanism and their kinematics.
//!
//! Beams meeting at a node are rigidly joined, so the nodes connected through elements (and
//! through a continuum member's cells) form
//! a *cluster* that moves, when rigid, with three coordinates `ρ = (c_x, c_y, ψ)`:
//! `x_i = X_i + c + (R(ψ) − I)(X_i − X_k)` about the cluster's first node `k`, `φ_i = ψ`.
//! A rigid body is a cluster of its own node.
//!
//! Uses:
//! * when a scene is built, the mechanism checks: every node on a beam or a body, every
//!   body's rotation held, no joint repeating
//!   a constraint of earlier ones ([`redundant_rows`]), every cluster reaching the ground
//!   through joints, and a static scene with no rigid-body mode left (mobility
//!   `3 n_clusters − rank`); and, reported rather than refused because the flexible model
//!   still runs, joints that over-constrain the rigid mechanism ([`Clusters::over_constraint`]);
//! * the rigid trajectory `r_rigid(t)` of the tip-deflection response (paper Eq. 40):
//!   the joints' constraints written on the cluster coordinates, solved by Newton at each
//!   time; the mechanism must be fully driven (mobility zero).
//!
//! The checks at a build take the ranks of `Φ_q` and `Φ_ρ` by [`crate::mechanism::rank`], in
//! near-linear time in the bodies and joints; the rigid kinematics' matrices are dense,
//! `n_rows × 3 n_clusters`.

use nalgebra::{DMatrix, DVector, Dyn, Vector2, SVD};

use crate::error::{Error, SceneError, SolveError};
use crate::interrupt::poll;
use crate::joint::planar::ConstraintRow;
use crate::mechanism::model::{Analysis, Initial, Model};
use crate::mechanism::rank::{repeated_rows, Link, Rank};
use crate::mechanism::rows::Row;
use crate::mechanism::spring::Spring;

/// Rigid over-constraint: `redundant` rows of the joints' Jacobian on the cluster
/// coordinates depend on others. `repeated` of them only repeat what undriven joints
/// between the same two clusters (or a cluster and the ground) already impose — a frame
/// pinned at both ends, a ring hinged at every node of a member's edge —: those agree in
/// every motion. The rest depend through `joints` (indices into `Model::joints`; empty
/// when every redundant row is a repetition): there the flexible model still runs (its
/// rows are independent once frames deform), but the rigid motion exists only where the
/// redundant constraints agree.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OverConstraint {
    /// Number of dependent rows.
    pub redundant: usize,
    /// How many of them repeat rows between the same two clusters.
    pub repeated: usize,
    /// The joints whose rows enter the other dependencies.
    pub joints: Vec<usize>,
}

impl OverConstraint {
    /// The joints by name, for messages: `'A', 'C' and 'lock'`.
    pub fn names(&self, model: &Model) -> String {
        let names: Vec<String> = self
            .joints
            .iter()
            .map(|&j| format!("'{}'", model.joints[j].name))
            .collect();
        match names.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
            _ => names.join(""),
        }
    }
}

/// Partition of the nodes into rigid clusters.
#[derive(Debug, Clone, PartialEq)]
pub struct Clusters {
    /// Cluster of each node.
    pub of_node: Vec<usize>,
    /// The reference node of each cluster (its first node).
    pub anchor: Vec<usize>,
}

impl Clusters {
    /// Connected components of the graph of elements and cells (union–find).
    pub fn of(model: &Model) -> Self {
        let n = model.nodes.len();
        let mut parent: Vec<usize> = (0..n).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let edges = model.elements.iter().map(|e| (e.nodes[0], e.nodes[1]));
        let cells = model
            .cells
            .iter()
            .flat_map(|c| (1..4).map(|k| (c.nodes[0], c.nodes[k])));
        for (a, b) in edges.chain(cells) {
            let (a, b) = (root(&mut parent, a), root(&mut parent, b));
            parent[a.max(b)] = a.min(b);
        }
        let mut of_node = vec![usize::MAX; n];
        let mut anchor = Vec::new();
        for i in 0..n {
            let r = root(&mut parent, i);
            if of_node[r] == usize::MAX {
                of_node[r] = anchor.len();
                anchor.push(r);
            }
            of_node[i] = of_node[r];
        }
        Self { of_node, anchor }
    }

    /// Number of clusters.
    pub fn len(&self) -> usize {
        self.anchor.len()
    }

    /// Node DOF value and its gradient with respect to the cluster coordinates `ρ`.
    fn dof_map(&self, model: &Model, rho: &DVector<f64>, dof: usize) -> (f64, [(usize, f64); 3]) {
        let (node, k) = (dof / 3, dof % 3);
        let c = self.of_node[node];
        let arm = model.nodes[node].position - model.nodes[self.anchor[c]].position;
        let (cx, cy, psi) = (rho[3 * c], rho[3 * c + 1], rho[3 * c + 2]);
        let (cs, sn) = (psi.cos(), psi.sin());
        let rotated = Vector2::new(cs * arm.x - sn * arm.y, sn * arm.x + cs * arm.y);
        let d_rot = Vector2::new(-rotated.y, rotated.x);
        match k {
            0 => (
                cx + rotated.x - arm.x,
                [(3 * c, 1.0), (3 * c + 2, d_rot.x), (0, 0.0)],
            ),
            1 => (
                cy + rotated.y - arm.y,
                [(3 * c + 1, 1.0), (3 * c + 2, d_rot.y), (0, 0.0)],
            ),
            _ => (psi, [(3 * c + 2, 1.0), (0, 0.0), (0, 0.0)]),
        }
    }

    /// Constraint values `Φ(ρ, t)` on the cluster coordinates and their Jacobian: each
    /// row at the nodes' coordinates `q(ρ)`, by the chain rule through [`Clusters::dof_map`].
    /// Only the nodes the rows act on are placed: the rows read no other.
    fn constraints(
        &self,
        model: &Model,
        rho: &DVector<f64>,
        t: f64,
    ) -> (DVector<f64>, DMatrix<f64>) {
        let n_c = model.n_constraints();
        let mut q = vec![0.0; model.n_dofs()];
        let mut placed = vec![false; model.nodes.len()];
        for &dof in model.row_dofs.dofs() {
            if std::mem::replace(&mut placed[dof / 3], true) {
                continue;
            }
            let first = dof - dof % 3;
            for (d, value) in q.iter_mut().enumerate().skip(first).take(3) {
                *value = self.dof_map(model, rho, d).0;
            }
        }
        let mut phi = DVector::zeros(n_c);
        let mut jac = DMatrix::zeros(n_c, 3 * self.len());
        for i in 0..n_c {
            let dofs = model.row_dofs.of_row(i);
            let value = model.constraints().evaluate(i, &q, None, |l, coeff| {
                for (j, g) in self.dof_map(model, rho, dofs[l]).1 {
                    jac[(i, j)] += coeff * g;
                }
            });
            phi[i] = value - model.constraints().prescribed(i, t)[0];
        }
        (phi, jac)
    }

    /// The origin of each cluster's coordinates: its anchor's reference position.
    fn origins(&self, model: &Model) -> Vec<Vector2<f64>> {
        self.anchor
            .iter()
            .map(|&a| model.nodes[a].position)
            .collect()
    }

    /// The links of `Φ_ρ` at the reference — each joint's rows on the cluster coordinates,
    /// by the chain rule through [`Clusters::dof_map`] — then one link per gradient of
    /// `extra` (on six node DOFs each).
    fn links(
        &self,
        model: &Model,
        extra: &[([Option<usize>; 6], [f64; 6])],
    ) -> Result<Vec<Link>, SolveError> {
        let rho = DVector::zeros(3 * self.len());
        let reference = vec![0.0; model.n_dofs()];
        let on_clusters = |terms: Vec<(Option<usize>, f64)>| {
            terms.into_iter().flat_map(|(d, coeff)| {
                let terms = d.map(|d| self.dof_map(model, &rho, d).1);
                let ground = d.is_none().then_some((None, 0.0));
                terms
                    .into_iter()
                    .flatten()
                    .filter(|&(_, g)| g != 0.0)
                    .map(move |(j, g)| (Some(j), coeff * g))
                    .chain(ground)
            })
        };
        let mut links = row_links(model, |k| on_clusters(row_terms(model, k, &reference)))?;
        let extra = extra
            .iter()
            .map(|(d, g)| d.iter().copied().zip(g.iter().copied()));
        links.extend(extra.map(|e| Link::new([on_clusters(e.collect())])));
        Ok(links)
    }

    /// Rigid-body modes neither the joints nor `springs` hold, at the reference:
    /// `3 n_clusters` less the rank of `Φ_ρ` with the springs' gradients on the cluster
    /// coordinates as more rows (no springs: the mechanism's mobility).
    ///
    /// # Errors
    /// [`SolveError::Interrupted`] when the caller asks to stop.
    pub fn free_modes(&self, model: &Model, springs: &[Spring]) -> Result<usize, SolveError> {
        let reference = vec![0.0; model.n_dofs()];
        let extra: Vec<_> = springs
            .iter()
            .map(|s| (s.dofs(), s.measure(&reference).gradient))
            .collect();
        let links = self.links(model, &extra)?;
        Ok(3 * self.len() - Rank::of(&links, &self.origins(model))?.rank())
    }

    /// How the joints over-constrain the rigid mechanism at the reference: the number of
    /// rows of `Φ_ρ` that depend on others (rows minus rank), how many of them repeat
    /// undriven rows between the same two clusters ([`repeated_rows`]), and the joints
    /// whose rows enter the dependencies left once those are set aside: the rows where the
    /// left null space of the other rows is not zero ([`Rank::dependent`]). `None` when
    /// the rows are independent.
    ///
    /// # Errors
    /// [`SolveError::Interrupted`] when the caller asks to stop.
    pub fn over_constraint(&self, model: &Model) -> Result<Option<OverConstraint>, SolveError> {
        let links = self.links(model, &[])?;
        let origins = self.origins(model);
        let rank = Rank::of(&links, &origins)?;
        let redundant = rank.rows() - rank.rank();
        if redundant == 0 {
            return Ok(None);
        }
        let repeats = repeated_rows(&links, |row| !model.constraints().driven(row));
        let repeated = repeats.iter().filter(|&&r| r).count();
        // The links without their repeated rows, and the model row of each row kept.
        let (mut kept, mut rows) = (Vec::new(), Vec::new());
        let mut first = 0;
        for link in &links {
            let keep: Vec<bool> = repeats[first..first + link.len()]
                .iter()
                .map(|r| !r)
                .collect();
            rows.extend((first..first + link.len()).filter(|&r| !repeats[r]));
            kept.extend(link.keeping(&keep));
            first += link.len();
        }
        let mut joints: Vec<usize> = if redundant > repeated {
            let rest = Rank::of(&kept, &origins)?;
            rest.dependent()?
                .into_iter()
                .filter_map(|row| model.rows.get(rows[row]).map(|r| r.joint))
                .collect()
        } else {
            Vec::new()
        };
        joints.dedup();
        Ok(Some(OverConstraint {
            redundant,
            repeated,
            joints,
        }))
    }

    /// Clusters not connected to the ground through any chain of joints and averaging
    /// rings: the parts of the clusters they join (union–find) with no joint to the ground.
    ///
    /// # Errors
    /// [`SolveError::Interrupted`] when the caller asks to stop.
    pub fn floating(&self, model: &Model) -> Result<Vec<usize>, SolveError> {
        let mut parent: Vec<usize> = (0..self.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut ground = Vec::new();
        for j in &model.joints {
            poll()?;
            let mut cs = j.nodes().into_iter().map(|n| self.of_node[n]);
            let Some(first) = cs.next() else { continue };
            for c in cs {
                let (a, b) = (root(&mut parent, first), root(&mut parent, c));
                parent[b] = a;
            }
            if j.is_grounded() {
                ground.push(first);
            }
        }
        for ring in &model.averagings {
            let (a, b) = (self.of_node[ring.reference], self.of_node[ring.nodes[0]]);
            let (a, b) = (root(&mut parent, a), root(&mut parent, b));
            parent[b] = a;
        }
        let mut grounded = vec![false; self.len()];
        for c in ground {
            grounded[root(&mut parent, c)] = true;
        }
        Ok((0..self.len())
            .filter(|&c| !grounded[root(&mut parent, c)])
            .collect())
    }

    /// Cluster coordinates `ρ(t)` when every cluster is rigid and the drives follow their
    /// laws, at each time of `times` (Newton from the previous time's solution).
    ///
    /// # Errors
    /// [`SolveError::Kinematics`] when the mechanism is not fully driven or Newton fails.
    pub fn rigid_motion(
        &self,
        model: &Model,
        times: &[f64],
    ) -> Result<Vec<DVector<f64>>, SolveError> {
        let n = 3 * self.len();
        let mut rho = DVector::zeros(n);
        let mut out = Vec::with_capacity(times.len());
        let scale = model.size();
        // The Jacobian's SVD judges the singularity wherever it is made: at each time's
        // converged point, and where Newton with the one kept from the time before stops
        // contracting tenfold per iteration.
        let mut kept: Option<SVD<f64, Dyn, Dyn>> = None;
        for &t in times {
            let fail = |detail: String| SolveError::Kinematics { time: t, detail };
            let mut previous = f64::INFINITY;
            for iter in 0.. {
                let (phi, jac) = self.constraints(model, &rho, t);
                let residual = phi.amax();
                let converged = residual <= 1e-13 * scale;
                let svd = match kept.take() {
                    Some(svd) if !converged && residual <= 0.1 * previous => kept.insert(svd),
                    _ => kept.insert(jac.svd(true, true)),
                };
                previous = residual;
                let sigma = &svd.singular_values;
                let condition = sigma.min() / sigma.max().max(f64::MIN_POSITIVE);
                if sigma.len() < n || condition < SINGULAR {
                    let free = n - rank_of(sigma).min(n);
                    return Err(fail(if out.is_empty() {
                        format!("the mechanism is not fully driven ({} free rigid-body modes): the rigid trajectory is undefined", free.max(1))
                    } else {
                        format!(
                            "kinematic singularity: the joints' Jacobian is (nearly) rank-deficient here \
                             (smallest/largest singular value {condition:.1e}), so the rigid mechanism cannot \
                             follow its drives through this configuration"
                        )
                    }));
                }
                if converged {
                    break;
                }
                if iter == 50 {
                    let over = self
                        .over_constraint(model)?
                        .filter(|o| !o.joints.is_empty());
                    let over = over.map_or(String::new(), |o| {
                        format!(
                            "; the joints {} over-constrain the rigid mechanism ({} redundant row(s))",
                            o.names(model),
                            o.redundant - o.repeated
                        )
                    });
                    return Err(fail(format!(
                        "no rigid configuration satisfies the joints here (Newton stalled at |Φ| = {:.3e}): \
                         the drives ask for a position the rigid mechanism cannot reach — it went through a \
                         kinematic singularity (a toggle or dead-centre position) or its drives contradict each other{over}",
                        phi.amax()
                    )));
                }
                rho -= svd.solve(&phi, 1e-12).map_err(|e| fail(e.to_string()))?;
            }
            out.push(rho.clone());
        }
        Ok(out)
    }

    /// The rates `∂r/∂p` of `node`'s rigid positions along `motion` (the cluster
    /// coordinates at `times`, from [`Clusters::rigid_motion`]) when driven row `row`'s
    /// prescribed value changes at `rates[n]` at each time: `Φ_ρ ρ_p = e_row g_p`,
    /// `r_p = q_ρ ρ_p`.
    ///
    /// # Errors
    /// [`SolveError::Kinematics`] where `Φ_ρ` cannot be solved, or the row is redundant
    /// with others (the system has no solution: the drive cannot change alone).
    pub fn trajectory_rates(
        &self,
        model: &Model,
        motion: &[DVector<f64>],
        times: &[f64],
        node: usize,
        row: usize,
        rates: &[f64],
    ) -> Result<Vec<[f64; 2]>, SolveError> {
        motion
            .iter()
            .zip(times)
            .zip(rates)
            .map(|((rho, &t), &rate)| {
                let (_, jac) = self.constraints(model, rho, t);
                let mut rhs = DVector::zeros(jac.nrows());
                rhs[row] = rate;
                let fail = |e: &str| SolveError::Kinematics {
                    time: t,
                    detail: e.to_string(),
                };
                let rho_p = jac.clone().svd(true, true).solve(&rhs, 1e-12).map_err(fail)?;
                // A driven row that other rows make redundant cannot move alone.
                if (&jac * &rho_p - &rhs).amax() > 1e-9 * rate.abs() {
                    let joint = &model.joints[model.rows[row].joint].name;
                    return Err(fail(&format!(
                        "the drive of joint '{joint}' is redundant with other joints: its law cannot change alone, so the rigid trajectory has no rate to it"
                    )));
                }
                let along = |dof: usize| -> f64 {
                    let (_, grad) = self.dof_map(model, rho, dof);
                    grad.iter().map(|&(j, g)| g * rho_p[j]).sum()
                };
                Ok([along(3 * node), along(3 * node + 1)])
            })
            .collect()
    }

    /// Position of `node` for cluster coordinates `rho`.
    pub fn position(&self, model: &Model, rho: &DVector<f64>, node: usize) -> [f64; 2] {
        let p = model.nodes[node].position;
        [
            p.x + self.dof_map(model, rho, 3 * node).0,
            p.y + self.dof_map(model, rho, 3 * node + 1).0,
        ]
    }
}

/// Positions of every node of `model` at `times` when every frame is rigid and the joints
/// follow their drives, flattened `[x, y]` per node per time (m).
///
/// # Errors
/// A [`SolveError::Kinematics`] where the rigid kinematics cannot be solved.
pub fn rigid_positions(model: &Model, times: &[f64]) -> Result<Vec<f64>, SolveError> {
    let clusters = Clusters::of(model);
    Ok(clusters
        .rigid_motion(model, times)?
        .iter()
        .flat_map(|rho| (0..model.nodes.len()).flat_map(|k| clusters.position(model, rho, k)))
        .collect())
}

/// The velocities `q̇₀` of the rigid motion in which every joint holds (its rows' rates
/// zero: drives start at rest) and each of `rates` has its coordinate move at its rate:
/// `[Φ_ρ; C_ρ] ρ̇ = [0; ċ]` on the cluster coordinates, `q̇₀ = q_ρ ρ̇`, solved on the free
/// coordinates of the joints' spanning forest ([`Rank::solve`]).
///
/// # Errors
/// A [`SceneError`] at `initial_rates` when the rates leave a rigid-body mode undetermined,
/// or ask for a motion the joints forbid; [`SolveError::Interrupted`] when the caller asks
/// to stop.
pub(crate) fn initial_velocity(
    model: &Model,
    rates: &[(ConstraintRow, f64)],
) -> Result<Vec<f64>, Error> {
    let clusters = Clusters::of(model);
    let reference = vec![0.0; model.n_dofs()];
    let extra: Vec<_> = rates
        .iter()
        .map(|(row, _)| (row.dofs(), row.evaluate(&reference).1))
        .collect();
    let links = clusters.links(model, &extra)?;
    let origins = clusters.origins(model);
    let system = Rank::of(&links, &origins)?;
    let free = 3 * clusters.len() - system.rank();
    if free > 0 {
        let msg = format!("the rates leave {free} rigid-body mode(s) of the mechanism undetermined: give the rates of more joints");
        return Err(SceneError::new("initial_rates", msg).into());
    }
    let n = system.rows() - rates.len();
    let rhs: Vec<f64> = (0..n)
        .map(|_| 0.0)
        .chain(rates.iter().map(|r| r.1))
        .collect();
    let rho_dot = system.solve(&rhs);
    let largest = rhs.iter().fold(0.0, |m: f64, r| m.max(r.abs()));
    if system.residual(&rho_dot, &rhs) > 1e-9 * largest.max(f64::MIN_POSITIVE) {
        let msg = "these rates ask for a motion the joints forbid (more rates than the mechanism has free modes, in contradiction)";
        return Err(SceneError::new("initial_rates", msg).into());
    }
    let rho = DVector::zeros(3 * clusters.len());
    Ok((0..model.n_dofs())
        .map(|dof| {
            let (_, grad) = clusters.dof_map(model, &rho, dof);
            grad.iter().map(|&(j, g)| g * rho_dot[j / 3][j % 3]).sum()
        })
        .collect())
}

/// Smallest over largest singular value of the joints' Jacobian below which the rigid
/// mechanism is taken as singular. Newton converging onto an exact singularity stops
/// about `√tol` away from it, where this ratio is of that order (1e-7); a configuration
/// 1e-6 rad from a toggle still has a ratio near 1e-3.
const SINGULAR: f64 = 1e-6;

/// Numerical rank by singular values relative to the largest.
fn rank_of(s: &DVector<f64>) -> usize {
    let tol = 1e-10 * s.max().max(f64::MIN_POSITIVE);
    s.iter().filter(|&&v| v > tol).count()
}

/// Row `k`'s gradient at `q` as terms `(DOF, value)`, `(None, 0)` for a joint's
/// anchor on the ground.
fn row_terms(model: &Model, k: usize, q: &[f64]) -> Vec<(Option<usize>, f64)> {
    match model.constraints().row(k) {
        Row::Joint(row) => row.dofs().into_iter().zip(row.gradient(q)).collect(),
        Row::Ring(..) => {
            let dofs = model.row_dofs.of_row(k).iter().map(|&d| Some(d));
            dofs.zip(model.constraints().gradient(k, q)).collect()
        }
    }
}

/// One [`Link`] per joint and per averaging ring (in the order of the rows), each row's
/// terms `(coordinate, value)` from `terms`, with [`poll`] between links.
fn row_links<T>(model: &Model, terms: impl Fn(usize) -> T) -> Result<Vec<Link>, SolveError>
where
    T: IntoIterator<Item = (Option<usize>, f64)>,
{
    let owner = |k: usize| match model.constraints().row(k) {
        Row::Joint(row) => (0, row.joint),
        Row::Ring(..) => (1, (k - model.rows.len()) / 3),
    };
    let rows: Vec<usize> = (0..model.n_constraints()).collect();
    rows.chunk_by(|&a, &b| owner(a) == owner(b))
        .map(|rows| {
            poll()?;
            Ok(Link::new(rows.iter().map(|&k| terms(k))))
        })
        .collect()
}

/// Rows of `Φ_q` at the reference that depend linearly on earlier ones (an
/// over-constrained mechanism), in order ([`Rank::redundant`] with the nodes as bodies).
/// An averaging ring, on many nodes, enters as what it does to its reference node alone:
/// a weld to a body of its own, so its rows are never taken as repeating others.
///
/// # Errors
/// [`SolveError::Interrupted`] when the caller asks to stop.
pub fn redundant_rows(model: &Model) -> Result<Vec<usize>, SolveError> {
    let reference = vec![0.0; model.n_dofs()];
    let n_nodes = model.nodes.len();
    let links = row_links(model, |k| match model.constraints().row(k) {
        Row::Joint(_) => row_terms(model, k, &reference),
        Row::Ring(ring, c) => {
            let own = n_nodes + (k - model.rows.len()) / 3;
            let coordinate = c as usize;
            vec![
                (Some(3 * ring.reference + coordinate), 1.0),
                (Some(3 * own + coordinate), -1.0),
            ]
        }
    })?;
    let rings = model
        .averagings
        .iter()
        .map(|r| model.nodes[r.reference].position);
    let bodies: Vec<Vector2<f64>> = model
        .nodes
        .iter()
        .map(|n| n.position)
        .chain(rings)
        .collect();
    Ok(Rank::of(&links, &bodies)?.redundant())
}

/// The mechanism checks of a built scene, in order: every node on a beam or a body, every
/// body's rotation held by inertia or a joint, no redundant
/// joint, every averaging ring on one cluster, every cluster grounded, and for a static scene mobility zero.
///
/// # Errors
/// A [`SceneError`] naming the first node or joint at fault; [`SolveError::Interrupted`]
/// when the caller asks to stop.
pub(crate) fn check_mechanism(model: &Model) -> Result<(), Error> {
    check_attached(model)?;
    check_body_rotations(model)?;
    check_redundancy(model)?;
    let clusters = Clusters::of(model);
    check_rings(model, &clusters)?;
    check_grounding(model, &clusters)?;
    if model.analysis == Analysis::Static || model.initial == Initial::Equilibrium {
        check_mobility(model, &clusters)?;
    }
    Ok(())
}

/// Every node is an end of some element, a corner of a cell or a rigid body's.
fn check_attached(model: &Model) -> Result<(), SceneError> {
    let mut attached = vec![false; model.nodes.len()];
    model
        .elements
        .iter()
        .flat_map(|e| e.nodes)
        .chain(model.cells.iter().flat_map(|c| c.nodes))
        .chain(model.bodies.iter().map(|b| b.node))
        .for_each(|n| attached[n] = true);
    match attached.iter().position(|a| !a) {
        Some(n) => Err(SceneError::new(
            format!("node '{}'", model.nodes[n].name),
            "is not attached to any beam",
        )),
        None => Ok(()),
    }
}

/// A rigid body without rotary inertia has its rotation held by something: a beam ending
/// at its centre, or a joint at one of its points or one that locks or drives its rotation.
/// Otherwise the rotation is a free unknown with no inertia and the iteration matrix is
/// singular.
fn check_body_rotations(model: &Model) -> Result<(), SceneError> {
    let n = model.nodes.len();
    let mut inertia = vec![0.0; n];
    for p in &model.point_masses {
        inertia[p.node] += p.inertia;
    }
    let mut held = vec![false; n];
    for e in &model.elements {
        e.nodes.iter().for_each(|&node| held[node] = true);
    }
    for &d in model.row_dofs.dofs().iter().filter(|&&d| d % 3 == 2) {
        held[d / 3] = true;
    }
    match model
        .bodies
        .iter()
        .find(|b| inertia[b.node] == 0.0 && !held[b.node])
    {
        Some(body) => Err(SceneError::new(
            format!("rigid body '{}'", body.name),
            "has no rotary inertia and no joint holds its rotation (its joints act at its \
             centre): give it an inertia, or attach a joint at one of its points",
        )),
        None => Ok(()),
    }
}

/// No row of `Φ_q` depends on earlier ones: the first redundant row names its joint.
fn check_redundancy(model: &Model) -> Result<(), Error> {
    match redundant_rows(model)?.first() {
        Some(&r) if r < model.rows.len() => {
            let j = model.rows[r].joint;
            Err(SceneError::new(
                format!("joints[{j}] ({})", model.joints[j].name),
                "over-constrained: this joint repeats a constraint already imposed by earlier joints",
            )
            .into())
        }
        // A ring's rows stand there for a weld to a body of their own: judged below.
        _ => check_ring_redundancy(model),
    }
}

/// An averaging ring's rows with every row that acts on its nodes or its body, at the
/// reference (a dense rank, the ring being small): the ring named where they depend on one
/// another — its nodes all pinned and its centre held as well, say. Dependencies that reach
/// further through the structure are not seen here; Newton then names the ring's multiplier
/// at a zero pivot.
fn check_ring_redundancy(model: &Model) -> Result<(), Error> {
    let constraints = model.constraints();
    let reference = vec![0.0; model.n_dofs()];
    for ring in &model.averagings {
        poll()?;
        let mut on = vec![false; model.nodes.len()];
        ring.nodes
            .iter()
            .chain([&ring.reference])
            .for_each(|&n| on[n] = true);
        let rows: Vec<usize> = (0..model.n_constraints())
            .filter(|&k| model.row_dofs.of_row(k).iter().any(|&d| on[d / 3]))
            .collect();
        let mut dofs: Vec<usize> = (rows.iter())
            .flat_map(|&k| model.row_dofs.of_row(k))
            .copied()
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        let mut jac = DMatrix::<f64>::zeros(rows.len(), dofs.len());
        for (i, &k) in rows.iter().enumerate() {
            let gradient = constraints.gradient(k, &reference);
            for (&d, g) in model.row_dofs.of_row(k).iter().zip(gradient) {
                jac[(i, dofs.binary_search(&d).unwrap_or_default())] += g;
            }
        }
        if rank_of(&jac.transpose().singular_values()) < rows.len() {
            return Err(SceneError::new(
                format!("ring '{}'", ring.name),
                "over-constrained: its rows repeat what the joints on its nodes and its centre \
                 already impose (an averaging ring's nodes must keep some freedom)",
            )
            .into());
        }
    }
    Ok(())
}

/// An averaging ring's nodes lie on one member or frame: its rows act on that cluster and
/// its body, as every link of the rank analysis acts on two.
fn check_rings(model: &Model, clusters: &Clusters) -> Result<(), SceneError> {
    for ring in &model.averagings {
        let first = clusters.of_node[ring.nodes[0]];
        if let Some(&n) = (ring.nodes.iter()).find(|&&n| clusters.of_node[n] != first) {
            let (a, b) = (&model.nodes[ring.nodes[0]].name, &model.nodes[n].name);
            let msg = format!(
                "nodes '{a}' and '{b}' lie on different members or frames: an averaging ring \
                 acts on one (join two with a joint at each ring's centre)"
            );
            return Err(SceneError::new(format!("ring '{}'", ring.name), msg));
        }
    }
    Ok(())
}

/// Every cluster reaches the ground through a chain of joints.
fn check_grounding(model: &Model, clusters: &Clusters) -> Result<(), Error> {
    match clusters.floating(model)?.first() {
        Some(&c) => {
            let node = &model.nodes[clusters.anchor[c]].name;
            Err(SceneError::new("joints", format!("unconstrained: the frame containing node '{node}' is not connected to the ground by any joint")).into())
        }
        None => Ok(()),
    }
}

/// The springs with stiffness (a damper alone holds nothing at rest).
fn stiff_springs(model: &Model) -> Vec<Spring> {
    model
        .springs
        .iter()
        .filter(|s| s.stiffness > 0.0)
        .cloned()
        .collect()
}

/// The joints and springs leave no rigid-body mode free (a static scene, or the
/// equilibrium a dynamic one starts from, cannot be a mechanism).
fn check_mobility(model: &Model, clusters: &Clusters) -> Result<(), Error> {
    match clusters.free_modes(model, &stiff_springs(model))? {
        0 => Ok(()),
        free => Err(SceneError::new("joints", format!("unconstrained: the static scene is a mechanism with {free} free rigid-body mode(s); clamp or drive its joints, or hold them with springs")).into()),
    }
}
