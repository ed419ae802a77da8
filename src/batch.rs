//! Every group in one call: checked input, groups spread over threads, the
//! results as flat arrays with offsets (geoarrow's layout).

use std::panic::{catch_unwind, AssertUnwindSafe};

use rayon::prelude::*;

use crate::frame::Xy;
use crate::group::{solve, Options, Reason, Solved};
use crate::mesh::counting_sort;

/// Coordinates beyond this magnitude are refused (their squares overflow).
pub const MAX_COORDINATE: f64 = 1e100;

/// Groups beyond the number of points a call may have (empty groups): each
/// costs memory, so a larger count is refused rather than allocated.
pub const MAX_EMPTY_GROUPS: usize = 1 << 20;

/// Everything one call takes.
pub struct Input<'a> {
    /// Points sorted by group.
    pub xy: &'a [Xy],
    /// The same points in the output coordinates, if they differ.
    pub out: Option<&'a [Xy]>,
    /// Group `g` is `xy[offsets[g]..offsets[g + 1]]`.
    pub offsets: &'a [i64],
    /// A given alpha per group (instead of the optimum).
    pub alpha: Option<&'a [f64]>,
    /// Rows (or locations) every group may leave out: a count, the same for
    /// all (0: none, or `options.fraction` of each group's).
    pub count: i64,
    /// The options of every group.
    pub options: Options,
}

/// The results as flat arrays with offsets: the dict `alpha_shapes` returns
/// (`geoalpha/_kernel.pyi`); point indices are into `xy` (sorted by group).
#[derive(Clone, Debug, Default)]
pub struct Output {
    pub(crate) reason: Vec<u8>,
    pub(crate) alpha: Vec<f64>,
    pub(crate) n_distinct: Vec<u32>,
    pub(crate) n_parts: Vec<u32>,
    pub(crate) area: Vec<f64>,
    pub(crate) n_outliers: Vec<u64>,
    pub(crate) whole: Vec<bool>,
    pub(crate) capped: Vec<bool>,
    pub(crate) rep: Vec<i64>,
    pub(crate) left_out: Vec<bool>,
    pub(crate) ring_vertex: Vec<i64>,
    pub(crate) ring_offsets: Vec<i64>,
    pub(crate) polygon_offsets: Vec<i64>,
    pub(crate) group_offsets: Vec<i64>,
    pub(crate) curve_value: Vec<f64>,
    pub(crate) curve_valid: Vec<bool>,
    pub(crate) curve_offsets: Vec<i64>,
    pub(crate) limited_by: Vec<u8>,
    pub(crate) critical: Vec<i64>,
    pub(crate) last_vertex: Vec<i64>,
    pub(crate) last_offsets: Vec<i64>,
    pub(crate) suspicious: Vec<bool>,
    pub(crate) alt_k: Vec<u32>,
    pub(crate) alt_radius: Vec<f64>,
    pub(crate) alt_area: Vec<f64>,
    pub(crate) alt_parts: Vec<u32>,
    pub(crate) alt_capped: Vec<bool>,
    pub(crate) alt_offsets: Vec<i64>,
    pub(crate) alt_rows: Vec<i64>,
    pub(crate) alt_row_offsets: Vec<i64>,
}

