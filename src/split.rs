//! `overlap="split"` in one pass: the overlaps of neighbouring groups'
//! polygons given to the group of the nearest input point, every group's
//! split polygon traced from one constrained triangulation.
//!
//! The overlapping pairs are joined into components (groups linked by an
//! overlap). For each component, one constrained Delaunay triangulation
//! (spade) holds every ring of its polygons and, for each overlapping pair,
//! the Voronoi edges between a point of one group and a point of the other
//! (the lines where the nearest point changes group), clipped to the pair's
//! common box; constraints that cross are split at their crossing. Every
//! triangle then lies in one face of that arrangement: its centroid says
//! which polygons hold it and, where two or more do, which of their groups
//! has the nearest point (the pairs' Voronoi diagrams, by tournament). Each
//! group's polygon is the union of the triangles it owns, traced as rings.
//!
//! A triangle has one owner, so the split polygons are interior-disjoint by
//! construction, with the same vertices where they meet. A component this
//! cannot do plainly (a location holding points of both groups of a pair,
//! coordinates spade refuses, a ring that does not close) is returned as
//! failed and the caller splits it another way (GEOS overlays).

use std::cell::Cell;
use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Once;

use rayon::prelude::*;
use spade::handles::{FixedDirectedEdgeHandle, FixedFaceHandle, FixedVertexHandle, InnerTag};
use spade::{
    ConstrainedDelaunayTriangulation, DelaunayTriangulation, HasPosition, Point2, Triangulation,
};

use crate::frame::Xy;
use crate::mesh::Union;

/// Polygons in geoarrow's MultiPolygon layout (shapely's `to_ragged_array`):
/// geometry `g` is polygons `geometry_offsets[g]..geometry_offsets[g + 1]`,
/// polygon `p` rings `polygon_offsets[p]..`, ring `r` coordinates
/// `ring_offsets[r]..` (closed: the last repeats the first).
pub struct Polygons<'a> {
    /// The coordinates of every ring.
    pub xy: &'a [Xy],
    /// Ring `r` is `xy[ring_offsets[r]..ring_offsets[r + 1]]`.
    pub ring_offsets: &'a [i64],
    /// Polygon `p` is rings `polygon_offsets[p]..polygon_offsets[p + 1]`.
    pub polygon_offsets: &'a [i64],
    /// Geometry `g` is polygons `geometry_offsets[g]..geometry_offsets[g + 1]`.
    pub geometry_offsets: &'a [i64],
}

/// What [`split`] returns: for each geometry its status and, if split, its
/// new polygon in the same layout.
#[derive(Debug, Default)]
pub struct Output {
    /// Per geometry: 0 untouched (in no pair), 1 split, 2 failed (its
    /// component could not be split here; the caller splits it).
    pub status: Vec<u8>,
    /// The new polygons' coordinates (empty geometries for status 0 and 2).
    pub xy: Vec<f64>,
    /// As [`Polygons::ring_offsets`].
    pub ring_offsets: Vec<i64>,
    /// As [`Polygons::polygon_offsets`].
    pub polygon_offsets: Vec<i64>,
    /// As [`Polygons::geometry_offsets`].
    pub geometry_offsets: Vec<i64>,
    /// Per failed component, the reason (for the caller's message).
    pub failures: Vec<String>,
}

/// A polygon: rings of closed coordinates, the first the shell.
type Polygon = Vec<Vec<Xy>>;

/// One pair's diagram and its Voronoi edges between the two groups.
type Built = (Pair, Vec<[Xy; 2]>);

/// One component's split: each group's new polygons, or why it failed.
type Component = Result<Vec<(usize, Vec<Polygon>)>, String>;

/// Split the overlaps of the `pairs` of geometries (index pairs, each pair's
/// polygons overlapping) by nearest point.
///
/// `points[point_offsets[g]..point_offsets[g + 1]]` are the points of
/// geometry `g` (those its polygon covers). Components are split on rayon's
/// threads; a panic or error in one fails that component only.
///
/// # Errors
/// Offsets out of range or pairs naming no geometry.
pub fn split(
    polygons: &Polygons,
    points: &[Xy],
    point_offsets: &[i64],
    pairs: &[[i64; 2]],
) -> Result<Output, String> {
    let n = polygons.geometry_offsets.len().saturating_sub(1);
    check_offsets(polygons, points, point_offsets, n)?;
    let mut union = Union::new(n);
    for &[a, b] in pairs {
        union.union(index(a, n)?, index(b, n)?);
    }
    let mut members: HashMap<u32, Vec<usize>> = HashMap::new();
    let mut in_pair = vec![false; n];
    for &[a, b] in pairs {
        in_pair[a as usize] = true;
        in_pair[b as usize] = true;
    }
    for g in (0..n).filter(|&g| in_pair[g]) {
        let root = union.find(g as u32);
        members.entry(root).or_default().push(g);
    }
    let mut of_component: HashMap<u32, Vec<[usize; 2]>> = HashMap::new();
    for &[a, b] in pairs {
        let root = union.find(a as u32);
        of_component
            .entry(root)
            .or_default()
            .push([a as usize, b as usize]);
    }
    let mut components: Vec<(Vec<usize>, Vec<[usize; 2]>)> = members
        .into_iter()
        .map(|(root, groups)| (groups, of_component.remove(&root).unwrap_or_default()))
        .collect();
    components.sort_by_key(|(groups, _)| groups[0]);
    let input = Input {
        polygons,
        points,
        point_offsets,
    };
    let results: Vec<Component> = components
        .par_iter()
        .map(|(groups, pairs)| {
            quietly(|| split_component(&input, groups, pairs))
                .unwrap_or_else(|_| Err("the triangulation failed".to_string()))
        })
        .collect();
    let mut out = Output {
        status: in_pair.iter().map(|&p| u8::from(p)).collect(),
        ..Output::default()
    };
    let mut shapes: Vec<Option<Vec<Polygon>>> = vec![None; n];
    for ((groups, _), result) in components.iter().zip(results) {
        match result {
            Ok(split) => {
                for (g, shape) in split {
                    shapes[g] = Some(shape);
                }
            }
            Err(why) => {
                for &g in groups {
                    out.status[g] = 2;
                }
                out.failures.push(why);
            }
        }
    }
    out.geometry_offsets.push(0);
    out.polygon_offsets.push(0);
    out.ring_offsets.push(0);
    for shape in shapes {
        for polygon in shape.unwrap_or_default() {
            for ring in polygon {
                out.xy.extend(ring.iter().flatten());
                out.ring_offsets.push((out.xy.len() / 2) as i64);
            }
            out.polygon_offsets.push(out.ring_offsets.len() as i64 - 1);
        }
        out.geometry_offsets
            .push(out.polygon_offsets.len() as i64 - 1);
    }
    Ok(out)
}

