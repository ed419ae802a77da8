//! Every group in one call: checked input, groups spread over threads, the
//! results as flat arrays with offsets (geoarrow's layout).

use std::fmt;

use rayon::prelude::*;

use crate::frame::Xy;
use crate::group::{solve, Options, Solved};

/// Coordinates beyond this magnitude are refused (their squares overflow).
pub const MAX_COORDINATE: f64 = 1e100;

/// Input the kernel refuses. The Python side checks everything first and
/// names rows; these are the last line, turned into `ValueError`.
#[derive(Clone, Debug, PartialEq)]
pub enum KernelError {
    /// Offsets that do not cut `0..n` into groups.
    Offsets(String),
    /// An array of the wrong length.
    Length(String),
    /// A coordinate that is NaN, infinite or too large (its row).
    Coordinate(usize),
    /// An option out of range.
    Option(String),
}

impl fmt::Display for KernelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KernelError::Offsets(s) | KernelError::Length(s) | KernelError::Option(s) => {
                f.write_str(s)
            }
            KernelError::Coordinate(row) => write!(
                f,
                "coordinates must be finite numbers of magnitude at most {MAX_COORDINATE:e}; \
                 row {row} is not"
            ),
        }
    }
}

impl std::error::Error for KernelError {}

/// Everything one call takes.
pub struct Input<'a> {
    /// Points sorted by group.
    pub xy: &'a [Xy],
    /// The same points in the output coordinates, if they differ.
    pub out: Option<&'a [Xy]>,
    /// Group `g` is `xy[offsets[g]..offsets[g + 1]]`.
    pub offsets: &'a [usize],
    /// A given alpha per group (instead of the optimum).
    pub alpha: Option<&'a [f64]>,
    /// Rows each group may leave out.
    pub budget: Option<&'a [u64]>,
    /// The options of every group.
    pub options: Options,
}

/// The results, flat. Point indices are into `xy` (sorted by group).
#[derive(Clone, Debug, Default)]
pub struct Output {
    /// Per group: a [`crate::group::Reason`] code.
    pub reason: Vec<u8>,
    /// Per group: alpha (NaN if degenerate).
    pub alpha: Vec<f64>,
    /// Per group: the radius threshold.
    pub radius: Vec<f64>,
    /// Per group: distinct points.
    pub n_distinct: Vec<u32>,
    /// Per group: pieces (polygons).
    pub n_parts: Vec<u32>,
    /// Per group: area of the shape.
    pub area: Vec<f64>,
    /// Per group: rows left out.
    pub n_outliers: Vec<u64>,
    /// Per group: every triangle is in the shape.
    pub whole: Vec<bool>,
    /// Per group: the outlier search hit its node budget.
    pub capped: Vec<bool>,
    /// Per point: its representative.
    pub rep: Vec<i64>,
    /// Per point: left out (`outliers=`).
    pub left_out: Vec<bool>,
    /// Ring vertices (closed rings), as point indices.
    pub ring_vertex: Vec<i64>,
    /// Ring `k` is `ring_vertex[ring_offsets[k]..ring_offsets[k + 1]]`.
    pub ring_offsets: Vec<i64>,
    /// Polygon `p` has rings `polygon_offsets[p]..polygon_offsets[p + 1]`.
    pub polygon_offsets: Vec<i64>,
    /// Group `g` has polygons `group_offsets[g]..group_offsets[g + 1]`.
    pub group_offsets: Vec<i64>,
    /// The validity curves (when asked): values, ascending per group.
    pub curve_value: Vec<f64>,
    /// Validity at each value.
    pub curve_valid: Vec<bool>,
    /// Group `g`'s curve is `curve_offsets[g]..curve_offsets[g + 1]`.
    pub curve_offsets: Vec<i64>,
}

