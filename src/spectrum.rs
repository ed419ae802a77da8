//! The radius spectrum of a triangulation and the sweeps over it: tied radii,
//! fill radii, the exact optimum, the outlier optimum. All work on a threshold
//! `R = 1 / alpha` and a weight `w(t)` per triangle (its merged radius with
//! holes kept, its fill radius with holes filled): the shape at `R` is
//! `{t : w(t) <= R}` (solid: `alpha * r(t) <= 1`, `DESIGN.md`).

use rayon::prelude::*;

use crate::mesh::{counting_sort, Mesh, Union, NONE};

/// Circumradii that agree to this relative tolerance are one spectrum value:
/// cocircular points (grids, rounded coordinates) have equal radii in exact
/// arithmetic, which rounding splits by an ulp or two.
pub const TIE_RTOL: f64 = 1e-10;

/// Relative slack of the solid test `r <= 1 / alpha` for a given alpha:
/// `1 / (1 / r)` may differ from `r` by an ulp, and the optimal alpha fed
/// back must give the optimal shape.
pub const ALPHA_RTOL: f64 = 8.0 * f64::EPSILON;

/// Above this many triangles, sorts and per-triangle passes use every thread.
pub const PARALLEL_TRIANGLES: usize = 1 << 16;

/// A triangulation's radius spectrum: the distinct radii, ascending, and the
/// rank of each triangle's radius among them (integers that compare as the
/// radii do, so the sweeps sort by counting and queue by bucket).
///
/// Radii that agree to [`TIE_RTOL`] are one value, the largest: a run starts
/// at the smallest radius not yet taken and holds every radius up to `start *
/// (1 + TIE_RTOL)` (runs do not chain). Radii are positive (or infinite), so
/// their bit patterns sort as they do.
pub fn merge_ties(radius: &[f64]) -> (Vec<f64>, Vec<u32>) {
    let mut keyed: Vec<(u64, u32)> = radius.iter().map(|r| r.to_bits()).zip(0..).collect();
    if keyed.len() > PARALLEL_TRIANGLES {
        keyed.par_sort_unstable();
    } else {
        keyed.sort_unstable();
    }
    let value = |i: usize| f64::from_bits(keyed[i].0);
    let (mut values, mut rank) = (Vec::new(), vec![0; radius.len()]);
    let mut i = 0;
    while i < keyed.len() {
        let limit = value(i) * (1.0 + TIE_RTOL);
        let mut j = i;
        while j + 1 < keyed.len() && value(j + 1) <= limit {
            j += 1;
        }
        for &(_, t) in &keyed[i..=j] {
            rank[t as usize] = values.len() as u32;
        }
        values.push(value(j));
        i = j + 1;
    }
    (values, rank)
}

/// The fill rank of every triangle: the largest, over dual paths from the
/// triangle to the outside of the convex hull, of the smallest rank on the
/// path (the triangle's own included).
///
/// With holes filled, `t` is in the shape at rank `R` exactly when its fill
/// rank is `<= R`. A widest-path search from the outside on a bucket queue:
/// the keys taken out never increase, so a triangle's first key (the min of
/// the current key and its rank) is its fill rank; `O(m + k)`.
pub fn fill_rank(rank: &[u32], k: usize, nb: &[[u32; 3]]) -> Vec<u32> {
    let m = rank.len();
    let mut fill = vec![NONE; m];
    // Buckets as lists threaded through the triangles: head[key] -> next.
    let mut head = vec![NONE; k];
    let mut next = vec![NONE; m];
    let queue = |fill: &mut [u32], head: &mut [u32], next: &mut [u32], t: usize, key: u32| {
        fill[t] = key;
        next[t] = head[key as usize];
        head[key as usize] = t as u32;
    };
    for (t, n) in nb.iter().enumerate() {
        if n.contains(&NONE) {
            queue(&mut fill, &mut head, &mut next, t, rank[t]);
        }
    }
    for b in (0..k).rev() {
        while head[b] != NONE {
            let t = head[b] as usize;
            head[b] = next[t];
            for &s in &nb[t] {
                if s != NONE && fill[s as usize] == NONE {
                    let key = (b as u32).min(rank[s as usize]);
                    queue(&mut fill, &mut head, &mut next, s as usize, key);
                }
            }
        }
    }
    fill
}

