//! The rank of a joints' Jacobian in near-linear time, and the rows that depend on others.
//!
//! The Jacobian's column blocks are *bodies* of three coordinates — the nodes of `q` for
//! `Φ_q`, the rigid clusters of `ρ` for `Φ_ρ` — and its row blocks *links*: a joint's rows,
//! or a spring's row, each on one or two bodies and perhaps the ground. A dense SVD costs
//! `O(n³)` in the bodies; this analysis costs `O(n)` for trees, and for loops the length of
//! their paths in the tree and a dense factorization of their reduced rows only.
//!
//! 1. **Spanning forest**, links in the order given (Kruskal's, with no weights). A link
//!    that joins two parts not yet connected — the ground one part with every grounded one
//!    — with rows of full rank on each body it acts on is a *tree* link. Its rows are
//!    independent of all earlier rows, and no later tree link enters a dependency among
//!    earlier rows: a row between two bodies is invariant under their common rigid motion
//!    (joined points coincide at the reference, a distance and a relative angle do not
//!    change), so an ungrounded part moves rigidly under all its own rows, which the new
//!    link's rows on one of its bodies, of full rank, cannot all allow.
//! 2. **Free coordinates.** The body velocities that satisfy every tree row are, down each
//!    tree, `u_c = M_c u_p + F_c ξ_c` with `F_c` an orthonormal basis of `ker J_c` (`J_c`,
//!    `J_p`: the tree link's blocks on the child `c` and its parent `p`) and
//!    `M_c = (I − J_c⁺ J_c) T_c − J_c⁺ J_p`, which solves `J_c M_c = −J_p` and is the rigid
//!    transport `T_c` from `p` to `c` (`u_c = u_p + ω × (x_c − x_p)`) since
//!    `J_c T_c = −J_p` (the invariance): a subtree moves rigidly with its root. Below the
//!    ground `u_c = F_c ξ_c`; a root that no ground holds has its three coordinates free.
//!    So `u = N ξ` with `N` spanning `ker J_tree`.
//! 3. **Loop rows** — every row of the other links — reduce to `ṽ = v N`: `v` depends on the
//!    tree rows and some loop rows if and only if `ṽ` depends on theirs, and the rank is the
//!    number of tree rows plus the rank of the reduced rows. A row between two bodies of one
//!    tree sees only the free coordinates below their lowest common ancestor (step 1's
//!    invariance), so a loop's row is as long as the loop.
//! 4. **Reduced blocks.** A reduced row alone on a free coordinate is independent of the
//!    others, which are judged without it (peeled, until no row is alone); the rest fall
//!    into blocks that share no coordinate, each dense and small: its SVD gives its rank and
//!    left null vectors, Gram–Schmidt in order the rows that depend on earlier ones, both at
//!    the relative threshold [`TOL`].

use std::collections::{BinaryHeap, HashMap};

use nalgebra::{DMatrix, DVector, Matrix3, Vector2, Vector3};

use crate::error::SolveError;
use crate::interrupt::poll;

/// Relative threshold of rank: a singular value, a residual of Gram–Schmidt or a reduced
/// entry at or below `TOL` times its scale (the largest singular value, the row's size)
/// counts as zero.
const TOL: f64 = 1e-10;

/// Entry of a left null vector (unit length) below which its row is taken as not entering
/// the dependency.
const NULL_ENTRY: f64 = 1e-8;

/// The rows of one joint, or of one spring, on at most two bodies and perhaps the ground.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Link {
    /// The body it acts on.
    a: usize,
    /// Its other body, if it acts on two.
    b: Option<usize>,
    /// Whether it also acts on the ground.
    grounded: bool,
    /// Its number of rows: at most three (a joint's; a spring's one).
    len: usize,
    /// Each row's coefficients on `a`'s three coordinates, then on `b`'s (the first `len`).
    rows: [[f64; 6]; 3],
    /// Their sizes before any term cancelled another: the sums of the terms' magnitudes.
    sizes: [[f64; 6]; 3],
}

impl Link {
    /// The link of `rows`, each given as the terms of its gradient: `(Some(3 body + k),
    /// value)`, or `(None, _)` for a coordinate of the ground. The rows, at most three, act
    /// on one or two bodies together (every row of a joint on its one or two anchors).
    pub(crate) fn new<R>(rows: impl IntoIterator<Item = R>) -> Self
    where
        R: IntoIterator<Item = (Option<usize>, f64)>,
    {
        let mut bodies: [Option<usize>; 2] = [None; 2];
        let mut link = Self {
            a: 0,
            b: None,
            grounded: false,
            len: 0,
            rows: [[0.0; 6]; 3],
            sizes: [[0.0; 6]; 3],
        };
        for (i, terms) in rows.into_iter().enumerate() {
            assert!(i < 3, "a joint has at most three rows");
            link.len = i + 1;
            for (coordinate, value) in terms {
                let Some(j) = coordinate else {
                    link.grounded = true;
                    continue;
                };
                let side = (bodies.iter())
                    .position(|&b| b.is_none() || b == Some(j / 3))
                    .expect("a joint or spring acts on at most two bodies");
                bodies[side] = Some(j / 3);
                link.rows[i][3 * side + j % 3] += value;
                link.sizes[i][3 * side + j % 3] += value.abs();
            }
        }
        link.a = bodies[0].expect("a joint or spring acts on a body");
        link.b = bodies[1];
        link
    }

    /// The block of the rows on side `side` (0: `a`, 1: `b`), padded with zero rows.
    fn block(&self, side: usize) -> Matrix3<f64> {
        Matrix3::from_fn(|i, k| {
            if i < self.len {
                self.rows[i][3 * side + k]
            } else {
                0.0
            }
        })
    }

    /// The coefficients of row `i` on side `side`.
    fn on(&self, i: usize, side: usize) -> Vector3<f64> {
        Vector3::from_column_slice(&self.rows[i][3 * side..3 * side + 3])
    }

    /// Their sizes before cancellation.
    fn size_on(&self, i: usize, side: usize) -> Vector3<f64> {
        Vector3::from_column_slice(&self.sizes[i][3 * side..3 * side + 3])
    }