thread_local! {
    /// Calls of [`quietly`] running on this thread.
    static QUIET: Cell<u32> = const { Cell::new(0) };
}

/// Run `work`, a panic caught as its error without the panic message on
/// stderr (the component fails and is split another way: nothing to report).
/// The process's panic hook is wrapped once; panics elsewhere still print.
fn quietly<T>(work: impl FnOnce() -> T) -> std::thread::Result<T> {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(Cell::get) == 0 {
                default(info);
            }
        }));
    });
    QUIET.with(|q| q.set(q.get() + 1));
    let out = catch_unwind(AssertUnwindSafe(work));
    QUIET.with(|q| q.set(q.get() - 1));
    out
}

/// The arrays every component reads.
struct Input<'a> {
    polygons: &'a Polygons<'a>,
    points: &'a [Xy],
    point_offsets: &'a [i64],
}

impl Input<'_> {
    /// The rings of geometry `g`'s polygons.
    fn rings(&self, g: usize) -> Vec<&[Xy]> {
        let p = self.polygons;
        let (p0, p1) = (p.geometry_offsets[g], p.geometry_offsets[g + 1]);
        let (r0, r1) = (
            p.polygon_offsets[p0 as usize],
            p.polygon_offsets[p1 as usize],
        );
        (r0..r1)
            .map(|r| {
                &p.xy[p.ring_offsets[r as usize] as usize..p.ring_offsets[r as usize + 1] as usize]
            })
            .collect()
    }

    /// The points of geometry `g`.
    fn points(&self, g: usize) -> &[Xy] {
        &self.points[self.point_offsets[g] as usize..self.point_offsets[g + 1] as usize]
    }
}

fn check_offsets(
    p: &Polygons,
    points: &[Xy],
    point_offsets: &[i64],
    n: usize,
) -> Result<(), String> {
    let monotone = |o: &[i64], end: usize, name: &str| -> Result<(), String> {
        let ok = o.first() == Some(&0)
            && o.windows(2).all(|w| w[0] <= w[1])
            && o.last().is_some_and(|&l| l as usize == end);
        if ok {
            Ok(())
        } else {
            Err(format!("{name} must rise from 0 to {end}"))
        }
    };
    monotone(p.ring_offsets, p.xy.len(), "ring_offsets")?;
    monotone(
        p.polygon_offsets,
        p.ring_offsets.len() - 1,
        "polygon_offsets",
    )?;
    monotone(
        p.geometry_offsets,
        p.polygon_offsets.len() - 1,
        "geometry_offsets",
    )?;
    monotone(point_offsets, points.len(), "point_offsets")?;
    if point_offsets.len() != n + 1 {
        return Err(format!(
            "point_offsets must have {} entries, one more than the geometries",
            n + 1
        ));
    }
    Ok(())
}

fn index(i: i64, n: usize) -> Result<u32, String> {
    u32::try_from(i)
        .ok()
        .filter(|&i| (i as usize) < n)
        .ok_or_else(|| format!("pair names geometry {i}, of {n}"))
}

/// A point of a pair's Voronoi diagram: its position and group (0 or 1).
#[derive(Clone, Copy, Debug)]
struct Site {
    at: Point2<f64>,
    side: u8,
}

impl HasPosition for Site {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.at
    }
}

/// An axis-aligned box: `[x0, y0, x1, y1]`.
type Box2 = [f64; 4];

fn bounds(rings: &[&[Xy]]) -> Box2 {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in rings.iter().flat_map(|r| r.iter()) {
        b = [
            b[0].min(p[0]),
            b[1].min(p[1]),
            b[2].max(p[0]),
            b[3].max(p[1]),
        ];
    }
    b
}

/// A group's polygon, indexed for point-in-polygon tests: its edges by rows
/// of y.
struct Shape {
    bounds: Box2,
    edges: Vec<[Xy; 2]>,
    rows: Vec<Vec<u32>>,
}

impl Shape {
    fn new(rings: &[&[Xy]]) -> Self {
        let bounds = bounds(rings);
        let edges: Vec<[Xy; 2]> = rings
            .iter()
            .flat_map(|r| r.windows(2).map(|w| [w[0], w[1]]))
            .filter(|[a, b]| a != b)
            .collect();
        let n_rows = (edges.len() / 4).clamp(1, 4096);
        let mut rows = vec![Vec::new(); n_rows];
        let height = bounds[3] - bounds[1];
        for (k, [a, b]) in edges.iter().enumerate() {
            let (lo, hi) = (a[1].min(b[1]), a[1].max(b[1]));
            let (r0, r1) = (
                row(lo, bounds[1], height, n_rows),
                row(hi, bounds[1], height, n_rows),
            );
            for r in &mut rows[r0..=r1] {
                r.push(k as u32);
            }
        }
        Shape {
            bounds,
            edges,
            rows,
        }
    }

