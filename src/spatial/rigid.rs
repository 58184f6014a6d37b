//! The rigid trajectory of a spatial mechanism: where its nodes would go were every link
//! rigid — the `r_rigid(t)` of the tip deflection (paper Eq. 40, "the tip position of the
//! undeformed mechanism … computed from the joint trajectory using the rigid kinematic
//! relations").
//!
//! **Links.** The beams, the truss bars and the welds between two nodes are the edges of a
//! graph on the nodes; its connected components are the links. The **rigid companion** has
//! one node per link, at its first node's initial frame, carrying a nominal mass and
//! inertia; every other joint of the mechanism acts on the links' nodes, its anchors carried
//! into their frames, with its drive; welds to the ground stay; force elements go (the
//! rigid motion is the drives', not the loads'). It runs on the engine's integrator, on the
//! run's grid, and a node's rigid trajectory is its link's pose applied to its initial
//! place in the link: `r(t) = x_L(t) + R_L(t) R_L(0)ᵀ (x₀ − x_L(0))`.
//!
//! Its motion is the rigid trajectory only where the drives determine it: with every
//! freedom driven, the constraints `Φ(q, tₙ) = 0` fix each state whatever the masses. That
//! is checked, not assumed: the companion runs twice with two different distributions of
//! its nominal masses, and trajectories that differ by more than [`DETERMINED_TOLERANCE`]
//! of the mechanism's size show a freedom no drive holds ([`SettingsError`] naming it).
//!
//! **Rates.** A parameter `p` of a drive's law moves the rigid trajectory as the
//! constraints say: `B(qₙ) εₙ = −∂Φ/∂p` at each state (`εₙ` the links' variation, `B` of
//! full column rank where the drives hold every freedom, the rows possibly redundant: a
//! least-squares solve), and a node at `place` in its link moves by
//! `u' + R_L (θ' × place)` ([`rigid_trajectory_rates`]).

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::error::{Error, SettingsError, SolveError};
use crate::group::Frame;
use crate::group::NV;
use crate::joint::motion::LawParameter;
use crate::joint::spatial::{Anchor, JointKind};
use crate::mechanism::rank::Sets;
use crate::settings::{DynamicSettings, TOL};
use crate::solver::alpha::State;
use crate::spatial::integrator::simulate_spatial;
use crate::spatial::model::SpatialModel;
use crate::time_grid::TimeGrid;

/// Largest difference (of the mechanism's size) between the companion's two runs for its
/// motion to count as determined by the drives: the companion's Newton tolerance is 1e-10
/// or tighter (whatever the run's, [`companion_run`]), a free freedom moves by a share of
/// the motion.
pub const DETERMINED_TOLERANCE: f64 = 1e-7;

/// Largest residual of `B ε = −∂Φ/∂p` (of `‖∂Φ/∂p‖`) for a drive's law to move the rigid
/// trajectory: a driven row the other rows repeat leaves a residual of its own size.
const REDUNDANT_DRIVE: f64 = 1e-6;

/// The links of a mechanism: each node's link, and each link's first node.
struct Links {
    of_node: Vec<usize>,
    first: Vec<usize>,
}

impl Links {
    fn new(model: &SpatialModel) -> Self {
        let mut sets = Sets::new(model.nodes.len());
        let welds = (model.joints.iter())
            .filter(|j| j.kind == JointKind::Weld)
            .map(|j| j.pair.nodes);
        let elements = model.elements().map(|e| e.pair().nodes);
        for nodes in welds.chain(elements) {
            if let [Some(a), Some(b)] = nodes {
                sets.union(a, b);
            }
        }
        let mut link_of_root = vec![usize::MAX; model.nodes.len()];
        let (mut of_node, mut first) = (Vec::new(), Vec::new());
        for node in 0..model.nodes.len() {
            let root = sets.find(node);
            if link_of_root[root] == usize::MAX {
                link_of_root[root] = first.len();
                first.push(node);
            }
            of_node.push(link_of_root[root]);
        }
        Self { of_node, first }
    }