/// Edge-connected pieces of the triangles `t` with `inside(t)`: a label
/// `0..P` per triangle inside (numbered by their first triangle), [`NONE`]
/// outside.
pub fn pieces(inside: impl Fn(usize) -> bool, nb: &[[u32; 3]]) -> (Vec<u32>, usize) {
    let m = nb.len();
    let mut union = Union::new(m);
    for t in (0..m).filter(|&t| inside(t)) {
        for &s in &nb[t] {
            if s != NONE && inside(s as usize) {
                union.union(t as u32, s);
            }
        }
    }
    let mut label = vec![NONE; m];
    let mut of_root = vec![NONE; m];
    let mut count = 0;
    for t in (0..m).filter(|&t| inside(t)) {
        let r = union.find(t as u32) as usize;
        if of_root[r] == NONE {
            of_root[r] = count;
            count += 1;
        }
        label[t] = of_root[r];
    }
    (label, count as usize)
}

/// The validity curve: every distinct weight (a rank), ascending, and whether
/// the shape at that threshold is valid.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curve {
    /// Distinct weights, ascending.
    pub ranks: Vec<u32>,
    /// Validity at each (between two, that of the lower one).
    pub valid: Vec<bool>,
}

/// The shape as triangles are added: its pieces (union-find over triangles)
/// and the points it covers.
struct Growing<'a> {
    mesh: &'a Mesh,
    union: Union,
    added: Vec<bool>,
    covered: Vec<bool>,
    n_covered: usize,
    n_pieces: usize,
}

impl Growing<'_> {
    fn add(&mut self, t: usize) {
        self.added[t] = true;
        self.n_pieces += 1;
        for &v in &self.mesh.tri[t] {
            if !self.covered[v as usize] {
                self.covered[v as usize] = true;
                self.n_covered += 1;
            }
        }
        for &s in &self.mesh.nb[t] {
            if s != NONE && self.added[s as usize] && self.union.union(t as u32, s) {
                self.n_pieces -= 1;
            }
        }
    }
}

/// One union-find sweep over the triangles in increasing weight `w` (ranks
/// below `k`): the first valid threshold (the optimum; `None` if none is,
/// never on a Delaunay triangulation) and, if asked, the whole curve.
///
/// Without the curve, the sweep starts at the coverage bound, adding the
/// triangles up to it in index order (neighbours close in memory).
pub fn sweep(
    w: &[u32],
    k: usize,
    mesh: &Mesh,
    components: usize,
    want_curve: bool,
) -> (Option<u32>, Curve) {
    let mut shape = Growing {
        mesh,
        union: Union::new(w.len()),
        added: vec![false; w.len()],
        covered: vec![false; mesh.rep.len()],
        n_covered: 0,
        n_pieces: 0,
    };
    // The distinct points are all triangle vertices.
    let valid =
        |shape: &Growing| shape.n_covered == mesh.n_distinct && shape.n_pieces <= components;
    let mut from = 0;
    if !want_curve && !w.is_empty() {
        // The largest, over the points, of the smallest weight of a triangle
        // at the point: no lower threshold covers every point.
        let mut lowest = vec![NONE; mesh.rep.len()];
        for (t, v) in mesh.tri.iter().enumerate() {
            for &p in v {
                lowest[p as usize] = lowest[p as usize].min(w[t]);
            }
        }
        let bound = lowest.into_iter().filter(|&x| x != NONE).max().unwrap_or(0);
        for t in (0..w.len()).filter(|&t| w[t] <= bound) {
            shape.add(t);
        }
        if valid(&shape) {
            return (Some(bound), Curve::default());
        }
        from = bound + 1;
    }
    // The triangles of rank `from` or more, in increasing rank.
    let above = w.iter().zip(0..).filter(|&(&r, _)| r >= from);
    let order = counting_sort(
        above.map(|(&r, t)| ((r - from) as usize, t)),
        k - from as usize,
    );
    let mut curve = Curve::default();
    let mut first = None;
    for run in order.chunk_by(|&a: &u32, &b| w[a as usize] == w[b as usize]) {
        run.iter().for_each(|&t| shape.add(t as usize));
        let (value, valid) = (w[run[0] as usize], valid(&shape));
        if valid && first.is_none() {
            first = Some(value);
            if !want_curve {
                break;
            }
        }
        if want_curve {
            curve.ranks.push(value);
            curve.valid.push(valid);
        }
    }
    (first, curve)
}