    /// Whether the closed box `cell` may meet the polygon: its centre is
    /// inside or an edge meets it (else the polygon is inside or outside it
    /// whole, and then its centre says which, unless the polygon is inside
    /// the cell: then a vertex, so an edge, is in it).
    fn may_meet(&self, cell: Box2) -> bool {
        let b = self.bounds;
        if cell[0] > b[2] || cell[2] < b[0] || cell[1] > b[3] || cell[3] < b[1] {
            return false;
        }
        if self.contains([(cell[0] + cell[2]) / 2.0, (cell[1] + cell[3]) / 2.0]) {
            return true;
        }
        let height = b[3] - b[1];
        let n = self.rows.len();
        let (r0, r1) = (
            row(cell[1].max(b[1]), b[1], height, n),
            row(cell[3].min(b[3]), b[1], height, n),
        );
        self.rows[r0..=r1].iter().flatten().any(|&k| {
            let [p, q] = self.edges[k as usize];
            clip(p, q, cell).is_some()
        })
    }

    /// Whether `p` lies on one of the edges (exactly, orientation 0), not
    /// at an end.
    fn on_edge(&self, p: Xy) -> bool {
        let b = self.bounds;
        if !(p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3]) {
            return false;
        }
        let r = row(p[1], b[1], b[3] - b[1], self.rows.len());
        self.rows[r].iter().any(|&k| {
            let [a, c] = self.edges[k as usize];
            let within = p[0] >= a[0].min(c[0])
                && p[0] <= a[0].max(c[0])
                && p[1] >= a[1].min(c[1])
                && p[1] <= a[1].max(c[1]);
            within
                && p != a
                && p != c
                && robust::orient2d(
                    robust::Coord { x: a[0], y: a[1] },
                    robust::Coord { x: c[0], y: c[1] },
                    robust::Coord { x: p[0], y: p[1] },
                ) == 0.0
        })
    }

    /// Whether `p` is inside (crossings of the ray towards +x; a point on
    /// the boundary may go either way: centroids of triangles are not).
    fn contains(&self, p: Xy) -> bool {
        let b = self.bounds;
        if !(p[0] >= b[0] && p[0] <= b[2] && p[1] >= b[1] && p[1] <= b[3]) {
            return false;
        }
        let r = row(p[1], b[1], b[3] - b[1], self.rows.len());
        let mut inside = false;
        for &k in &self.rows[r] {
            let [a, c] = self.edges[k as usize];
            if (a[1] > p[1]) != (c[1] > p[1]) {
                let side = robust::orient2d(
                    robust::Coord { x: a[0], y: a[1] },
                    robust::Coord { x: c[0], y: c[1] },
                    robust::Coord { x: p[0], y: p[1] },
                );
                // The ray crosses the edge iff p is left of an upward edge
                // or right of a downward one.
                if (side > 0.0) == (c[1] > a[1]) {
                    inside = !inside;
                }
            }
        }
        inside
    }
}

fn row(y: f64, y0: f64, height: f64, n: usize) -> usize {
    if height <= 0.0 {
        return 0;
    }
    (((y - y0) / height * n as f64) as usize).min(n - 1)
}

/// One pair's Voronoi diagram of its two groups' points.
struct Pair {
    groups: [usize; 2],
    sites: DelaunayTriangulation<Site>,
}

impl Pair {
    /// Which of the pair's groups has the point nearest `p`.
    fn nearest(&self, p: Xy) -> usize {
        let v = self.sites.nearest_neighbor(Point2::new(p[0], p[1]));
        self.groups[usize::from(v.map_or(0, |v| v.data().side))]
    }
}