    /// A node's anchor point `arm` (in its frame) as an anchor on its link's node.
    fn anchor(&self, model: &SpatialModel, node: Option<usize>, arm: Vector3<f64>) -> Anchor {
        let Some(node) = node else {
            return Anchor::Ground(arm);
        };
        let link = self.of_node[node];
        let (at, of) = (
            &model.nodes[node].frame,
            &model.nodes[self.first[link]].frame,
        );
        let point = of.r.inverse() * (at.x + at.r * arm - of.x);
        Anchor::Node { node: link, point }
    }
}

/// The rigid companion of `model` over `links` (module docs), its links' nominal masses
/// spread by `spread` (the second run's differ from the first's), with each of the
/// model's joints' index in it (`None` for a joint within one link).
///
/// # Errors
/// A [`SettingsError`] at `tip_deflection` for a drive within one link; the model's own
/// errors where a carried joint cannot be built.
fn companion(
    model: &SpatialModel,
    links: &Links,
    spread: bool,
) -> Result<(SpatialModel, Vec<Option<usize>>), Error> {
    let mut rigid = SpatialModel::new(model.gravity)?;
    let (mass, length) = nominal(model, links.first.len());
    for (k, &node) in links.first.iter().enumerate() {
        // The second run changes each link's mass and the shape and size of its inertia.
        let (factor, moments) = if spread {
            (1.0 + (k % 3) as f64, Vector3::new(6.0, 3.0, 4.5))
        } else {
            (1.0, Vector3::new(1.0, 1.5, 2.0))
        };
        let inertia = Matrix3::from_diagonal(&moments);
        let n = &model.nodes[node];
        let body = rigid.add_body(
            &n.name,
            n.frame,
            mass * factor,
            inertia * (mass * factor * length * length),
        )?;
        let [u, w] = [&n.velocity[..3], &n.velocity[3..]].map(Vector3::from_column_slice);
        rigid.set_rates(body, u, w)?;
    }
    let mut carried_as = Vec::with_capacity(model.joints.len());
    for joint in &model.joints {
        carried_as.push(None);
        let [a, b] = [0, 1].map(|s| links.anchor(model, joint.pair.nodes[s], joint.pair.arms[s]));
        let same_link = matches!((&a, &b), (Anchor::Node { node: x, .. }, Anchor::Node { node: y, .. }) if x == y);
        if same_link {
            if joint.is_driven() {
                return Err(SettingsError::new(
                    "tip_deflection",
                    format!(
                        "joint '{}' is driven within one link (its beams join its two sides): \
                         the rigid mechanism cannot move it",
                        joint.name
                    ),
                )
                .into());
            }
            continue;
        }
        let carried = rigid.add_joint(&joint.name, joint.kind, a, b)?;
        if let Some(law) = joint.drive_law() {
            rigid.add_drive(carried, law.clone())?;
        }
        if let Some(last) = carried_as.last_mut() {
            *last = Some(carried);
        }
    }
    Ok((rigid, carried_as))
}

/// The rigid companion and its run.
struct Companion {
    model: SpatialModel,
    /// Each of the mechanism's joints' index in the companion.
    carried_as: Vec<Option<usize>>,
    states: Vec<State>,
}

/// Largest singular value of the companion's constraint gradient (of its largest) below
/// which a direction of its links' motion counts as free: round-off of unit-sized rows.
const FREE_DIRECTION: f64 = 1e-9;

/// The freedoms the companion's joints and drives leave its links at the start: the null
/// space of their gradient `B` (rows × six per link, each column the rows' rate `Φ̇ − ∂Φ/∂t`
/// at a unit velocity of one link), its dimension by the singular values of `B` below
/// [`FREE_DIRECTION`] of the largest. The two runs of [`rigid_trajectories`] cannot see a
/// freedom that neither moves (a link hinged at its own first node, where its nominal mass
/// sits, feels no weight); the rank does.
fn free_motions(rigid: &SpatialModel) -> usize {
    let (q, n) = (rigid.initial_configuration(), NV * rigid.nodes.len());
    let rows: usize = rigid.joints.iter().map(|j| j.n_rows()).sum();
    if rows == 0 {
        return n;
    }
    let mut b = DMatrix::<f64>::zeros(rows, n);
    let mut v = vec![0.0; n];
    // `∂Φ/∂t` of each joint, taken once: what its rates read at rest.
    let at_rest: Vec<_> = rigid.joints.iter().map(|j| j.rates(&q, &v, 0.0)).collect();
    for column in 0..n {
        v[column] = 1.0;
        let mut row = 0;
        for (j, still) in rigid.joints.iter().zip(&at_rest) {
            let rate = j.rates(&q, &v, 0.0) - still;
            for k in 0..j.n_rows() {
                b[(row + k, column)] = rate[k];
            }
            row += j.n_rows();
        }
        v[column] = 0.0;
    }
    let sigma = b.singular_values();
    let largest = sigma.max();
    n - sigma
        .iter()
        .filter(|&&s| s > FREE_DIRECTION * largest)
        .count()
}