    /// The link of the rows `keep` marks (`None` where it marks none): the same bodies.
    pub(crate) fn keeping(&self, keep: &[bool]) -> Option<Self> {
        let mut out = Self {
            len: 0,
            rows: [[0.0; 6]; 3],
            sizes: [[0.0; 6]; 3],
            ..self.clone()
        };
        for i in (0..self.len).filter(|&i| keep[i]) {
            out.rows[out.len] = self.rows[i];
            out.sizes[out.len] = self.sizes[i];
            out.len += 1;
        }
        (out.len > 0).then_some(out)
    }

    /// Its number of rows.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The bodies it acts on as a key that does not depend on their order (`(a, b, ground)`,
    /// `a < b`), and row `i` on their coordinates in that order.
    fn keyed_row(&self, i: usize) -> ((usize, Option<usize>, bool), [f64; 6]) {
        let mut row = self.rows[i];
        match self.b {
            Some(b) if b < self.a => {
                row.rotate_left(3);
                ((b, Some(self.a), self.grounded), row)
            }
            b => ((self.a, b, self.grounded), row),
        }
    }

    /// Whether the rows have full row rank on side `side`'s body.
    fn full_rank_on(&self, side: usize) -> bool {
        let sigma = self.block(side).singular_values();
        rank_of(sigma.as_slice(), 0.0) == self.len
    }
}

/// Per row of `links`, in order: whether it repeats what rows before it on the same bodies
/// (one body and the ground, or two bodies) already impose, among the rows `counts` admits
/// (ordered Gram–Schmidt on each pair of bodies' rows; a row repeats where its residual is
/// at most [`TOL`] times its size). Such rows hold in every motion the others allow: two
/// pins between the same two frames weld them, and a third says nothing more.
pub(crate) fn repeated_rows(links: &[Link], counts: impl Fn(usize) -> bool) -> Vec<bool> {
    let mut bases: HashMap<(usize, Option<usize>, bool), Vec<DVector<f64>>> = HashMap::new();
    let mut out = Vec::with_capacity(links.iter().map(Link::len).sum());
    for link in links {
        for i in 0..link.len {
            if !counts(out.len()) {
                out.push(false);
                continue;
            }
            let (key, row) = link.keyed_row(i);
            let size: f64 = link.sizes[i].iter().sum();
            let basis = bases.entry(key).or_default();
            let mut v = DVector::from_column_slice(&row);
            for _ in 0..2 {
                for b in basis.iter() {
                    v -= b * b.dot(&v);
                }
            }
            let norm = v.norm();
            let repeats = norm <= TOL * size;
            if !repeats {
                basis.push(v / norm);
            }
            out.push(repeats);
        }
    }
    out
}

/// Number of the singular values `sigma` (largest first) above [`TOL`] times the larger of
/// the largest and `scale`.
fn rank_of(sigma: &[f64], scale: f64) -> usize {
    let tol = TOL * sigma.first().copied().unwrap_or(0.0).max(scale);
    sigma.iter().filter(|&&s| s > tol && s > 0.0).count()
}

/// Disjoint sets (union–find with path halving).
pub(crate) struct Sets(Vec<usize>);

impl Sets {
    pub(crate) fn new(n: usize) -> Self {
        Self((0..n).collect())
    }

    /// The representative of `i`'s set.
    pub(crate) fn find(&mut self, mut i: usize) -> usize {
        while self.0[i] != i {
            self.0[i] = self.0[self.0[i]];
            i = self.0[i];
        }
        i
    }

    /// Joins the sets of `a` and `b`; the representative of the union.
    pub(crate) fn union(&mut self, a: usize, b: usize) -> usize {
        let (a, b) = (self.find(a), self.find(b));
        self.0[b] = a;
        a
    }
}

/// The parts the links connect so far, each grounded or not (step 1).
struct Parts {
    sets: Sets,
    /// Per representative, whether the part reaches the ground.
    grounded: Vec<bool>,
}

impl Parts {
    /// Whether `link` joins two parts not connected yet, the ground one part.
    fn joins(&mut self, link: &Link) -> bool {
        let a = self.sets.find(link.a);
        match (link.b.map(|b| self.sets.find(b)), link.grounded) {
            (None, true) => !self.grounded[a],
            (Some(b), false) => a != b && !(self.grounded[a] && self.grounded[b]),
            _ => false,
        }
    }

    /// Connects the bodies of `link`, and the ground if it acts on it.
    fn connect(&mut self, link: &Link) {
        let mut grounded = link.grounded || self.grounded[self.sets.find(link.a)];
        let mut root = self.sets.find(link.a);
        if let Some(b) = link.b {
            grounded |= self.grounded[self.sets.find(b)];
            root = self.sets.union(link.a, b);
        }
        self.grounded[root] = grounded;
    }
}

/// How a body moves in the forest: `u = M u_parent + F ξ` (step 2).
#[derive(Debug, Clone)]
struct Edge {
    /// The tree link to its parent and the side of it the body is on; none for a root
    /// that no ground holds.
    link: Option<(usize, usize)>,
    /// The parent body; none for the ground or a root.
    parent: Option<usize>,
    /// `J⁺` of the link's block on the body (`3 × 3`, zero columns past its rows).
    pinv: Matrix3<f64>,
    /// `M`, zero without a parent body.
    m: Matrix3<f64>,
    /// An orthonormal basis of `ker J` in its first `free` columns.
    basis: Matrix3<f64>,
    free: usize,
    /// Index of the first of its free coordinates `ξ`.
    first: usize,
}

/// A loop row reduced to the free coordinates.
#[derive(Debug, Clone)]
struct Reduced {
    /// Its row of the Jacobian.
    row: usize,
    /// Its link and its place in it.
    link: usize,
    at: usize,
    /// `ṽ = v N`: (free coordinate, value), leaving out entries `v f` (`f` a unit column
    /// of `N`) at most [`TOL`] times the size of `v` had nothing cancelled.
    entries: Vec<(usize, f64)>,
    /// The size of `ṽ` had nothing cancelled: the scale of its threshold.
    size: f64,
}