/// The split polygons of one component's groups.
fn split_component(input: &Input, groups: &[usize], pairs: &[[usize; 2]]) -> Component {
    let rings: Vec<Vec<&[Xy]>> = groups.iter().map(|&g| input.rings(g)).collect();
    let shapes: Vec<Shape> = rings.iter().map(|r| Shape::new(r)).collect();
    let local: HashMap<usize, usize> = groups.iter().enumerate().map(|(i, &g)| (g, i)).collect();
    let commons: Vec<Box2> = pairs
        .iter()
        .map(|&[a, b]| {
            let (ba, bb) = (shapes[local[&a]].bounds, shapes[local[&b]].bounds);
            [
                ba[0].max(bb[0]),
                ba[1].max(bb[1]),
                ba[2].min(bb[2]),
                ba[3].min(bb[3]),
            ]
        })
        .collect();
    // Every vertex, loaded at once: the rings', the points on a ring in a
    // pair's common box (a constraint through one is split there exactly,
    // so it stays on the boundary), and the ends of the pairs' Voronoi edges.
    let mut vertices: Vec<Xy> = rings
        .iter()
        .flatten()
        .flat_map(|r| r.iter().map(|&p| unsigned(p)))
        .collect();
    for (&[a, b], c) in pairs.iter().zip(&commons) {
        let on = [&shapes[local[&a]], &shapes[local[&b]]];
        for &p in input.points(a).iter().chain(input.points(b)) {
            let inside = p[0] >= c[0] && p[0] <= c[2] && p[1] >= c[1] && p[1] <= c[3];
            if inside && on.iter().any(|s| s.on_edge(p)) {
                vertices.push(unsigned(p));
            }
        }
    }
    // The pairs' diagrams on rayon's threads (a component may hold most pairs).
    let built: Vec<Result<Built, String>> = pairs
        .par_iter()
        .zip(&commons)
        .map(|(&[a, b], &common)| {
            let (pa, pb) = (input.points(a), input.points(b));
            let shapes = [&shapes[local[&a]], &shapes[local[&b]]];
            let sites = match near_overlap(pa, pb, shapes, common) {
                Some(near) => {
                    let na: Vec<Xy> = pa.iter().filter(|p| near.keeps(p)).copied().collect();
                    let nb: Vec<Xy> = pb.iter().filter(|p| near.keeps(p)).copied().collect();
                    voronoi(&na, &nb)?
                }
                None => voronoi(pa, pb)?,
            };
            let cuts = voronoi_edges(&sites, widened(common), true);
            let pair = Pair {
                groups: [local[&a], local[&b]],
                sites,
            };
            Ok((pair, cuts.into_iter().map(|(seg, _)| seg).collect()))
        })
        .collect();
    let mut diagrams = Vec::with_capacity(pairs.len());
    let mut of_pair: HashMap<[usize; 2], usize> = HashMap::new();
    let mut cuts: Vec<[Xy; 2]> = Vec::new();
    for one in built {
        let (pair, segments) = one?;
        let [la, lb] = pair.groups;
        of_pair.insert([la.min(lb), la.max(lb)], diagrams.len());
        diagrams.push(pair);
        cuts.extend(segments);
    }
    vertices.extend(cuts.iter().flatten().map(|&p| unsigned(p)));
    vertices.sort_unstable_by(|p, q| p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1])));
    vertices.dedup();
    let handle = |p: &Xy| {
        let i = vertices
            .binary_search_by(|q| q[0].total_cmp(&p[0]).then(q[1].total_cmp(&p[1])))
            .expect("every vertex was loaded");
        FixedVertexHandle::from_index(i)
    };
    // (distinct vertices and no edges: bulk_load_cdt keeps their order)
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> =
        ConstrainedDelaunayTriangulation::bulk_load_cdt(
            vertices.iter().map(|p| Point2::new(p[0], p[1])).collect(),
            Vec::new(),
        )
        .map_err(|e| format!("a coordinate spade refuses ({e:?})"))?;
    if cdt.num_vertices() != vertices.len() {
        return Err("spade merged vertices".to_string());
    }
    let segments = rings
        .iter()
        .flatten()
        .flat_map(|r| r.windows(2).map(|w| [w[0], w[1]]))
        .chain(cuts.iter().copied());
    // Where constraints cross near one point, spade may route one through a
    // nearby vertex instead of the rounded crossing: a path that leaves its
    // segment by more than rounding fails the component.
    let all = bounds(&rings.iter().flatten().copied().collect::<Vec<_>>());
    let tolerance = 1e-9 * (all[2] - all[0]).max(all[3] - all[1]);
    for [p, q] in segments {
        let (u, v) = (handle(&unsigned(p)), handle(&unsigned(q)));
        if u == v {
            continue;
        }
        let path = cdt.add_constraint_and_split(u, v, |p| p);
        let (d, length) = ([q[0] - p[0], q[1] - p[1]], (q[0] - p[0]).hypot(q[1] - p[1]));
        for e in path {
            let at = cdt.directed_edge(e).to().position();
            let off = (d[0] * (at.y - p[1]) - d[1] * (at.x - p[0])).abs() / length;
            if off > tolerance {
                return Err("spade routed a constraint around a crossing".to_string());
            }
        }
    }
    let owner = owners(&cdt, &shapes, &diagrams, &of_pair)?;
    // The guarantee where polygons changed: in the boxes the pairs share
    // (elsewhere each polygon is its hull, vertex for vertex).
    let mut checked: Vec<(Xy, usize)> = Vec::new();
    for (&[a, b], &common) in pairs.iter().zip(&commons) {
        let frame = widened(common);
        for g in [a, b] {
            checked.extend(input.points(g).iter().filter_map(|&p| {
                let inside =
                    p[0] >= frame[0] && p[0] <= frame[2] && p[1] >= frame[1] && p[1] <= frame[3];
                inside.then_some((p, local[&g]))
            }));
        }
    }
    // In rows, alternately left and right: each located from the last.
    let height = (all[3] - all[1]).max(f64::MIN_POSITIVE);
    let key = |p: &Xy| {
        let r = ((p[1] - all[1]) / height * 64.0).floor() as i64;
        (r, if r % 2 == 0 { p[0] } else { -p[0] })
    };
    checked.sort_unstable_by(|x, y| {
        let (kx, ky) = (key(&x.0), key(&y.0));
        kx.0.cmp(&ky.0).then(kx.1.total_cmp(&ky.1))
    });
    checked.dedup();
    let mut hint = FixedVertexHandle::from_index(0);
    for (p, g) in checked {
        hint = check_point(&cdt, &owner, p, g, hint)?;
    }
    let traced = trace(&cdt, &owner, groups.len(), vertices.len())?;
    Ok(groups.iter().copied().zip(traced).collect())
}

/// `p` with -0.0 as 0.0 (one vertex for spade, one key for the lookup).
fn unsigned(p: Xy) -> Xy {
    [p[0] + 0.0, p[1] + 0.0]
}

/// Check that point `p` of local group `g` is covered by g's triangles (in
/// one or on the boundary of one) and strictly inside no other group's
/// (all the triangles around it another's), with spade's exact location
/// walked from vertex `hint`; returns a vertex next to it (the next hint).
fn check_point(
    cdt: &ConstrainedDelaunayTriangulation<Point2<f64>>,
    owner: &[Option<usize>],
    p: Xy,
    g: usize,
    hint: FixedVertexHandle,
) -> Result<FixedVertexHandle, String> {
    use spade::PositionInTriangulation::{OnEdge, OnFace, OnVertex};
    let mut around: Vec<Option<usize>> = Vec::new();
    let near = match cdt.locate_with_hint(Point2::new(p[0], p[1]), hint) {
        OnFace(f) => {
            around.push(owner[f.index()]);
            cdt.face(f).vertices()[0].fix()
        }
        OnEdge(e) => {
            let e = cdt.directed_edge(e);
            around.push(owner[e.face().fix().index()]);
            around.push(owner[e.rev().face().fix().index()]);
            e.from().fix()
        }
        OnVertex(v) => {
            around.extend(
                cdt.vertex(v)
                    .out_edges()
                    .map(|e| owner[e.face().fix().index()]),
            );
            v
        }
        _ => return Err("a point outside the triangulation".to_string()),
    };
    if !around.contains(&Some(g)) {
        return Err("a split polygon leaves one of its points out".to_string());
    }
    if let Some(&first) = around.first() {
        if first.is_some() && first != Some(g) && around.iter().all(|&o| o == first) {
            return Err("a point strictly inside another group's polygon".to_string());
        }
    }
    Ok(near)
}