/// The companion's run (its rates checked to be a rigid motion of the links).
///
/// # Errors
/// As [`rigid_trajectories`].
fn companion_run(
    model: &SpatialModel,
    links: &Links,
    spread: bool,
    settings: &DynamicSettings,
    grid: &TimeGrid,
) -> Result<Companion, Error> {
    let (rigid, carried_as) = companion(model, links, spread)?;
    let free = free_motions(&rigid);
    if free > 0 {
        return Err(SettingsError::new(
            "tip_deflection",
            format!(
                "the drives leave the rigid mechanism {}, so it has no rigid trajectory (drive \
                 every freedom of the mechanism with its links rigid)",
                if free == 1 {
                    "a freedom".to_string()
                } else {
                    format!("{free} freedoms")
                }
            ),
        )
        .into());
    }
    rigid.check_rates().map_err(|e| {
        SettingsError::new(
            "tip_deflection",
            format!("the initial rates are not a rigid motion of the links: {e}"),
        )
    })?;
    // At Newton's default tolerance or the run's tighter one: a looser one (a companion run
    // of a run to a tolerance stops at 1e-6) moves the two runs' trajectories apart by more
    // than DETERMINED_TOLERANCE, which would pass for a freedom no drive holds.
    let tight = DynamicSettings {
        tol: settings.tol.min(TOL),
        ..*settings
    };
    let states = simulate_spatial(&rigid, &tight, grid)?;
    Ok(Companion {
        model: rigid,
        carried_as,
        states,
    })
}

/// Where node `n` sits in its link's frame, with the link.
fn place(model: &SpatialModel, links: &Links, n: usize) -> (usize, Vector3<f64>) {
    let link = links.of_node[n];
    let (at, of) = (&model.nodes[n].frame, &model.nodes[links.first[link]].frame);
    (link, of.r.inverse() * (at.x - of.x))
}

/// A nominal mass (kg, the mechanism's mean per link) and length (m, its size over its
/// links) for the companion's links.
fn nominal(model: &SpatialModel, links: usize) -> (f64, f64) {
    let total: f64 = model.bodies.iter().map(|b| b.mass).sum::<f64>()
        + model.elements().map(|e| e.mass()).sum::<f64>();
    let n = links.max(1) as f64;
    let mass = if total > 0.0 { total / n } else { 1.0 };
    (mass, model.size().max(f64::MIN_POSITIVE))
}

/// The rigid trajectories of `nodes`' origins over `grid` (module docs): one position per
/// state of the grid, for each node in order.
///
/// # Errors
/// [`SettingsError`] at `tip_deflection` where the drives leave a freedom of the rigid
/// mechanism free, its initial rates are not a rigid motion of the links, or a drive acts
/// within one link; the companion's run errors (a singular matrix where the rigid
/// mechanism's joints repeat one another).
pub fn rigid_trajectories(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    nodes: &[usize],
) -> Result<Vec<Vec<Vector3<f64>>>, Error> {
    let links = Links::new(model);
    let run = |spread| -> Result<Vec<Vec<Vector3<f64>>>, Error> {
        let states = companion_run(model, &links, spread, settings, grid)?.states;
        Ok(nodes
            .iter()
            .map(|&n| {
                let (link, place) = place(model, &links, n);
                let frame = |s: &State| {
                    let f = Frame::read(&s.q, link);
                    f.x + f.r * place
                };
                states.iter().map(frame).collect()
            })
            .collect())
    };
    let (first, second) = (run(false)?, run(true)?);
    let size = model.size();
    for (k, (a, b)) in first.iter().zip(&second).enumerate() {
        let gap = (a.iter().zip(b))
            .map(|(a, b)| (a - b).norm())
            .fold(0.0f64, f64::max);
        if gap.is_nan() || gap > DETERMINED_TOLERANCE * size {
            return Err(SettingsError::new(
                "tip_deflection",
                format!(
                    "the drives leave the rigid mechanism a freedom: node '{}' moves by {:.1e} m \
                     more or less as its links' masses change, so it has no rigid trajectory \
                     (drive every freedom of the mechanism with its links rigid)",
                    model.nodes[nodes[k]].name, gap
                ),
            )
            .into());
        }
    }
    Ok(first)
}