/// What the rows put on each body, taken deepest first ([`Rank::tree_part`]).
#[derive(Default)]
struct Sums {
    by_body: HashMap<usize, Vector3<f64>>,
    queue: BinaryHeap<(usize, usize)>,
}

impl Sums {
    /// Adds `s` to the sum on `body`, at `depth` in its tree.
    fn add(&mut self, body: usize, depth: usize, s: Vector3<f64>) {
        match self.by_body.get_mut(&body) {
            Some(sum) => *sum += s,
            None => {
                self.by_body.insert(body, s);
                self.queue.push((depth, body));
            }
        }
    }

    /// The deepest body with its sum, taken out.
    fn deepest(&mut self) -> Option<(usize, Vector3<f64>)> {
        let (_, body) = self.queue.pop()?;
        Some((body, self.by_body.remove(&body)?))
    }
}

/// The rank analysis of the Jacobian of a list of links.
pub(crate) struct Rank<'a> {
    links: &'a [Link],
    /// The position of each body's coordinates' origin (a node, a cluster's anchor).
    positions: &'a [Vector2<f64>],
    /// First row of each link.
    first: Vec<usize>,
    rows: usize,
    /// Per body, its [`Edge`] in `edges` (`usize::MAX` for a body no link touches).
    edge_of: Vec<usize>,
    edges: Vec<Edge>,
    /// Per body, its depth in its tree (the ground's children 1, a free root 0).
    depth: Vec<usize>,
    /// Bodies in the order of the forest, parents before children.
    order: Vec<usize>,
    /// Number of free coordinates.
    n_free: usize,
    tree_rows: usize,
    loops: Vec<Reduced>,
    /// Loop rows peeled as independent (indices into `loops`).
    peeled: usize,
    /// The blocks of the other loop rows (indices into `loops`), with their ranks.
    blocks: Vec<(Vec<usize>, usize)>,
}

impl<'a> Rank<'a> {
    /// The analysis of `links` on bodies with the origins of their coordinates at
    /// `positions`.
    ///
    /// # Errors
    /// [`SolveError::Interrupted`] when the caller asks to stop ([`crate::with_checker`]).
    pub(crate) fn of(links: &'a [Link], positions: &'a [Vector2<f64>]) -> Result<Self, SolveError> {
        let bodies = positions.len();
        let mut first = Vec::with_capacity(links.len());
        let mut rows = 0;
        for link in links {
            first.push(rows);
            rows += link.len;
        }
        let mut parts = Parts {
            sets: Sets::new(bodies),
            grounded: vec![false; bodies],
        };
        let mut tree = vec![false; links.len()];
        for (l, link) in links.iter().enumerate() {
            poll()?;
            tree[l] = parts.joins(link)
                && link.full_rank_on(0)
                && (link.b.is_none() || link.full_rank_on(1));
            parts.connect(link);
        }
        let mut rank = Self {
            links,
            positions,
            first,
            rows,
            edge_of: vec![usize::MAX; bodies],
            edges: Vec::new(),
            depth: vec![0; bodies],
            order: Vec::new(),
            n_free: 0,
            tree_rows: 0,
            loops: Vec::new(),
            peeled: 0,
            blocks: Vec::new(),
        };
        rank.grow_forest(&tree)?;
        rank.reduce_loops(&tree)?;
        rank.split_blocks()?;
        Ok(rank)
    }

    /// The forest of the tree links: from the ground first, then from each body not
    /// reached yet as a free root; each body's [`Edge`] and depth. The tree links at each
    /// body are `adjacent[start[body]..start[body + 1]]`.
    fn grow_forest(&mut self, tree: &[bool]) -> Result<(), SolveError> {
        let bodies = self.edge_of.len();
        let mut start = vec![0; bodies + 1];
        for (l, link) in self.links.iter().enumerate().filter(|&(l, _)| tree[l]) {
            self.tree_rows += link.len;
            match link.b {
                Some(b) => {
                    start[link.a + 1] += 1;
                    start[b + 1] += 1;
                }
                None => self.attach(link.a, Some((l, 0)), None),
            }
        }
        for body in 0..bodies {
            start[body + 1] += start[body];
        }
        let mut adjacent = vec![0; start[bodies]];
        let mut fill = start.clone();
        for (l, link) in self.links.iter().enumerate().filter(|&(l, _)| tree[l]) {
            let Some(b) = link.b else { continue };
            for body in [link.a, b] {
                adjacent[fill[body]] = l;
                fill[body] += 1;
            }
        }
        let adjacent = |body: usize| &adjacent[start[body]..start[body + 1]];
        let mut next = 0;
        self.spread(&mut next, &adjacent)?;
        for link in self.links {
            for root in [link.a].into_iter().chain(link.b) {
                if self.edge_of[root] == usize::MAX {
                    self.attach(root, None, None);
                    self.spread(&mut next, &adjacent)?;
                }
            }
        }
        Ok(())
    }