fn check(input: &Input) -> Result<usize, String> {
    let (n, off) = (input.xy.len(), input.offsets);
    if off.iter().any(|&x| x < 0) {
        return Err("offsets must be >= 0".into());
    }
    if input.count < 0 {
        return Err(format!("count must be >= 0; got {}", input.count));
    }
    if off.first() != Some(&0) || off.last() != Some(&(n as i64)) {
        return Err(format!(
            "offsets must run from 0 to the number of points ({n})"
        ));
    }
    if off.windows(2).any(|w| w[1] < w[0]) {
        return Err("offsets must not decrease".into());
    }
    let groups = off.len() - 1;
    if let Some(got) = input.out.map(<[Xy]>::len).filter(|&len| len != n) {
        return Err(format!(
            "out_xy must have one row per point ({n}); got {got}"
        ));
    }
    if let Some(len) = input.alpha.map(<[f64]>::len).filter(|&len| len != groups) {
        return Err(format!(
            "alpha must have one value per group ({groups}); got {len}"
        ));
    }
    let bad_alpha = |x: &f64| !(x.is_finite() && *x >= 0.0);
    if input.alpha.is_some_and(|a| a.iter().any(bad_alpha)) {
        return Err("alpha must be finite and >= 0".into());
    }
    if input.options.components < 1 {
        return Err("components must be >= 1".into());
    }
    let f = input.options.fraction;
    if !((0.0..1.0).contains(&f)) {
        return Err(format!("fraction must be in [0, 1); got {f}"));
    }
    let s = input.options.suspicious;
    if !(s == 0.0 || s > 1.0 && s.is_finite()) {
        return Err(format!(
            "suspicious must be 0 (off) or a factor > 1; got {s}"
        ));
    }
    let bad = |p: &Xy| !(p[0].abs() <= MAX_COORDINATE && p[1].abs() <= MAX_COORDINATE);
    let mut rows = input.xy.iter().chain(input.out.unwrap_or(&[]));
    if let Some(row) = rows.position(bad) {
        return Err(format!(
            "coordinates must be finite numbers of magnitude at most {MAX_COORDINATE:e}; \
             row {} is not",
            row % n.max(1)
        ));
    }
    // Finite by now: a NaN latitude was refused above.
    let beyond = |p: &Xy| input.options.sphere && p[1].abs() > 90.0;
    if let Some(row) = input.xy.iter().position(beyond) {
        return Err(format!(
            "with sphere=True, xy holds longitudes and latitudes in degrees; \
             row {row} has latitude {}",
            input.xy[row][1]
        ));
    }
    Ok(groups)
}

/// `xy` and `out` stably sorted by group (`codes`: each row's group, below
/// `groups`) and the rows in that order: counting sorts, the rows' on a second thread.
pub fn sort(codes: &[i64], groups: usize, xy: &[Xy], out: Option<&[Xy]>) -> Result<Sorted, String> {
    if codes.len() != xy.len() || out.is_some_and(|o| o.len() != xy.len()) {
        return Err("codes, xy and out_xy must have one row per point".into());
    }
    if groups > xy.len().saturating_add(MAX_EMPTY_GROUPS) {
        return Err(format!(
            "groups must be at most the number of points ({}) + {MAX_EMPTY_GROUPS}; got {groups}",
            xy.len()
        ));
    }
    if codes.iter().any(|&c| !(0..groups as i64).contains(&c)) {
        return Err(format!("codes must be in 0..{groups}"));
    }
    let keys = codes.iter().map(|&c| c as usize);
    let sorted = |p: &[Xy]| counting_sort(keys.clone().zip(p.iter().copied()), groups);
    let ((sxy, sout), order) = rayon::join(
        || (sorted(xy), out.map(sorted)),
        || counting_sort(keys.clone().zip(0..), groups),
    );
    Ok((sxy, sout, order))
}

/// What [`sort`] returns: `xy` and `out` sorted, and the rows in that order.
pub type Sorted = (Vec<Xy>, Option<Vec<Xy>>, Vec<i64>);

/// Solve every group, spread over the threads of the current rayon pool.
pub fn run(input: &Input) -> Result<Output, String> {
    let groups = check(input)?;
    let solved: Vec<Solved> = (0..groups)
        .into_par_iter()
        .map(|g| {
            if crate::stop::requested() {
                return failed(); // (Ctrl-C: the call is dropped below)
            }
            let (a, b) = (input.offsets[g] as usize, input.offsets[g + 1] as usize);
            // A panic in one group fails that group alone (reason 7).
            catch_unwind(AssertUnwindSafe(|| {
                #[cfg(test)]
                if tests::FAIL_GROUP.load(std::sync::atomic::Ordering::Relaxed) == g {
                    panic!("a failure injected in group {g}");
                }
                solve(
                    &input.xy[a..b],
                    input.out.map(|o| &o[a..b]),
                    input.alpha.map(|x| x[g]),
                    input.count as u64,
                    &input.options,
                )
            }))
            .unwrap_or_else(|_| failed())
        })
        .collect();
    crate::stop::check()?;
    Ok(flatten(&solved, input.offsets, input.xy.len()))
}

/// The result of a group the kernel failed on: no shape, reason 7.
fn failed() -> Solved {
    Solved {
        reason: Reason::Failed as u8,
        alpha: f64::NAN,
        radius: f64::NAN,
        ..Solved::default()
    }
}