/// The owner of every triangle (local group index, or none), one face of the
/// arrangement at a time: its triangles are those joined across edges that
/// are not constraints; they share their polygons and nearest group, which
/// the centroid of the largest of them decides (farthest from rounding).
fn owners(
    cdt: &ConstrainedDelaunayTriangulation<Point2<f64>>,
    shapes: &[Shape],
    diagrams: &[Pair],
    of_pair: &HashMap<[usize; 2], usize>,
) -> Result<Vec<Option<usize>>, String> {
    let mut owner: Vec<Option<usize>> = vec![None; cdt.num_all_faces()];
    let mut seen = vec![false; cdt.num_all_faces()];
    let mut face: Vec<FixedFaceHandle<InnerTag>> = Vec::new();
    let mut holders = Vec::new();
    for start in cdt.fixed_inner_faces() {
        if seen[start.index()] {
            continue;
        }
        seen[start.index()] = true;
        face.clear();
        face.push(start);
        let mut k = 0;
        while k < face.len() {
            for e in cdt.face(face[k]).adjacent_edges() {
                if e.is_constraint_edge() {
                    continue;
                }
                if let Some(other) = e.rev().face().as_inner() {
                    if !seen[other.fix().index()] {
                        seen[other.fix().index()] = true;
                        face.push(other.fix());
                    }
                }
            }
            k += 1;
        }
        let largest = face
            .iter()
            .map(|&f| (cdt.face(f).area(), f))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, f)| f)
            .expect("a face has a triangle");
        let [a, b, c] = cdt.face(largest).positions();
        let centre = [(a.x + b.x + c.x) / 3.0, (a.y + b.y + c.y) / 3.0];
        holders.clear();
        holders.extend((0..shapes.len()).filter(|&i| shapes[i].contains(centre)));
        let Some(&first) = holders.first() else {
            continue;
        };
        let mut best = first;
        for &other in &holders[1..] {
            let key = [best.min(other), best.max(other)];
            let pair = of_pair
                .get(&key)
                .ok_or("a triangle in two polygons that do not overlap")?;
            best = diagrams[*pair].nearest(centre);
        }
        for f in &face {
            owner[f.index()] = Some(best);
        }
    }
    Ok(owner)
}

/// Cells per side of the grid [`near_overlap`] lays over a pair's common box.
const GRID: usize = 16;

/// Where the points that can be nearest to a location of a pair's overlap
/// lie: within `reach` of a cell of the grid over the common box that may
/// meet both polygons (see [`near_overlap`]).
struct Near {
    frame: Box2,
    cell: [f64; 2],
    reach: f64,
    /// Cells within `reach` of a cell that counts (clamped to the grid).
    marked: Vec<bool>,
}

impl Near {
    /// Whether `p` may be the nearest point to a location of the overlap.
    fn keeps(&self, p: &Xy) -> bool {
        let (f, r) = (self.frame, self.reach);
        if !(p[0] >= f[0] - r && p[0] <= f[2] + r && p[1] >= f[1] - r && p[1] <= f[3] + r) {
            return false;
        }
        let clamp = |v: f64| (v.floor().max(0.0) as usize).min(GRID - 1);
        let (i, j) = (
            clamp((p[0] - f[0]) / self.cell[0]),
            clamp((p[1] - f[1]) / self.cell[1]),
        );
        self.marked[j * GRID + i]
    }
}

/// The points of either group that can be the nearest to a location of the
/// overlap of a pair's polygons, within their common `frame` (None: it could
/// not be bounded, take every point).
///
/// A grid over the frame; a cell counts if it may meet both polygons (its
/// centre inside, or an edge crossing it). From a location in a cell, the
/// nearest point is at most `d + h` away, `d` bounding the distance from the
/// cell's centre to its nearest point (a point found in the cell or the
/// rings of cells around it) and `h` half the cell's diagonal; so a point
/// farther than `d + 2h` from the centre is nearer to none of its locations.
/// With `reach` the largest such bound, a point is kept if it lies within
/// `reach` of the frame, in a cell (clamped to the grid) that many cells or
/// fewer from one that counts.
fn near_overlap(a: &[Xy], b: &[Xy], shapes: [&Shape; 2], frame: Box2) -> Option<Near> {
    let (w, h) = (
        (frame[2] - frame[0]) / GRID as f64,
        (frame[3] - frame[1]) / GRID as f64,
    );
    if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
        return None;
    }
    let cell_of = |p: &Xy| -> Option<(usize, usize)> {
        let (i, j) = (
            ((p[0] - frame[0]) / w).floor(),
            ((p[1] - frame[1]) / h).floor(),
        );
        (i >= 0.0 && j >= 0.0 && i < GRID as f64 && j < GRID as f64)
            .then_some((i as usize, j as usize))
    };
    // One point per cell (any: an upper bound of the nearest distance is enough).
    let mut one: Vec<Option<Xy>> = vec![None; GRID * GRID];
    for p in a.iter().chain(b) {
        if let Some((i, j)) = cell_of(p) {
            one[j * GRID + i].get_or_insert(*p);
        }
    }
    let half = 0.5 * w.hypot(h);
    let mut reach: f64 = 0.0;
    let mut counts = vec![false; GRID * GRID];
    for j in 0..GRID {
        for i in 0..GRID {
            let cell = [
                frame[0] + i as f64 * w,
                frame[1] + j as f64 * h,
                frame[0] + (i + 1) as f64 * w,
                frame[1] + (j + 1) as f64 * h,
            ];
            if !shapes.iter().all(|s| s.may_meet(cell)) {
                continue;
            }
            counts[j * GRID + i] = true;
            let centre = [(cell[0] + cell[2]) / 2.0, (cell[1] + cell[3]) / 2.0];
            let mut d = f64::INFINITY;
            for ring in 0..GRID {
                let (i0, i1) = (i.saturating_sub(ring), (i + ring).min(GRID - 1));
                let (j0, j1) = (j.saturating_sub(ring), (j + ring).min(GRID - 1));
                for jj in j0..=j1 {
                    for ii in i0..=i1 {
                        if let Some(p) = one[jj * GRID + ii] {
                            d = d.min((p[0] - centre[0]).hypot(p[1] - centre[1]));
                        }
                    }
                }
                if d.is_finite() {
                    break;
                }
            }
            if !d.is_finite() {
                return None;
            }
            reach = reach.max(d + 2.0 * half);
        }
    }
    // (rounding: a little more)
    let reach = reach * (1.0 + 1e-9) + 1e-9 * (frame[2] - frame[0]).max(frame[3] - frame[1]);
    // A point within `reach` of a counting cell's centre is at most this many
    // cells from it, in either direction (its own cell clamped to the grid).
    let k = ((reach / w.min(h)).ceil() as usize).min(GRID);
    let mut marked = vec![false; GRID * GRID];
    for j in 0..GRID {
        for i in 0..GRID {
            if counts[j * GRID + i] {
                for jj in j.saturating_sub(k)..=(j + k).min(GRID - 1) {
                    for ii in i.saturating_sub(k)..=(i + k).min(GRID - 1) {
                        marked[jj * GRID + ii] = true;
                    }
                }
            }
        }
    }
    Some(Near {
        frame,
        cell: [w, h],
        reach,
        marked,
    })
}