    /// Attaches the children of the bodies in `order` from `next` on, breadth first, by the
    /// tree links `adjacent` to each.
    fn spread<'t>(
        &mut self,
        next: &mut usize,
        adjacent: &impl Fn(usize) -> &'t [usize],
    ) -> Result<(), SolveError> {
        while *next < self.order.len() {
            poll()?;
            let parent = self.order[*next];
            *next += 1;
            for &l in adjacent(parent) {
                let link = &self.links[l];
                let (child, side) = match link.b {
                    Some(b) if b != parent => (b, 1),
                    _ => (link.a, 0),
                };
                if self.edge_of[child] == usize::MAX {
                    self.attach(child, Some((l, side)), Some(parent));
                }
            }
        }
        Ok(())
    }

    /// Attaches `body` to the forest below `parent` by `link` (the link and the body's
    /// side of it), or as a root.
    fn attach(&mut self, body: usize, link: Option<(usize, usize)>, parent: Option<usize>) {
        let (mut pinv, mut m, mut basis, mut free) =
            (Matrix3::zeros(), Matrix3::zeros(), Matrix3::identity(), 3);
        if let Some((l, side)) = link {
            let link = &self.links[l];
            let j_c = link.block(side);
            let svd = j_c.svd(true, true);
            let r = link.len;
            let v_t = svd.v_t.expect("V requested");
            pinv = svd
                .pseudo_inverse(TOL * svd.singular_values[0])
                .expect("U and V requested");
            // Singular values largest first: the last 3 − r rows of Vᵀ span the kernel.
            basis = Matrix3::from_fn(|i, k| if k < 3 - r { v_t[(r + k, i)] } else { 0.0 });
            free = 3 - r;
            if let Some(p) = parent {
                let d = self.positions[body] - self.positions[p];
                let rigid = Matrix3::new(1.0, 0.0, -d.y, 0.0, 1.0, d.x, 0.0, 0.0, 1.0);
                m = (Matrix3::identity() - pinv * j_c) * rigid - pinv * link.block(1 - side);
            }
        }
        self.depth[body] = parent.map_or(usize::from(link.is_some()), |p| self.depth[p] + 1);
        self.edge_of[body] = self.edges.len();
        self.edges.push(Edge {
            link,
            parent,
            pinv,
            m,
            basis,
            free,
            first: self.n_free,
        });
        self.n_free += free;
        self.order.push(body);
    }
}

/// One end of a loop row on its way up a tree: the body, the row's coefficients carried to
/// it, and their sizes had nothing cancelled (the terms' magnitudes, carried by `|M|ᵀ`).
type End = (usize, Vector3<f64>, Vector3<f64>);