/// The pieces chosen at one threshold with outliers allowed.
#[derive(Clone, Debug, Default)]
pub struct Cover {
    /// Rows covered by the chosen pieces.
    pub rows: u64,
    /// Piece label of every triangle ([`NONE`] outside the shape).
    pub label: Vec<u32>,
    /// The chosen pieces' labels.
    pub chosen: Vec<u32>,
    /// The search for the best union stopped at its node budget.
    pub capped: bool,
}

/// Branch-and-bound nodes the best union of several pieces may visit (the
/// default of [`crate::group::Options::max_union_nodes`]).
pub const MAX_UNION_NODES: usize = 1_000_000;

struct BestUnion<'a> {
    /// Each piece's rows, label and points, in decreasing rows.
    sets: Vec<(u64, u32, Vec<u32>)>,
    weight: &'a [u64],
    count: Vec<u32>,
    best: (u64, Vec<u32>),
    choice: Vec<u32>,
    nodes_left: usize,
    capped: bool,
}

impl BestUnion<'_> {
    /// Add up to `left` more pieces, from the `from`-th on.
    fn search(&mut self, from: usize, left: usize, current: u64) {
        if current > self.best.0 {
            self.best = (current, self.choice.clone());
        }
        if left == 0 {
            return;
        }
        for k in from..self.sets.len() {
            // The most the rest can add: the next `left` weights.
            let bound: u64 = self.sets[k..].iter().take(left).map(|s| s.0).sum();
            if current + bound <= self.best.0 {
                return;
            }
            if self.nodes_left == 0 {
                self.capped = true;
                return;
            }
            self.nodes_left -= 1;
            let mut gained = 0;
            for &v in &self.sets[k].2 {
                if self.count[v as usize] == 0 {
                    gained += self.weight[v as usize];
                }
                self.count[v as usize] += 1;
            }
            self.choice.push(self.sets[k].1);
            self.search(k + 1, left - 1, current + gained);
            self.choice.pop();
            for &v in &self.sets[k].2 {
                self.count[v as usize] -= 1;
            }
        }
    }
}

/// The `components` pieces at threshold `r` that cover the most rows
/// (`weight[v]`: rows at point `v`). Pieces may share a vertex, so the union
/// is counted exactly, by branch and bound over the pieces in decreasing
/// weight, visiting at most `max_nodes` nodes.
pub fn best_cover(
    w: &[u32],
    r: u32,
    mesh: &Mesh,
    weight: &[u64],
    components: usize,
    max_nodes: usize,
) -> Cover {
    let (label, n) = pieces(|t| w[t] <= r, &mesh.nb);
    if components == 1 {
        return heaviest_piece(label, n, mesh, weight);
    }
    let mut points = vec![Vec::new(); n];
    for (&p, tri) in label.iter().zip(&mesh.tri).filter(|(&p, _)| p != NONE) {
        points[p as usize].extend_from_slice(tri);
    }
    let points = points.into_iter().zip(0..).map(|(mut s, p)| {
        s.sort_unstable();
        s.dedup();
        (s.iter().map(|&v| weight[v as usize]).sum(), p, s)
    });
    let mut sets: Vec<(u64, u32, Vec<u32>)> = points.collect();
    sets.sort_by_key(|s| std::cmp::Reverse(s.0));
    let mut search = BestUnion {
        sets,
        weight,
        count: vec![0; weight.len()],
        best: (0, Vec::new()),
        choice: Vec::new(),
        nodes_left: max_nodes,
        capped: false,
    };
    search.search(0, components, 0);
    Cover {
        rows: search.best.0,
        chosen: search.best.1,
        capped: search.capped,
        label,
    }
}

/// The smallest weight of a triangle at each point ([`NONE`] for a point
/// that is no vertex: a near-duplicate merged into another): at a lower
/// threshold the shape does not reach the point.
pub fn lowest(w: &[u32], mesh: &Mesh) -> Vec<u32> {
    let mut lowest = vec![NONE; mesh.rep.len()];
    for (t, v) in mesh.tri.iter().enumerate() {
        for &p in v {
            lowest[p as usize] = lowest[p as usize].min(w[t]);
        }
    }
    lowest
}