/// The Delaunay triangulation of two groups' points (side 0 and 1).
///
/// # Errors
/// A location holding points of both groups (its cell is halved by another
/// rule: the caller's), or a coordinate spade refuses.
fn voronoi(a: &[Xy], b: &[Xy]) -> Result<DelaunayTriangulation<Site>, String> {
    let mut all: Vec<(Xy, u8)> = a
        .iter()
        .map(|&p| (p, 0))
        .chain(b.iter().map(|&p| (p, 1)))
        .collect();
    all.sort_unstable_by(|x, y| x.0[0].total_cmp(&y.0[0]).then(x.0[1].total_cmp(&y.0[1])));
    let mut sites: Vec<Site> = Vec::with_capacity(all.len());
    for (p, side) in all {
        match sites.last() {
            Some(last) if last.at.x == p[0] && last.at.y == p[1] => {
                if last.side != side {
                    return Err("a location holds points of both groups".to_string());
                }
            }
            _ => sites.push(Site {
                at: Point2::new(p[0], p[1]),
                side,
            }),
        }
    }
    DelaunayTriangulation::bulk_load(sites)
        .map_err(|e| format!("a coordinate spade refuses ({e:?})"))
}

/// `frame` widened by 1e-9 of its size (so that a Voronoi edge along its
/// side is kept).
fn widened(frame: Box2) -> Box2 {
    let pad = 1e-9
        * (frame[2] - frame[0])
            .max(frame[3] - frame[1])
            .max(f64::MIN_POSITIVE);
    [
        frame[0] - pad,
        frame[1] - pad,
        frame[2] + pad,
        frame[3] + pad,
    ]
}

/// The Voronoi edges of `sites` (only those between a site of either group
/// if `between`), clipped to `frame`, each with one of its two sites.
fn voronoi_edges(
    sites: &DelaunayTriangulation<Site>,
    frame: Box2,
    between: bool,
) -> Vec<([Xy; 2], Xy)> {
    let centre = [(frame[0] + frame[2]) / 2.0, (frame[1] + frame[3]) / 2.0];
    let size = (frame[2] - frame[0]) + (frame[3] - frame[1]);
    // Long enough to cross the frame from a start however far away.
    let far = |from: Xy| 2.0 * (size + (from[0] - centre[0]).hypot(from[1] - centre[1]));
    let mut out = Vec::new();
    for edge in sites.undirected_edges() {
        let [u, v] = edge.vertices();
        if between && u.data().side == v.data().side {
            continue;
        }
        let e = edge.as_directed();
        let (p, q) = (e.from().position(), e.to().position());
        let (dx, dy) = (q.x - p.x, q.y - p.y);
        let norm = dx.hypot(dy);
        if norm == 0.0 || !norm.is_finite() {
            continue;
        }
        // The edge's perpendicular bisector, left of p->q positive.
        let left = [-dy / norm, dx / norm];
        let circumcentre = |f: Option<spade::handles::FaceHandle<InnerTag, Site, (), (), ()>>| {
            f.map(|f| {
                let c = f.circumcenter();
                [c.x, c.y]
            })
        };
        let (l, r) = (
            circumcentre(e.face().as_inner()),
            circumcentre(e.rev().face().as_inner()),
        );
        let ray = |from: Xy, sign: f64| {
            let k = sign * far(from);
            [from[0] + k * left[0], from[1] + k * left[1]]
        };
        let (s, t) = match (l, r) {
            (Some(l), Some(r)) => (l, r),
            (None, Some(r)) => (r, ray(r, 1.0)),
            (Some(l), None) => (l, ray(l, -1.0)),
            (None, None) => {
                let mid = [(p.x + q.x) / 2.0, (p.y + q.y) / 2.0];
                (ray(mid, -1.0), ray(mid, 1.0))
            }
        };
        if let Some(seg) = clip(s, t, frame) {
            out.push((seg, [p.x, p.y]));
        }
    }
    out
}