fn check(input: &Input) -> Result<usize, KernelError> {
    let n = input.xy.len();
    let off = input.offsets;
    if off.is_empty() || off[0] != 0 || off[off.len() - 1] != n {
        return Err(KernelError::Offsets(format!(
            "offsets must run from 0 to the number of points ({n})"
        )));
    }
    if off.windows(2).any(|w| w[1] < w[0]) {
        return Err(KernelError::Offsets("offsets must not decrease".into()));
    }
    let groups = off.len() - 1;
    if let Some(o) = input.out {
        if o.len() != n {
            return Err(KernelError::Length(format!(
                "out_xy must have one row per point ({n}); got {}",
                o.len()
            )));
        }
    }
    for (name, len) in [
        ("alpha", input.alpha.map(<[f64]>::len)),
        ("budget", input.budget.map(<[u64]>::len)),
    ] {
        if let Some(len) = len {
            if len != groups {
                return Err(KernelError::Length(format!(
                    "{name} must have one value per group ({groups}); got {len}"
                )));
            }
        }
    }
    if let Some(a) = input.alpha {
        if a.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(KernelError::Option("alpha must be finite and >= 0".into()));
        }
    }
    if input.options.components < 1 {
        return Err(KernelError::Option("components must be >= 1".into()));
    }
    let bad = |p: &Xy| !(p[0].abs() <= MAX_COORDINATE && p[1].abs() <= MAX_COORDINATE);
    let rows = input.xy.iter().chain(input.out.unwrap_or(&[]).iter());
    if let Some(row) = rows
        .enumerate()
        .find(|(_, p)| bad(p))
        .map(|(i, _)| i % n.max(1))
    {
        return Err(KernelError::Coordinate(row));
    }
    if input.options.sphere {
        if let Some(row) = input
            .xy
            .iter()
            .position(|p| p[1].abs().is_nan() || p[1].abs() > 90.0)
        {
            return Err(KernelError::Option(format!(
                "with sphere=True, xy holds longitudes and latitudes in degrees; \
                 row {row} has latitude {}",
                input.xy[row][1]
            )));
        }
    }
    Ok(groups)
}

/// Solve every group, spread over the threads of the current rayon pool.
pub fn run(input: &Input) -> Result<Output, KernelError> {
    let groups = check(input)?;
    let solved: Vec<Solved> = (0..groups)
        .into_par_iter()
        .map(|g| {
            let (a, b) = (input.offsets[g], input.offsets[g + 1]);
            solve(
                &input.xy[a..b],
                input.out.map(|o| &o[a..b]),
                input.alpha.map(|x| x[g]),
                input.budget.map_or(0, |x| x[g]),
                &input.options,
            )
        })
        .collect();
    Ok(flatten(&solved, input.offsets, input.xy.len()))
}

fn flatten(solved: &[Solved], offsets: &[usize], n: usize) -> Output {
    let g = solved.len();
    let mut o = Output {
        rep: Vec::with_capacity(n),
        left_out: vec![false; n],
        ring_offsets: vec![0],
        polygon_offsets: vec![0],
        group_offsets: vec![0],
        curve_offsets: vec![0],
        ..Output::default()
    };
    for (k, s) in solved.iter().enumerate() {
        let base = offsets[k] as i64;
        o.reason.push(s.reason);
        o.alpha.push(s.alpha);
        o.radius.push(s.radius);
        o.n_distinct.push(s.n_distinct);
        o.n_parts.push(s.polygons.len() as u32);
        o.area.push(s.area);
        o.n_outliers.push(s.n_outliers);
        o.whole.push(s.whole);
        o.capped.push(s.capped);
        if s.rep.is_empty() {
            o.rep.extend(base..offsets[k + 1] as i64);
        } else {
            o.rep.extend(s.rep.iter().map(|&r| base + r as i64));
        }
        for (i, &out) in s.left_out.iter().enumerate() {
            o.left_out[offsets[k] + i] = out;
        }
        for polygon in &s.polygons {
            for ring in polygon {
                o.ring_vertex.extend(ring.iter().map(|&v| base + v as i64));
                o.ring_offsets.push(o.ring_vertex.len() as i64);
            }
            o.polygon_offsets.push(o.ring_offsets.len() as i64 - 1);
        }
        o.group_offsets.push(o.polygon_offsets.len() as i64 - 1);
        o.curve_value.extend_from_slice(&s.curve_values);
        o.curve_valid.extend_from_slice(&s.curve.valid);
        o.curve_offsets.push(o.curve_value.len() as i64);
    }
    debug_assert_eq!(o.reason.len(), g);
    o
}