/// A lower bound of the outlier optimum with budget `k`: the smallest
/// threshold at which the points not yet reached weigh at most `k` (a shape
/// at a lower one leaves out more than `k`, whichever pieces it keeps).
pub fn lower_bound(lowest: &[u32], weight: &[u64], k: u64) -> u32 {
    let mut reached: Vec<(u32, u64)> = (lowest.iter().zip(weight))
        .filter(|&(&l, &x)| l != NONE && x > 0)
        .map(|(&l, &x)| (l, x))
        .collect();
    // Every point weighs at least 1: the k + 1 highest decide.
    let top = (k as usize).saturating_add(1);
    if reached.len() > top {
        reached.select_nth_unstable_by_key(top - 1, |&(l, _)| std::cmp::Reverse(l));
        reached.truncate(top);
    }
    reached.sort_unstable_by_key(|&(l, _)| std::cmp::Reverse(l));
    let mut left = 0;
    for (l, x) in reached {
        left += x;
        if left > k {
            return l;
        }
    }
    0
}

/// Outlier optima of one triangulation: the best cover at any threshold and
/// the smallest threshold at which it reaches a number of rows.
pub struct Outliers<'a> {
    w: &'a [u32],
    mesh: &'a Mesh,
    /// Rows (or 1 per location) at each point, 0 at a merged near-duplicate.
    pub weight: &'a [u64],
    components: usize,
    max_nodes: usize,
    /// The distinct weights, ascending.
    values: Vec<u32>,
}

impl<'a> Outliers<'a> {
    /// The searches over the weights `w` of `mesh`'s triangles.
    pub fn new(
        w: &'a [u32],
        mesh: &'a Mesh,
        weight: &'a [u64],
        components: usize,
        max_nodes: usize,
    ) -> Self {
        // The weights are ranks: the distinct ones by presence, in O(m).
        let mut present = vec![false; w.iter().max().map_or(0, |&x| x as usize + 1)];
        w.iter().for_each(|&x| present[x as usize] = true);
        let values: Vec<u32> = (0..present.len() as u32)
            .filter(|&x| present[x as usize])
            .collect();
        Outliers {
            w,
            mesh,
            weight,
            components,
            max_nodes,
            values,
        }
    }

    /// The best `components` pieces at threshold `r` ([`best_cover`]).
    pub fn cover(&self, r: u32) -> Cover {
        best_cover(
            self.w,
            r,
            self.mesh,
            self.weight,
            self.components,
            self.max_nodes,
        )
    }

    /// The smallest weight in `lo..=hi` at which the best pieces cover at
    /// least `need`, and those pieces; `hi` must be enough (the largest
    /// weight always is: one piece, every point). The best coverage only
    /// grows with the threshold (pieces grow and merge): a binary search.
    pub fn optimum(&self, need: u64, lo: u32, hi: u32) -> (u32, Cover) {
        let values = &self.values;
        let mut a = values.partition_point(|&v| v < lo);
        let mut b = values.partition_point(|&v| v < hi).min(values.len() - 1);
        while a < b {
            let mid = a + (b - a) / 2;
            if self.cover(values[mid]).rows >= need {
                b = mid;
            } else {
                a = mid + 1;
            }
        }
        (values[b], self.cover(values[b]))
    }

    /// The largest weight.
    pub fn top(&self) -> u32 {
        self.values.last().copied().unwrap_or(0)
    }
}

/// [`best_cover`] with one piece: the piece whose points weigh the most (the
/// first of equals), each point counted once (the triangles taken piece by
/// piece, a stamp per point), without the search over unions.
fn heaviest_piece(label: Vec<u32>, n: usize, mesh: &Mesh, weight: &[u64]) -> Cover {
    let inside = label.iter().zip(0..).filter(|&(&l, _)| l != NONE);
    let order = counting_sort(inside.map(|(&l, t)| (l as usize, t)), n);
    let mut stamp = vec![NONE; weight.len()];
    let mut total = vec![0u64; n];
    for &t in &order {
        let p = label[t as usize];
        for &v in &mesh.tri[t as usize] {
            if stamp[v as usize] != p {
                stamp[v as usize] = p;
                total[p as usize] += weight[v as usize];
            }
        }
    }
    let best = (0..n).max_by_key(|&p| (total[p], std::cmp::Reverse(p)));
    Cover {
        rows: best.map_or(0, |p| total[p]),
        chosen: best.map(|p| vec![p as u32]).unwrap_or_default(),
        capped: false,
        label,
    }
}