fn flatten(solved: &[Solved], offsets: &[i64], n: usize) -> Output {
    let mut o = Output {
        rep: Vec::with_capacity(n),
        left_out: vec![false; n],
        ring_offsets: vec![0],
        polygon_offsets: vec![0],
        group_offsets: vec![0],
        curve_offsets: vec![0],
        last_offsets: vec![0],
        alt_offsets: vec![0],
        alt_row_offsets: vec![0],
        ..Output::default()
    };
    for (s, range) in solved.iter().zip(offsets.windows(2)) {
        let base = range[0];
        o.reason.push(s.reason);
        o.alpha.push(s.alpha);
        o.n_distinct.push(s.n_distinct);
        o.n_parts.push(s.polygons.len() as u32);
        o.area.push(s.area);
        o.n_outliers.push(s.n_outliers);
        o.whole.push(s.whole);
        o.capped.push(s.capped);
        if s.rep.is_empty() {
            o.rep.extend(base..range[1]);
        } else {
            o.rep.extend(s.rep.iter().map(|&r| base + r as i64));
        }
        o.left_out[base as usize..][..s.left_out.len()].copy_from_slice(&s.left_out);
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
        o.limited_by.push(s.limited_by);
        match s.critical {
            Some(t) => o.critical.extend(t.iter().map(|&v| base + v as i64)),
            None => o.critical.extend([-1; 3]),
        }
        o.last_vertex
            .extend(s.last.iter().map(|&v| base + v as i64));
        o.last_offsets.push(o.last_vertex.len() as i64);
        o.suspicious.push(s.suspicious);
        for a in &s.alternatives {
            o.alt_k.push(a.k);
            o.alt_radius.push(a.radius);
            o.alt_area.push(a.area);
            o.alt_parts.push(a.n_parts);
            o.alt_capped.push(a.capped);
            o.alt_rows
                .extend(a.left_out.iter().map(|&v| base + v as i64));
            o.alt_row_offsets.push(o.alt_rows.len() as i64);
        }
        o.alt_offsets.push(o.alt_k.len() as i64);
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// The group [`run`] panics in (none: `usize::MAX`); one test sets it.
    pub static FAIL_GROUP: AtomicUsize = AtomicUsize::new(usize::MAX);

    #[test]
    fn a_panic_in_one_group_fails_it_alone() {
        let square = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [2.0, 3.5]];
        let xy: Vec<Xy> = square
            .iter()
            .chain(&square)
            .chain(&square)
            .copied()
            .collect();
        let options = Options::DEFAULT;
        let input = Input {
            xy: &xy,
            out: None,
            offsets: &[0, 5, 10, 15],
            alpha: None,
            count: 0,
            options,
        };
        FAIL_GROUP.store(1, Ordering::Relaxed);
        let o = run(&input);
        FAIL_GROUP.store(usize::MAX, Ordering::Relaxed);
        let o = o.unwrap();
        assert_eq!(o.reason, vec![0, Reason::Failed as u8, 0]);
        assert_eq!(o.n_parts, vec![1, 0, 1]);
        assert!(o.alpha[1].is_nan() && (o.alpha[0] - o.alpha[2]).abs() == 0.0);
        assert!(o.alpha[0] > 0.4 && o.alpha[0] < 0.5);
        // The failed group's points represent themselves; the rings index the others.
        assert_eq!(&o.rep[5..10], &[5, 6, 7, 8, 9]);
        assert!(o.ring_vertex.iter().all(|&v| !(5..10).contains(&v)));
    }

    #[test]
    fn sort_is_stable_and_refuses_bad_codes() {
        let xy = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]];
        let (sxy, out, order) = sort(&[1, 0, 1, 0], 2, &xy, Some(&xy)).unwrap();
        assert_eq!(order, vec![1, 3, 0, 2]);
        assert_eq!(sxy, vec![xy[1], xy[3], xy[0], xy[2]]);
        assert_eq!(out, Some(sxy));
        assert!(sort(&[2, 0, 1, 0], 2, &xy, None).is_err());
        assert!(sort(&[-1, 0, 1, 0], 2, &xy, None).is_err());
        assert!(sort(&[0, 0, 1], 2, &xy, None).is_err());
        // A huge group count is refused, not allocated.
        assert!(sort(&[0, 0, 1, 0], usize::MAX, &xy, None).is_err());
        assert!(sort(&[0, 0, 1, 0], 4 + MAX_EMPTY_GROUPS, &xy, None).is_ok());
    }
}