/// The part of segment `s`-`t` in `frame` (Liang-Barsky), if any. Ends
/// inside the frame are kept exactly.
fn clip(s: Xy, t: Xy, frame: Box2) -> Option<[Xy; 2]> {
    if !(s.iter().chain(t.iter()).all(|v| v.is_finite())) {
        return None;
    }
    let d = [t[0] - s[0], t[1] - s[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d[0], s[0] - frame[0]),
        (d[0], frame[2] - s[0]),
        (-d[1], s[1] - frame[1]),
        (d[1], frame[3] - s[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |k: f64| {
        if k == 0.0 {
            s
        } else if k == 1.0 {
            t
        } else {
            [s[0] + k * d[0], s[1] + k * d[1]]
        }
    };
    Some([at(t0), at(t1)])
}

/// The polygons of the triangles `owner` gives each of `n` local groups:
/// rings traced along the edges with the group's triangle on the left only,
/// split where a ring meets itself, holes given to the shell of their
/// connected triangles.
fn trace(
    cdt: &ConstrainedDelaunayTriangulation<Point2<f64>>,
    owner: &[Option<usize>],
    n: usize,
    loaded: usize,
) -> Result<Vec<Vec<Polygon>>, String> {
    let owner_of = |f: FixedFaceHandle<spade::handles::PossiblyOuterTag>| owner[f.index()];
    // Triangles of one group joined across the edges inside its region.
    let mut joined = Union::new(owner.len());
    let mut boundary: Vec<FixedDirectedEdgeHandle> = Vec::new();
    for e in cdt.directed_edges() {
        let (left, right) = (e.face().fix(), e.rev().face().fix());
        let Some(g) = owner_of(left) else { continue };
        if owner_of(right) == Some(g) {
            if left.index() < right.index() {
                joined.union(left.index() as u32, right.index() as u32);
            }
        } else {
            boundary.push(e.fix());
        }
    }
    const NONE: usize = usize::MAX;
    let limit = cdt.num_directed_edges();
    let mut next = vec![NONE; limit];
    for &e in &boundary {
        // Around e's head through its group's triangles to the next boundary edge.
        let g = owner_of(cdt.directed_edge(e).face().fix());
        let mut cand = cdt.directed_edge(e).next();
        let mut steps = 0;
        while owner_of(cand.rev().face().fix()) == g {
            cand = cand.rev().next();
            steps += 1;
            if steps > limit {
                return Err("a ring does not close".to_string());
            }
        }
        next[e.index()] = cand.fix().index();
    }
    // (fixed_directed_edges yields the handles in index order)
    let handles: Vec<FixedDirectedEdgeHandle> = cdt.fixed_directed_edges().collect();
    let from = |e: usize| cdt.directed_edge(handles[e]).from();
    // Rings, each split where it passes a vertex twice.
    let mut used = vec![false; limit];
    let mut at = vec![NONE; cdt.num_vertices()];
    let mut loops: Vec<Vec<usize>> = Vec::new();
    for &start in &boundary {
        let start = start.index();
        if used[start] {
            continue;
        }
        let mut path: Vec<usize> = Vec::new();
        let mut e = start;
        while !used[e] {
            used[e] = true;
            let v = from(e).fix().index();
            if at[v] != NONE {
                let closed: Vec<usize> = path.drain(at[v]..).collect();
                for &c in &closed {
                    at[from(c).fix().index()] = NONE;
                }
                loops.push(closed);
            }
            at[v] = path.len();
            path.push(e);
            e = next[e];
            if e == NONE {
                return Err("a ring does not close".to_string());
            }
        }
        for &c in &path {
            at[from(c).fix().index()] = NONE;
        }
        if e != start {
            return Err("a ring does not close".to_string());
        }
        if !path.is_empty() {
            loops.push(path);
        }
    }
    // Shells (counter-clockwise) and holes, by connected triangles.
    let mut shells: HashMap<u32, (usize, usize)> = HashMap::new();
    let mut out: Vec<Vec<Polygon>> = vec![Vec::new(); n];
    let mut holes: Vec<(u32, Vec<Xy>)> = Vec::new();
    for ring in loops {
        let face = cdt.directed_edge(handles[ring[0]]).face();
        let g = owner_of(face.fix()).ok_or("a ring of no group")?;
        let root = joined.find(face.fix().index() as u32);
        // A vertex made by splitting two constraints where they cross, where
        // the ring runs straight on (to 1e-9 of a radian: along the
        // constraint it split), is left out: the ring keeps the edge it had
        // (in longitude/latitude, a vertex on a long edge would move its
        // geodesic). The neighbour whose corner it is keeps it, within
        // rounding of the line.
        let all: Vec<(usize, Xy)> = ring
            .iter()
            .map(|&e| {
                let v = from(e);
                let p = v.position();
                (v.fix().index(), [p.x, p.y])
            })
            .collect();
        let k = all.len();
        let mut xy: Vec<Xy> = (0..k)
            .filter(|&i| {
                let (index, v) = all[i];
                let (a, b) = (all[(i + k - 1) % k].1, all[(i + 1) % k].1);
                index < loaded || !straight(a, v, b)
            })
            .map(|i| all[i].1)
            .collect();
        if xy.len() < 3 {
            return Err("a ring of fewer than 3 vertices".to_string());
        }
        xy.push(xy[0]);
        if signed_area(&xy) > 0.0 {
            if shells.insert(root, (g, out[g].len())).is_some() {
                return Err("two shells around connected triangles".to_string());
            }
            out[g].push(vec![xy]);
        } else {
            holes.push((root, xy));
        }
    }
    for (root, hole) in holes {
        let &(g, p) = shells.get(&root).ok_or("a hole without a shell")?;
        out[g][p].push(hole);
    }
    Ok(out)
}

/// Whether `v` lies on the way from `a` to `b`: the turn there within 1e-9
/// of a radian of none.
fn straight(a: Xy, v: Xy, b: Xy) -> bool {
    let (p, q) = ([a[0] - v[0], a[1] - v[1]], [b[0] - v[0], b[1] - v[1]]);
    let cross = (p[0] * q[1] - p[1] * q[0]).abs();
    let dot = p[0] * q[0] + p[1] * q[1];
    dot < 0.0 && cross <= 1e-9 * p[0].hypot(p[1]) * q[0].hypot(q[1])
}

/// Twice the signed area of a closed ring (counter-clockwise positive).
fn signed_area(ring: &[Xy]) -> f64 {
    let o = ring[0];
    ring.windows(2)
        .map(|w| (w[0][0] - o[0]) * (w[1][1] - o[1]) - (w[1][0] - o[0]) * (w[0][1] - o[1]))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The boxes as closed counter-clockwise rings, one polygon each.
    fn boxes(b: &[Box2]) -> (Vec<Xy>, Vec<i64>, Vec<i64>, Vec<i64>) {
        let mut xy = Vec::new();
        for &[x0, y0, x1, y1] in b {
            xy.extend([[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]]);
        }
        let n = b.len() as i64;
        (
            xy,
            (0..=n).map(|k| 5 * k).collect(),
            (0..=n).collect(),
            (0..=n).collect(),
        )
    }

    fn run(b: &[Box2], points: &[Vec<Xy>], pairs: &[[i64; 2]]) -> Output {
        let (xy, rings, polygons, geometries) = boxes(b);
        let polys = Polygons {
            xy: &xy,
            ring_offsets: &rings,
            polygon_offsets: &polygons,
            geometry_offsets: &geometries,
        };
        let mut offsets = vec![0i64];
        let mut all = Vec::new();
        for p in points {
            all.extend(p);
            offsets.push(all.len() as i64);
        }
        split(&polys, &all, &offsets, pairs).unwrap()
    }

    /// Each geometry's area (shoelace, holes negative by orientation).
    fn areas(o: &Output) -> Vec<f64> {
        let xy: Vec<Xy> = o.xy.chunks(2).map(|c| [c[0], c[1]]).collect();
        (0..o.geometry_offsets.len() - 1)
            .map(|g| {
                let (p0, p1) = (
                    o.geometry_offsets[g] as usize,
                    o.geometry_offsets[g + 1] as usize,
                );
                let (r0, r1) = (
                    o.polygon_offsets[p0] as usize,
                    o.polygon_offsets[p1] as usize,
                );
                (r0..r1)
                    .map(|r| {
                        let ring = &xy[o.ring_offsets[r] as usize..o.ring_offsets[r + 1] as usize];
                        signed_area(ring) / 2.0
                    })
                    .sum()
            })
            .collect()
    }

    fn corners([x0, y0, x1, y1]: Box2) -> Vec<Xy> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn two_squares_split_at_the_bisector_of_their_nearest_points() {
        // [0, 2]² and [1, 3] x [0, 2], their corners as points: in the
        // overlap the nearest corners are x = 2 (first) and x = 1 (second),
        // so the line x = 1.5 divides it; a third box far away is untouched.
        let b = [
            [0.0, 0.0, 2.0, 2.0],
            [1.0, 0.0, 3.0, 2.0],
            [9.0, 9.0, 10.0, 10.0],
        ];
        let points: Vec<Vec<Xy>> = b.iter().map(|&c| corners(c)).collect();
        let o = run(&b, &points, &[[0, 1]]);
        assert_eq!(o.status, vec![1, 1, 0]);
        let a = areas(&o);
        assert!(
            (a[0] - 3.0).abs() < 1e-12 && (a[1] - 3.0).abs() < 1e-12,
            "{a:?}"
        );
        assert_eq!(a[2], 0.0); // (untouched: the caller keeps its polygon)
        let xy: Vec<Xy> = o.xy.chunks(2).map(|c| [c[0], c[1]]).collect();
        assert!(
            xy.contains(&[1.5, 0.0]) && xy.contains(&[1.5, 2.0]),
            "{xy:?}"
        );
    }

    #[test]
    fn a_point_on_the_edge_stays_on_the_boundary() {
        // A point of the first group on the second box's edge x = 1.
        let b = [[0.0, 0.0, 2.0, 2.0], [1.0, 0.0, 3.0, 2.0]];
        let mut first = corners(b[0]);
        first.push([1.0, 1.0]);
        let o = run(&b, &[first, corners(b[1])], &[[0, 1]]);
        assert_eq!(o.status, vec![1, 1]);
        let a = areas(&o);
        assert!((a[0] + a[1] - 6.0).abs() < 1e-12, "{a:?}");
        assert!(a[0] > 3.0, "the point at x = 1 takes area: {a:?}");
    }

    #[test]
    fn a_location_of_both_groups_fails_its_component_only() {
        let b = [
            [0.0, 0.0, 2.0, 2.0],
            [1.0, 0.0, 3.0, 2.0],
            [10.0, 0.0, 12.0, 2.0],
            [11.0, 0.0, 13.0, 2.0],
        ];
        let mut points: Vec<Vec<Xy>> = b.iter().map(|&c| corners(c)).collect();
        points[0].push([1.5, 1.0]);
        points[1].push([1.5, 1.0]);
        let o = run(&b, &points, &[[0, 1], [2, 3]]);
        assert_eq!(o.status, vec![2, 2, 1, 1]);
        assert_eq!(o.failures, vec!["a location holds points of both groups"]);
    }

    #[test]
    fn three_boxes_over_one_spot_give_it_to_the_nearest() {
        // Three unit-ish boxes all covering the centre: each keeps what its
        // corners are nearest to; the areas add up to the union's.
        let b = [
            [0.0, 0.0, 2.0, 2.0],
            [1.0, 0.0, 3.0, 2.0],
            [0.5, 1.0, 2.5, 3.0],
        ];
        let points: Vec<Vec<Xy>> = b.iter().map(|&c| corners(c)).collect();
        let o = run(&b, &points, &[[0, 1], [0, 2], [1, 2]]);
        assert_eq!(o.status, vec![1, 1, 1]);
        let a = areas(&o);
        // the union: 3 x 2 plus the third box above y = 2 (2 x 1)
        assert!((a.iter().sum::<f64>() - 8.0).abs() < 1e-12, "{a:?}");
        assert!(a.iter().all(|&x| x > 0.5), "{a:?}");
    }

    #[test]
    fn bad_offsets_and_pairs_are_errors() {
        let (xy, rings, polygons, geometries) = boxes(&[[0.0, 0.0, 1.0, 1.0]]);
        let polys = Polygons {
            xy: &xy,
            ring_offsets: &rings,
            polygon_offsets: &polygons,
            geometry_offsets: &geometries,
        };
        let e = split(&polys, &[], &[0], &[]).unwrap_err();
        assert!(e.contains("point_offsets"), "{e}");
        let e = split(&polys, &[], &[0, 0], &[[0, 1]]).unwrap_err();
        assert_eq!(e, "pair names geometry 1, of 1");
    }
}