/// The rates `∂r_rigid/∂p` of `nodes`' rigid trajectories over `grid` to each of `drives`
/// (a joint of `model` and a parameter of its trapezoidal law), indexed
/// `[drive][node][state]` (module docs: the constraints solved for the links' variation
/// at each state of the companion's run).
///
/// # Errors
/// As [`rigid_trajectories`]; a [`SettingsError`] at `parameters` for a drive within one
/// link, which the rigid mechanism does not carry.
pub(crate) fn rigid_trajectory_rates(
    model: &SpatialModel,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    nodes: &[usize],
    drives: &[(usize, LawParameter)],
) -> Result<Vec<Vec<Vec<Vector3<f64>>>>, Error> {
    if drives.is_empty() {
        return Ok(Vec::new());
    }
    let links = Links::new(model);
    let Companion {
        model: rigid,
        carried_as,
        states,
    } = companion_run(model, &links, false, settings, grid)?;
    let carried = (drives.iter())
        .map(|&(joint, law)| {
            carried_as[joint].map(|c| (c, law)).ok_or_else(|| {
                SettingsError::new(
                    "parameters",
                    format!("joint '{}' lies within one link", model.joints[joint].name),
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let places: Vec<_> = nodes.iter().map(|&n| place(model, &links, n)).collect();
    let mut rates = vec![vec![Vec::with_capacity(states.len()); nodes.len()]; drives.len()];
    for s in &states {
        let b = constraint_gradient(&rigid, s);
        let svd = b.clone().svd(true, true);
        for (&(joint, law), out) in carried.iter().zip(&mut rates) {
            let mut rhs = DVector::zeros(b.nrows());
            let j = &rigid.joints[joint];
            if let (Some(rows), Some((row, rate))) =
                (rigid.joint_rows(joint), j.drive_rate(&s.q, None, s.t, law))
            {
                rhs[rows.start + row] = -rate.value;
            }
            let eps = svd
                .solve(&rhs, 1e-12 * svd.singular_values.max())
                .map_err(|e| SolveError::Singular {
                    time: s.t,
                    detail: format!("the rigid mechanism's constraints: {e}"),
                })?;
            // The driven row must be independent of the others for the law to move them.
            let miss = (&b * &eps - &rhs).amax();
            if miss > REDUNDANT_DRIVE * rhs.amax() {
                return Err(SettingsError::new(
                    "parameters",
                    format!(
                        "joint '{}': the rigid mechanism's other joints already fix what its \
                         drive imposes, so its law cannot move the rigid trajectory",
                        rigid.joints[joint].name
                    ),
                )
                .into());
            }
            for (&(link, place), path) in places.iter().zip(out.iter_mut()) {
                let e = eps.fixed_rows::<NV>(NV * link);
                let (u, theta) = (e.fixed_rows::<3>(0), e.fixed_rows::<3>(3));
                let r = Frame::read(&s.q, link).rotation();
                path.push(u + r * theta.cross(&place));
            }
        }
    }
    Ok(rates)
}

/// The constraints' gradient `B` of `model` at state `s`, dense.
fn constraint_gradient(model: &SpatialModel, s: &State) -> DMatrix<f64> {
    let mut b = DMatrix::zeros(model.n_rows(), model.n_v());
    let mut first = 0;
    for joint in &model.joints {
        let g = joint.gradient(&s.q, s.t);
        for (side, node) in joint.local_nodes() {
            for r in 0..joint.n_rows() {
                for c in 0..NV {
                    b[(first + r, NV * node + c)] = g[(r, NV * side + c)];
                }
            }
        }
        first += joint.n_rows();
    }
    b
}