/// The outlier optimum: the smallest weight at which `components` pieces cover
/// at least `need` rows, and those pieces ([`Outliers::optimum`] over every
/// weight).
pub fn outlier_optimum(
    w: &[u32],
    mesh: &Mesh,
    weight: &[u64],
    components: usize,
    need: u64,
    max_nodes: usize,
) -> (u32, Cover) {
    let search = Outliers::new(w, mesh, weight, components, max_nodes);
    let lo = lower_bound(&lowest(w, mesh), weight, weight.iter().sum::<u64>() - need);
    search.optimum(need, lo, search.top())
}

/// The critical triangle of the threshold `r`: of the triangles whose own
/// radius is the spectrum value `r` (`rank`), the one with the largest
/// circumradius (the reported radius itself: ties within [`TIE_RTOL`] are
/// one value, the largest), preferring one that enters the shape at `r`
/// (`w == r`; with holes filled an enclosed one may enter earlier), then the
/// first in the mesh's order.
pub fn critical(r: u32, rank: &[u32], w: &[u32], radius: &[f64]) -> Option<usize> {
    let key = |t: usize| (radius[t], w[t] == r, std::cmp::Reverse(t));
    (0..rank.len()).filter(|&t| rank[t] == r).max_by(|&a, &b| {
        key(a)
            .partial_cmp(&key(b))
            .unwrap_or(std::cmp::Ordering::Equal)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ties_take_the_largest_of_their_run_and_do_not_chain() {
        let r = [2.0, 1.0, 1.0 + 1e-15, 1.0 + 0.6e-10, 1.0 + 1.2e-10];
        let (values, rank) = merge_ties(&r);
        assert_eq!(values, vec![1.0 + 0.6e-10, 1.0 + 1.2e-10, 2.0]);
        assert_eq!(rank, vec![2, 0, 0, 0, 1]);
    }

    #[test]
    fn a_chain_of_close_radii_is_cut_into_runs() {
        // 40 radii 0.6e-10 apart: runs of two (a run spans at most 1e-10).
        let r: Vec<f64> = (0..40).map(|k| 1.0 + k as f64 * 0.6e-10).collect();
        let (values, rank) = merge_ties(&r);
        assert_eq!(values.len(), 20);
        let merged = rank.iter().map(|&k| values[k as usize]);
        assert!(merged.zip(&r).all(|(a, b)| a / b - 1.0 <= TIE_RTOL));
    }

    #[test]
    fn fill_rank_of_an_enclosed_triangle_is_its_ring() {
        // Triangles 0 and 2 on the hull (radii 1, 3), 1 between them (5).
        let nb = [[1, NONE, NONE], [0, 2, 0], [1, NONE, NONE]];
        // Ranks 0 (radius 1), 2 (radius 5), 1 (radius 3).
        let f = fill_rank(&[0, 2, 1], 3, &nb);
        assert_eq!(f, vec![0, 1, 1]);
    }

    #[test]
    fn best_union_counts_shared_vertices_once() {
        // Pieces {0,1,2} and {2,3,4} share point 2 (10 rows): 12 rows each,
        // 14 together; {5,6,7} has 7 rows. Summing weights would pick the
        // first two (24); their union is 14, and 12 + 7 = 19 is the best.
        let mesh = Mesh {
            rep: (0..8).collect(),
            n_distinct: 8,
            tri: vec![[0, 1, 2], [2, 3, 4], [5, 6, 7]],
            nb: vec![[NONE; 3]; 3],
        };
        let weight = [1, 1, 10, 1, 1, 1, 1, 5];
        let c = best_cover(&[0, 0, 0], 0, &mesh, &weight, 2, MAX_UNION_NODES);
        assert_eq!(c.rows, 19);
        assert!(c.chosen.contains(&2));
        let c = best_cover(&[0, 0, 0], 0, &mesh, &weight, 1, MAX_UNION_NODES);
        assert_eq!(c.rows, 12);
    }
}