impl Rank<'_> {
    /// Every row of the loop links reduced to the free coordinates (step 3).
    fn reduce_loops(&mut self, tree: &[bool]) -> Result<(), SolveError> {
        for (l, link) in self.links.iter().enumerate() {
            if tree[l] {
                continue;
            }
            for at in 0..link.len {
                poll()?;
                let (entries, size) = self.reduce(link, at);
                self.loops.push(Reduced {
                    row: self.first[l] + at,
                    link: l,
                    at,
                    entries,
                    size,
                });
            }
        }
        Ok(())
    }

    /// `ṽ = v N` of row `at` of `link` with its size had nothing cancelled: each end's
    /// coefficients carried up its tree (`v ← v M`), giving `v F` on the way, to the ground
    /// or its root — or, between two bodies, until the ends meet at their lowest common
    /// ancestor, above which they move together.
    fn reduce(&self, link: &Link, at: usize) -> (Vec<(usize, f64)>, f64) {
        let end = |side: usize, body: usize| (body, link.on(at, side), link.size_on(at, side));
        let mut ends = [Some(end(0, link.a)), link.b.map(|b| end(1, b))];
        let between_two = link.b.is_some() && !link.grounded;
        let (mut entries, mut size2) = (Vec::new(), 0.0);
        loop {
            let side = match ends {
                [Some(x), Some(y)] if x.0 == y.0 => {
                    if between_two {
                        break;
                    }
                    ends = [Some((x.0, x.1 + y.1, x.2 + y.2)), None];
                    0
                }
                [Some(x), Some(y)] => usize::from(self.depth[y.0] > self.depth[x.0]),
                [Some(_), None] => 0,
                [None, Some(_)] => 1,
                [None, None] => break,
            };
            ends[side] = ends[side].and_then(|e| self.climb(e, &mut entries, &mut size2));
        }
        (entries, size2.sqrt())
    }

    /// One step up: the entries `v F` of the end's body, then the end at its parent
    /// (`v M`), none at the ground or a root.
    fn climb(
        &self,
        (body, v, size): End,
        entries: &mut Vec<(usize, f64)>,
        size2: &mut f64,
    ) -> Option<End> {
        let edge = &self.edges[self.edge_of[body]];
        let scale = size.norm();
        for k in 0..edge.free {
            let value = v.dot(&edge.basis.column(k));
            *size2 += scale * scale;
            if value.abs() > TOL * scale {
                entries.push((edge.first + k, value));
            }
        }
        Some((edge.parent?, edge.m.tr_mul(&v), edge.m.abs().tr_mul(&size)))
    }

    /// Step 4: peels the reduced rows alone on a coordinate, then splits the others into
    /// blocks that share none, and takes each block's rank.
    fn split_blocks(&mut self) -> Result<(), SolveError> {
        let (start, on) = self.rows_by_coordinate();
        let column = |c: usize| &on[start[c]..start[c + 1]];
        let mut count: Vec<usize> = (0..self.n_free).map(|c| column(c).len()).collect();
        let mut peeled = vec![false; self.loops.len()];
        let mut alone: Vec<usize> = (0..self.n_free).filter(|&c| count[c] == 1).collect();
        while let Some(c) = alone.pop() {
            let Some(&i) = column(c)
                .iter()
                .find(|&&i| !peeled[i])
                .filter(|_| count[c] == 1)
            else {
                continue;
            };
            peeled[i] = true;
            self.peeled += 1;
            for &(c, _) in &self.loops[i].entries {
                count[c] -= 1;
                if count[c] == 1 {
                    alone.push(c);
                }
            }
        }
        let mut sets = Sets::new(self.loops.len());
        for c in 0..self.n_free {
            let mut rest = column(c).iter().filter(|&&i| !peeled[i]);
            if let Some(&i) = rest.next() {
                rest.for_each(|&j| {
                    sets.union(i, j);
                });
            }
        }
        let mut block_of: HashMap<usize, usize> = HashMap::new();
        for i in (0..self.loops.len()).filter(|&i| !peeled[i]) {
            let next = block_of.len();
            let b = *block_of.entry(sets.find(i)).or_insert(next);
            if b == self.blocks.len() {
                self.blocks.push((Vec::new(), 0));
            }
            self.blocks[b].0.push(i);
        }
        for b in 0..self.blocks.len() {
            poll()?;
            let (dense, _, size) = self.dense(&self.blocks[b].0);
            self.blocks[b].1 = rank_of(dense.singular_values().as_slice(), size);
        }
        Ok(())
    }

    /// The loop rows on each free coordinate, compressed: those on `c` are
    /// `on[start[c]..start[c + 1]]`.
    fn rows_by_coordinate(&self) -> (Vec<usize>, Vec<usize>) {
        let mut start = vec![0; self.n_free + 1];
        for r in &self.loops {
            for &(c, _) in &r.entries {
                start[c + 1] += 1;
            }
        }
        for c in 0..self.n_free {
            start[c + 1] += start[c];
        }
        let mut on = vec![0; start[self.n_free]];
        let mut fill = start.clone();
        for (i, r) in self.loops.iter().enumerate() {
            for &(c, _) in &r.entries {
                on[fill[c]] = i;
                fill[c] += 1;
            }
        }
        (start, on)
    }

    /// The reduced rows `block` as a dense matrix on the free coordinates they act on
    /// (`columns`, padded with zero columns to at least as many as rows), and their
    /// largest size.
    fn dense(&self, block: &[usize]) -> (DMatrix<f64>, Vec<usize>, f64) {
        let mut local: HashMap<usize, usize> = HashMap::new();
        let mut columns = Vec::new();
        for &i in block {
            for &(c, _) in &self.loops[i].entries {
                local.entry(c).or_insert_with(|| {
                    columns.push(c);
                    columns.len() - 1
                });
            }
        }
        let mut dense = DMatrix::zeros(block.len(), columns.len().max(block.len()));
        for (r, &i) in block.iter().enumerate() {
            for &(c, value) in &self.loops[i].entries {
                dense[(r, local[&c])] += value;
            }
        }
        let size = block
            .iter()
            .map(|&i| self.loops[i].size)
            .fold(0.0, f64::max);
        (dense, columns, size)
    }

    /// The rank of the Jacobian.
    pub(crate) fn rank(&self) -> usize {
        self.tree_rows + self.peeled + self.blocks.iter().map(|b| b.1).sum::<usize>()
    }

    /// The number of rows.
    pub(crate) fn rows(&self) -> usize {
        self.rows
    }

    /// The rows that depend on earlier ones, in order: modified Gram–Schmidt on each
    /// block's reduced rows in order, a row dependent where its residual is at most
    /// [`TOL`] times its size.
    pub(crate) fn redundant(&self) -> Vec<usize> {
        let mut redundant = Vec::new();
        for (block, _) in &self.blocks {
            let (dense, ..) = self.dense(block);
            let mut basis: Vec<DVector<f64>> = Vec::new();
            for (r, &i) in block.iter().enumerate() {
                let mut v = dense.row(r).transpose();
                for b in &basis {
                    v -= b * b.dot(&v);
                }
                let norm = v.norm();
                if norm <= TOL * self.loops[i].size {
                    redundant.push(self.loops[i].row);
                } else {
                    basis.push(v / norm);
                }
            }
        }
        redundant.sort_unstable();
        redundant
    }

    /// The rows that enter the dependencies among the rows: those on which some left null
    /// vector `y` (`yᵀ J = 0`) is not zero. Each block's null vectors on its loop rows (its
    /// SVD's last left singular vectors) are completed on the tree rows below them
    /// ([`Rank::tree_part`]) and made orthonormal; a row enters where an entry passes
    /// [`NULL_ENTRY`].
    ///
    /// # Errors
    /// [`SolveError::Interrupted`] when the caller asks to stop.
    pub(crate) fn dependent(&self) -> Result<Vec<usize>, SolveError> {
        let mut dependent = Vec::new();
        for (block, rank) in self.blocks.iter().filter(|(b, rank)| *rank < b.len()) {
            poll()?;
            let u = self.dense(block).0.svd(true, false).u.expect("U requested");
            let nulls: Vec<HashMap<usize, f64>> = (*rank..block.len())
                .map(|k| {
                    let on_loops: Vec<(usize, f64)> = block
                        .iter()
                        .enumerate()
                        .map(|(r, &i)| (i, u[(r, k)]))
                        .collect();
                    self.tree_part(&on_loops)
                })
                .collect::<Result<_, _>>()?;
            let mut rows: Vec<usize> = nulls.iter().flat_map(|y| y.keys().copied()).collect();
            rows.sort_unstable();
            rows.dedup();
            let stacked = DMatrix::from_fn(rows.len(), nulls.len(), |r, k| {
                nulls[k].get(&rows[r]).copied().unwrap_or(0.0)
            });
            let q = stacked.qr().q();
            dependent.extend(
                rows.iter()
                    .enumerate()
                    .filter_map(|(r, &row)| (q.row(r).amax() > NULL_ENTRY).then_some(row)),
            );
        }
        dependent.sort_unstable();
        dependent.dedup();
        Ok(dependent)
    }

    /// The left null vector `y` of the Jacobian with entries `on_loops` (loop row, value)
    /// on the loop rows, by row: its tree rows solve `y_treeᵀ J_tree = −y_loopᵀ L`, body by
    /// body from the deepest up — on a body `c`, `J_cᵀ y_e` cancels what the rows below and
    /// the loop rows put on it, `y_e = −(J_c⁺)ᵀ s_c`, and `J_pᵀ y_e` goes to the parent.
    fn tree_part(&self, on_loops: &[(usize, f64)]) -> Result<HashMap<usize, f64>, SolveError> {
        let mut y: HashMap<usize, f64> = HashMap::new();
        let mut sums = Sums::default();
        for &(i, value) in on_loops {
            let r = &self.loops[i];
            let link = &self.links[r.link];
            y.insert(r.row, value);
            sums.add(link.a, self.depth[link.a], link.on(r.at, 0) * value);
            if let Some(b) = link.b {
                sums.add(b, self.depth[b], link.on(r.at, 1) * value);
            }
        }
        while let Some((body, sum)) = sums.deepest() {
            poll()?;
            let edge = &self.edges[self.edge_of[body]];
            let Some((l, side)) = edge.link else { continue };
            let y_e = -edge.pinv.tr_mul(&sum);
            let link = &self.links[l];
            for k in 0..link.len {
                y.insert(self.first[l] + k, y_e[k]);
            }
            if let Some(parent) = edge.parent {
                let s = link.block(1 - side).tr_mul(&y_e);
                sums.add(parent, self.depth[parent], s);
            }
        }
        Ok(y)
    }

    /// The body velocities `u` (three per body, zero where no link acts) that satisfy the
    /// rows with right-hand sides `rhs` (one per row, zero on the tree rows): `u = N ξ`, the
    /// free coordinates `ξ` the least-squares solution of the loop rows `L N ξ = rhs`.
    pub(crate) fn solve(&self, rhs: &[f64]) -> Vec<Vector3<f64>> {
        let mut xi = vec![0.0; self.n_free];
        if !self.loops.is_empty() {
            let all: Vec<usize> = (0..self.loops.len()).collect();
            let (dense, columns, _) = self.dense(&all);
            let b = DVector::from_iterator(all.len(), self.loops.iter().map(|r| rhs[r.row]));
            let svd = dense.svd(true, true);
            let tol = TOL * svd.singular_values.max();
            let x = svd.solve(&b, tol).expect("U and V requested");
            for (k, &c) in columns.iter().enumerate() {
                xi[c] = x[k];
            }
        }
        self.motion(&xi)
    }

    /// The body velocities `u = N ξ` of the free coordinates `ξ`, down the forest.
    fn motion(&self, xi: &[f64]) -> Vec<Vector3<f64>> {
        let mut u = vec![Vector3::zeros(); self.edge_of.len()];
        for &body in &self.order {
            let edge = &self.edges[self.edge_of[body]];
            let free = &xi[edge.first..edge.first + edge.free];
            let mut v = edge.basis.columns(0, edge.free) * DVector::from_column_slice(free);
            if let Some(p) = edge.parent {
                v += edge.m * u[p];
            }
            u[body] = v;
        }
        u
    }

    /// `max |J u − rhs|` over the rows.
    pub(crate) fn residual(&self, u: &[Vector3<f64>], rhs: &[f64]) -> f64 {
        let mut worst: f64 = 0.0;
        for (link, &first) in self.links.iter().zip(&self.first) {
            for k in 0..link.len {
                let on_b = link.b.map_or(0.0, |b| link.on(k, 1).dot(&u[b]));
                worst = worst.max((link.on(k, 0).dot(&u[link.a]) + on_b - rhs[first + k]).abs());
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift64*), uniform in `[0, 1)`.
    struct Random(u64);

    impl Random {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() * n as f64) as usize
        }

        fn point(&mut self) -> Vector2<f64> {
            Vector2::new(2.0 * self.next() - 1.0, 2.0 * self.next() - 1.0)
        }
    }

    /// A mechanism of rigid bodies on the plane: their centres.
    struct Bodies(Vec<Vector2<f64>>);

    impl Bodies {
        /// The terms of `mᵀ Δr` of the point `p` of `body` (`None`: the ground's).
        fn along(
            &self,
            body: Option<usize>,
            p: Vector2<f64>,
            m: Vector2<f64>,
            sign: f64,
        ) -> Vec<(Option<usize>, f64)> {
            match body {
                None => vec![(None, 0.0)],
                Some(c) => {
                    let arm = p - self.0[c];
                    let turn = m.x * -arm.y + m.y * arm.x;
                    vec![
                        (Some(3 * c), sign * m.x),
                        (Some(3 * c + 1), sign * m.y),
                        (Some(3 * c + 2), sign * turn),
                    ]
                }
            }
        }

        /// `mᵀ (Δr_a − Δr_b)` at the point `p` of `a` and `b`.
        fn separation(
            &self,
            a: Option<usize>,
            b: Option<usize>,
            p: Vector2<f64>,
            m: Vector2<f64>,
        ) -> Vec<(Option<usize>, f64)> {
            let mut row = self.along(a, p, m, 1.0);
            row.extend(self.along(b, p, m, -1.0));
            row
        }

        /// `φ_b − φ_a`.
        fn angle(a: Option<usize>, b: usize) -> Vec<(Option<usize>, f64)> {
            vec![(a.map(|a| 3 * a + 2), -1.0), (Some(3 * b + 2), 1.0)]
        }
    }

    const X: Vector2<f64> = Vector2::new(1.0, 0.0);
    const Y: Vector2<f64> = Vector2::new(0.0, 1.0);

    /// A random link of the mechanism: a pin (perhaps driven), a hinge (perhaps driven), a
    /// weld, a slider on the ground or carried, a spring between points of two bodies, a
    /// hinge of a body with itself (zero rows), or a copy of an earlier link. (A spring
    /// between two points of one body is a zero row but for round-off, on which ordered
    /// Gram–Schmidt relative to the row's own size would judge.)
    fn random_link(bodies: &Bodies, earlier: &[Link], random: &mut Random) -> Link {
        let n = bodies.0.len();
        let (a, b) = (random.below(n), random.below(n));
        let b = if a == b { (b + 1) % n } else { b };
        let p = random.point();
        let driven = random.next() < 0.3;
        let axis = random.point().normalize();
        let rows = match random.below(8) {
            0 => {
                let mut rows = vec![
                    bodies.separation(Some(a), None, p, X),
                    bodies.separation(Some(a), None, p, Y),
                ];
                if driven {
                    rows.push(Bodies::angle(None, a));
                }
                rows
            }
            1 => {
                let mut rows = vec![
                    bodies.separation(Some(a), Some(b), p, X),
                    bodies.separation(Some(a), Some(b), p, Y),
                ];
                if driven {
                    rows.push(Bodies::angle(Some(a), b));
                }
                rows
            }
            2 => vec![
                bodies.separation(Some(a), Some(b), p, X),
                bodies.separation(Some(a), Some(b), p, Y),
                Bodies::angle(Some(a), b),
            ],
            3 => vec![
                bodies.separation(None, Some(a), p, axis),
                Bodies::angle(None, a),
            ],
            4 => vec![
                bodies.separation(Some(a), Some(b), p, axis),
                Bodies::angle(Some(a), b),
            ],
            5 if a != b => {
                let q = random.point();
                vec![[
                    bodies.along(Some(a), p, (q - p).normalize(), -1.0),
                    bodies.along(Some(b), q, (q - p).normalize(), 1.0),
                ]
                .concat()]
            }
            5 | 6 => vec![
                bodies.separation(Some(a), Some(a), p, X),
                bodies.separation(Some(a), Some(a), p, Y),
            ],
            _ => {
                return earlier
                    .get(random.below(earlier.len().max(1)))
                    .cloned()
                    .unwrap_or_else(|| random_link(bodies, earlier, random))
            }
        };
        Link::new(rows)
    }

    /// The links as a dense Jacobian on `bodies` bodies.
    fn dense(links: &[Link], bodies: usize) -> DMatrix<f64> {
        let rows: Vec<(usize, [f64; 6], Option<usize>)> = links
            .iter()
            .flat_map(|l| l.rows[..l.len].iter().map(|r| (l.a, *r, l.b)))
            .collect();
        let mut j = DMatrix::zeros(rows.len(), 3 * bodies);
        for (i, (a, r, b)) in rows.iter().enumerate() {
            for k in 0..3 {
                j[(i, 3 * a + k)] += r[k];
                if let Some(b) = b {
                    j[(i, 3 * b + k)] += r[3 + k];
                }
            }
        }
        j
    }

    /// The rank by singular values relative to the largest.
    fn dense_rank(j: &DMatrix<f64>) -> usize {
        let s = j.singular_values();
        let tol = TOL * s.max().max(f64::MIN_POSITIVE);
        s.iter().filter(|&&v| v > tol).count()
    }

    /// The rows that depend on earlier ones by Gram–Schmidt on the dense rows.
    fn dense_redundant(j: &DMatrix<f64>) -> Vec<usize> {
        let mut basis: Vec<DVector<f64>> = Vec::new();
        let mut redundant = Vec::new();
        for i in 0..j.nrows() {
            let mut v = j.row(i).transpose();
            let norm0 = v.norm();
            for b in &basis {
                v -= b * b.dot(&v);
            }
            if v.norm() <= TOL * norm0 {
                redundant.push(i);
            } else {
                basis.push(v.normalize());
            }
        }
        redundant
    }

    /// The rows on which the left null space is not zero: eigenvectors of `J Jᵀ` for its
    /// smallest eigenvalues.
    fn dense_dependent(j: &DMatrix<f64>, redundant: usize) -> Vec<usize> {
        let eigen = (j * j.transpose()).symmetric_eigen();
        let mut order: Vec<usize> = (0..j.nrows()).collect();
        order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
        let mut rows: Vec<usize> = (0..j.nrows())
            .filter(|&i| {
                order[..redundant]
                    .iter()
                    .any(|&k| eigen.eigenvectors[(i, k)].abs() > NULL_ENTRY)
            })
            .collect();
        rows.dedup();
        rows
    }

    #[test]
    fn ranks_dependent_rows_and_null_spaces_match_a_dense_analysis() {
        let mut random = Random(0x9E37_79B9_7F4A_7C15);
        let (mut deficient, mut loops, mut peeled) = (0, 0, 0);
        for case in 0..3000 {
            let n = 1 + random.below(6);
            let bodies = Bodies((0..n).map(|_| random.point()).collect());
            let mut links = Vec::new();
            for _ in 0..1 + random.below(9) {
                let link = random_link(&bodies, &links, &mut random);
                links.push(link);
            }
            let j = dense(&links, n);
            let rank = Rank::of(&links, &bodies.0).unwrap();
            assert_eq!(rank.rank(), dense_rank(&j), "case {case}: rank");
            for c in 0..rank.n_free {
                let mut xi = vec![0.0; rank.n_free];
                xi[c] = 1.0;
                let u = rank.motion(&xi);
                let u = DVector::from_iterator(3 * n, u.iter().flat_map(|v| v.iter().copied()));
                let ju = &j * u;
                let mut tree_rows = vec![true; j.nrows()];
                for r in &rank.loops {
                    tree_rows[r.row] = false;
                    let reduced = r.entries.iter().find(|e| e.0 == c).map_or(0.0, |e| e.1);
                    assert!(
                        (ju[r.row] - reduced).abs() < 1e-9,
                        "case {case}: reduced row {} on {c}: {} vs {reduced}\n{links:?}",
                        r.row,
                        ju[r.row]
                    );
                }
                for (i, tree) in tree_rows.iter().enumerate() {
                    assert!(
                        !tree || ju[i].abs() < 1e-9,
                        "case {case}: tree row {i} on {c}: {}",
                        ju[i]
                    );
                }
            }
            assert_eq!(
                rank.redundant(),
                dense_redundant(&j),
                "case {case}: rows dependent on earlier ones\n{links:?}\n{j}\nloops {:?}",
                rank.loops
            );
            let redundant = j.nrows() - rank.rank();
            assert_eq!(
                rank.dependent().unwrap(),
                if redundant == 0 {
                    vec![]
                } else {
                    dense_dependent(&j, redundant)
                },
                "case {case}: rows in dependencies\n{links:?}\n{j}\nloops {:?}\nblocks {:?}",
                rank.loops,
                rank.blocks
            );
            deficient += usize::from(redundant > 0);
            loops += usize::from(!rank.loops.is_empty());
            peeled += usize::from(rank.peeled > 0);
        }
        assert!(
            deficient > 500 && loops > 1000 && peeled > 100,
            "{deficient} cases with dependent rows, {loops} with loops, {peeled} with peeled rows"
        );
    }

    /// A chain of `n` bodies along a random walk, hinged end to end (some driven), pinned
    /// at its start, with random extra links: closing pins, hinges and welds between any
    /// two bodies, sliders, springs; the links shuffled or not.
    fn chain(n: usize, random: &mut Random) -> (Bodies, Vec<Link>) {
        let mut ends = vec![random.point()];
        for k in 0..n {
            ends.push(ends[k] + random.point());
        }
        let bodies = Bodies(
            (0..n)
                .map(|k| (ends[k] + ends[k + 1]) / 2.0 + 0.1 * random.point())
                .collect(),
        );
        let mut links = vec![Link::new([
            bodies.separation(Some(0), None, ends[0], X),
            bodies.separation(Some(0), None, ends[0], Y),
        ])];
        for (k, &end) in ends.iter().enumerate().take(n).skip(1) {
            let mut rows = vec![
                bodies.separation(Some(k - 1), Some(k), end, X),
                bodies.separation(Some(k - 1), Some(k), end, Y),
            ];
            if random.next() < 0.1 {
                rows.push(Bodies::angle(Some(k - 1), k));
            }
            links.push(Link::new(rows));
        }
        for _ in 0..random.below(6) {
            let link = random_link(&bodies, &links, random);
            links.push(link);
        }
        if random.next() < 0.5 {
            for k in (1..links.len()).rev() {
                links.swap(k, random.below(k + 1));
            }
        }
        (bodies, links)
    }

    #[test]
    fn long_chains_with_loops_match_a_dense_analysis() {
        let mut random = Random(0x2545_F491_4F6C_DD1D);
        for case in 0..300 {
            let n = 10 + random.below(30);
            let (bodies, links) = chain(n, &mut random);
            let j = dense(&links, n);
            let rank = Rank::of(&links, &bodies.0).unwrap();
            assert_eq!(rank.rank(), dense_rank(&j), "case {case}: rank");
            assert_eq!(
                rank.redundant(),
                dense_redundant(&j),
                "case {case}: rows dependent on earlier ones"
            );
            let redundant = j.nrows() - rank.rank();
            let expected = if redundant == 0 {
                vec![]
            } else {
                dense_dependent(&j, redundant)
            };
            assert_eq!(
                rank.dependent().unwrap(),
                expected,
                "case {case}: rows in dependencies"
            );
        }
    }

    #[test]
    fn the_velocities_of_given_rates_solve_the_rows() {
        let mut random = Random(0xD1B5_4A32_D192_ED03);
        let mut unique = 0;
        for case in 0..300 {
            let n = 2 + random.below(12);
            let (bodies, mut links) = chain(n, &mut random);
            let joints = links.len();
            let mut angles: Vec<usize> = (0..n).collect();
            for k in (1..n).rev() {
                angles.swap(k, random.below(k + 1));
            }
            let given = if random.next() < 0.6 {
                n
            } else {
                1 + random.below(n)
            };
            for &k in &angles[..given] {
                links.push(Link::new([Bodies::angle(k.checked_sub(1), k)]));
            }
            let rank = Rank::of(&links, &bodies.0).unwrap();
            let first_rate: usize = links[..joints].iter().map(|l| l.len).sum();
            let rhs: Vec<f64> = (0..rank.rows())
                .map(|i| {
                    if i < first_rate {
                        0.0
                    } else {
                        random.next() - 0.5
                    }
                })
                .collect();
            let u = rank.solve(&rhs);
            let j = dense(&links, n);
            let b = DVector::from_column_slice(&rhs);
            let svd = j.clone().svd(true, true);
            let dense_u = svd.solve(&b, TOL * svd.singular_values.max()).unwrap();
            let u = DVector::from_iterator(3 * n, u.iter().flat_map(|v| v.iter().copied()));
            if (&j * &dense_u - &b).amax() < 1e-9 {
                assert!(
                    rank.residual(&rank.solve(&rhs), &rhs) < 1e-9,
                    "case {case}: the rows hold"
                );
                if rank.rank() == 3 * n {
                    assert!(
                        (&u - &dense_u).amax() < 1e-9,
                        "case {case}: the one solution"
                    );
                    unique += 1;
                }
            }
        }
        assert!(unique > 20, "{unique} cases with one solution");
    }

    /// Three hinges between bodies 0 and 1 at three points (the second welds them, the
    /// third repeats two rows), given as (1, 0) once to check that the order of the bodies
    /// does not matter; a pin of body 0 to the ground, then a second pin of it at another
    /// point (one row repeats); and a driven angle row that would repeat is kept.
    #[test]
    fn repeated_rows_are_those_a_pair_of_bodies_already_has() {
        let bodies = Bodies(vec![Vector2::new(0.0, 0.0), Vector2::new(1.0, 0.5)]);
        let hinge = |a, b, p: Vector2<f64>| {
            Link::new([
                bodies.separation(Some(a), Some(b), p, X),
                bodies.separation(Some(a), Some(b), p, Y),
            ])
        };
        let pin = |p: Vector2<f64>| {
            Link::new([
                bodies.separation(Some(0), None, p, X),
                bodies.separation(Some(0), None, p, Y),
            ])
        };
        let links = vec![
            hinge(0, 1, Vector2::new(0.2, 0.1)),
            hinge(1, 0, Vector2::new(0.7, 0.4)),
            hinge(0, 1, Vector2::new(0.3, 0.9)),
            pin(Vector2::new(-0.5, 0.0)),
            pin(Vector2::new(0.5, 0.3)),
            Link::new([Bodies::angle(Some(0), 1)]),
        ];
        let repeated = repeated_rows(&links, |row| row != 10);
        let expected = [
            false, false, false, true, true, true, false, false, false, true, false,
        ];
        assert_eq!(repeated, expected);
        // Without the rows that repeat, the rank is the same and only the driven row is
        // redundant (the hinges weld the bodies, so their angle is fixed).
        let positions = &bodies.0;
        let all = Rank::of(&links, positions).unwrap();
        let kept: Vec<Link> = links
            .iter()
            .scan(0, |first, link| {
                let keep: Vec<bool> = (0..link.len()).map(|k| !repeated[*first + k]).collect();
                *first += link.len();
                Some(link.keeping(&keep))
            })
            .flatten()
            .collect();
        let rest = Rank::of(&kept, positions).unwrap();
        assert_eq!((all.rows(), all.rank()), (11, 6));
        assert_eq!((rest.rows(), rest.rank()), (7, 6));
        // Kept in order: the weld's rows 0, 1, 2, the pins' 6, 7, 8, the angle 10: the
        // angle depends on the weld's rows only (the two x rows give the relative turn).
        let dependent = rest.dependent().unwrap();
        assert!(dependent.contains(&6) && dependent.iter().all(|&r| r < 3 || r == 6));
    }
}
