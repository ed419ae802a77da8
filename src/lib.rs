//! geoalpha's compiled kernel: exact optimal alpha shapes of many groups of
//! points in one call, each group triangulated by spade, its radius spectrum
//! swept with union-find, its shape returned as rings of point indices; the
//! groups on rayon's threads with the GIL released (`docs/architecture.md`).

pub mod batch;
pub mod frame;
pub mod geodesic;
pub mod group;
pub mod mesh;
pub mod rings;
pub mod spectrum;
pub mod sphere;
pub mod split;
pub mod stop;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Mutex};

use numpy::{prelude::*, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::batch::Input;
use crate::frame::Xy;
use crate::group::Options;

/// mimalloc for the kernel's own allocations (why: `Cargo.toml`).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn points<'a>(name: &str, array: &'a PyReadonlyArray2<'_, f64>) -> PyResult<&'a [Xy]> {
    let shape = array.shape();
    if shape.len() != 2 || shape[1] != 2 {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (n, 2); got {shape:?}"
        )));
    }
    // as_slice also takes a Fortran-ordered array, whose flat order is not xy's.
    let flat = (array.as_slice().ok())
        .filter(|_| array.is_c_contiguous())
        .ok_or_else(|| PyValueError::new_err(format!("{name} must be C-contiguous")))?;
    Ok(flat.as_chunks::<2>().0)
}

/// Run `work` on [`pool`]`(threads)` with the GIL released; its error
/// becomes `ValueError`, a panic `RuntimeError`, Ctrl-C `KeyboardInterrupt`.
///
/// The calling thread waits for the work on a channel and checks Python's
/// signals every [`stop::POLL`] (with the GIL, briefly); on SIGINT it raises
/// [`stop::request`]'s flag, waits for the work to stop and raises.
fn detached<T: Send, E: std::fmt::Display + Send>(
    py: Python<'_>,
    threads: usize,
    work: impl FnOnce() -> Result<T, E> + Send,
) -> PyResult<T> {
    let pool = pool(threads)?;
    let (tx, mut rx) = std::sync::mpsc::channel();
    let mut interrupt: Option<(PyErr, stop::Request)> = None;
    let outcome = pool.in_place_scope(|scope| {
        scope.spawn(move |_| {
            // (The receiver is alive until the answer: this send succeeds.)
            let _ = tx.send(catch_unwind(AssertUnwindSafe(work)));
        });
        loop {
            let (back, got) = py.detach(move || {
                let got = rx.recv_timeout(stop::POLL);
                (rx, got)
            });
            rx = back;
            match got {
                Ok(outcome) => return Some(outcome),
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return None,
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            }
            if interrupt.is_none() {
                if let Err(err) = py.check_signals() {
                    interrupt = Some((err, stop::request()));
                }
            }
        }
    });
    if let Some((err, request)) = interrupt {
        drop(request);
        return Err(err);
    }
    match outcome {
        Some(Ok(Ok(value))) => Ok(value),
        Some(Ok(Err(err))) if err.to_string() == stop::INTERRUPTED => {
            // Another call's Ctrl-C stopped this one too.
            Err(PyKeyboardInterrupt::new_err(stop::INTERRUPTED))
        }
        Some(Ok(Err(err))) => Err(PyValueError::new_err(err.to_string())),
        Some(Err(_)) | None => Err(PyRuntimeError::new_err(
            "geoalpha's kernel failed unexpectedly (a bug: please report it with the input)",
        )),
    }
}

/// A dict of the named fields of `$o`, each as a numpy array.
macro_rules! dict_of {
    ($py:expr, $o:expr; $($field:ident),*) => {{
        let d = PyDict::new($py);
        $(d.set_item(stringify!($field), $o.$field.into_pyarray($py))?;)*
        d
    }};
}

/// What `alpha_shapes` is asked, the same for every group: the attributes
/// of one Python object (`geoalpha.kernel.Compiled`; `geoalpha/_kernel.pyi`).
#[derive(FromPyObject)]
struct Request {
    holes: bool,
    components: usize,
    curve: bool,
    threads: usize,
    max_union_nodes: usize,
    sphere: bool,
    locations: bool,
    fraction: f64,
    count: i64,
    explain: bool,
    max_left_out: usize,
    left_out_locations: bool,
    suspicious: f64,
}

/// Optimal (or given-alpha) alpha shapes of every group, in one call (the
/// arguments and the arrays returned: `geoalpha/_kernel.pyi`).
#[pyfunction(name = "alpha_shapes")]
#[pyo3(signature = (xy, offsets, request, *, out_xy=None, alpha=None))]
fn py_alpha_shapes<'py>(
    py: Python<'py>,
    xy: PyReadonlyArray2<'py, f64>,
    offsets: PyReadonlyArray1<'py, i64>,
    request: Request,
    out_xy: Option<PyReadonlyArray2<'py, f64>>,
    alpha: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let r = request;
    let input = Input {
        xy: points("xy", &xy)?,
        out: out_xy.as_ref().map(|o| points("out_xy", o)).transpose()?,
        offsets: offsets.as_slice()?,
        alpha: alpha.as_ref().map(|a| a.as_slice()).transpose()?,
        count: r.count,
        options: Options {
            holes: r.holes,
            components: r.components,
            curve: r.curve,
            max_union_nodes: r.max_union_nodes,
            sphere: r.sphere,
            locations: r.locations,
            fraction: r.fraction,
            explain: r.explain,
            max_left_out: r.max_left_out,
            left_out_locations: r.left_out_locations,
            suspicious: r.suspicious,
        },
    };
    let o = detached(py, r.threads, || batch::run(&input))?;
    Ok(dict_of!(py, o;
        reason, alpha, n_distinct, n_parts, area, n_outliers, whole, capped,
        rep, left_out, ring_vertex, ring_offsets, polygon_offsets, group_offsets,
        curve_value, curve_valid, curve_offsets, limited_by, critical, last_vertex,
        last_offsets, suspicious, alt_k, alt_radius, alt_area, alt_parts, alt_capped,
        alt_offsets, alt_rows, alt_row_offsets))
}

/// The points stably sorted by group and the rows in that order
/// ([`batch::sort`]; arguments in `geoalpha/_kernel.pyi`).
#[pyfunction(name = "sort_groups")]
#[pyo3(signature = (xy, codes, groups, *, out_xy=None, threads=0))]
fn py_sort_groups<'py>(
    py: Python<'py>,
    xy: PyReadonlyArray2<'py, f64>,
    codes: PyReadonlyArray1<'py, i64>,
    groups: usize,
    out_xy: Option<PyReadonlyArray2<'py, f64>>,
    threads: usize,
) -> PyResult<Bound<'py, PyTuple>> {
    let (xy, codes) = (points("xy", &xy)?, codes.as_slice()?);
    let out = out_xy.as_ref().map(|o| points("out_xy", o)).transpose()?;
    let (sxy, sout, order) = detached(py, threads, || batch::sort(codes, groups, xy, out))?;
    let array = |p: Vec<Xy>| p.into_flattened().into_pyarray(py).reshape([xy.len(), 2]);
    let sout = sout.map(array).transpose()?;
    (array(sxy)?, sout, order.into_pyarray(py)).into_pyobject(py)
}

/// Areas (m²) on the WGS84 ellipsoid of (multi)polygons in longitude/latitude
/// ([`geodesic::polygon_areas`]; arguments in `geoalpha/_kernel.pyi`).
#[pyfunction(name = "geodesic_areas")]
#[pyo3(signature = (lon, lat, ring_offsets, polygon_offsets, geometry_offsets, *, threads=0))]
fn py_geodesic_areas<'py>(
    py: Python<'py>,
    lon: PyReadonlyArray1<'py, f64>,
    lat: PyReadonlyArray1<'py, f64>,
    ring_offsets: PyReadonlyArray1<'py, i64>,
    polygon_offsets: PyReadonlyArray1<'py, i64>,
    geometry_offsets: PyReadonlyArray1<'py, i64>,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (lon, lat) = (lon.as_slice()?, lat.as_slice()?);
    let rings = ring_offsets.as_slice()?;
    let polygons = polygon_offsets.as_slice()?;
    let geometries = geometry_offsets.as_slice()?;
    let areas = detached(py, threads, || {
        geodesic::polygon_areas(lon, lat, rings, polygons, geometries)
    })?;
    Ok(areas.into_pyarray(py))
}

/// `overlap="split"`: the overlaps of the `pairs` of polygons given to the
/// group of the nearest point, every component of overlapping groups from
/// one constrained triangulation ([`split::split`]; arguments and the dict
/// returned in `geoalpha/_kernel.pyi`).
#[pyfunction(name = "split_overlaps")]
#[pyo3(signature = (xy, ring_offsets, polygon_offsets, geometry_offsets, points, point_offsets, pairs, *, threads=0))]
#[allow(clippy::too_many_arguments)] // (the layout's arrays, as shapely gives them)
fn py_split_overlaps<'py>(
    py: Python<'py>,
    xy: PyReadonlyArray2<'py, f64>,
    ring_offsets: PyReadonlyArray1<'py, i64>,
    polygon_offsets: PyReadonlyArray1<'py, i64>,
    geometry_offsets: PyReadonlyArray1<'py, i64>,
    points: PyReadonlyArray2<'py, f64>,
    point_offsets: PyReadonlyArray1<'py, i64>,
    pairs: PyReadonlyArray2<'py, i64>,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let polygons = split::Polygons {
        xy: self::points("xy", &xy)?,
        ring_offsets: ring_offsets.as_slice()?,
        polygon_offsets: polygon_offsets.as_slice()?,
        geometry_offsets: geometry_offsets.as_slice()?,
    };
    let sites = self::points("points", &points)?;
    let point_offsets = point_offsets.as_slice()?;
    if pairs.shape().len() != 2 || pairs.shape()[1] != 2 || !pairs.is_c_contiguous() {
        return Err(PyValueError::new_err(
            "pairs must be a C-contiguous array of shape (p, 2)",
        ));
    }
    let pairs = pairs.as_slice()?.as_chunks::<2>().0;
    let o = detached(py, threads, || {
        split::split(&polygons, sites, point_offsets, pairs)
    })?;
    let d = dict_of!(py, o; status, ring_offsets, polygon_offsets, geometry_offsets);
    let n = o.xy.len() / 2;
    d.set_item("xy", o.xy.into_pyarray(py).reshape([n, 2])?)?;
    d.set_item("failures", o.failures)?;
    Ok(d)
}

/// The pool of `threads` threads (0: one per core; more than the cores the
/// process may run on: that many), built once per process and count
/// (building one costs more than a small call). A child made by
/// `fork` has none of its parent's threads, so it forgets (never drops) the
/// parent's pools; the lock is only taken with the GIL held, so no thread
/// holds it when Python forks.
fn pool(threads: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    static POOLS: Mutex<Vec<(u32, usize, Arc<rayon::ThreadPool>)>> = Mutex::new(Vec::new());
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let threads = threads.min(cores);
    let pid = std::process::id();
    let mut pools = POOLS
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if pools.first().is_some_and(|&(owner, _, _)| owner != pid) {
        std::mem::forget(std::mem::take(&mut *pools));
    }
    if let Some((_, _, pool)) = pools.iter().find(|&&(_, n, _)| n == threads) {
        return Ok(Arc::clone(pool));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("no thread pool: {e}")))?;
    let pool = Arc::new(pool);
    pools.push((pid, threads, Arc::clone(&pool)));
    Ok(pool)
}

/// The compiled kernel of geoalpha.
#[pymodule]
fn _kernel(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(py_alpha_shapes, m)?)?;
    m.add_function(wrap_pyfunction!(py_geodesic_areas, m)?)?;
    m.add_function(wrap_pyfunction!(py_sort_groups, m)?)?;
    m.add_function(wrap_pyfunction!(py_split_overlaps, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SPADE_VERSION", env!("GEOALPHA_SPADE_VERSION"))?;
    m.add("NEAR_RTOL", frame::NEAR_RTOL)?;
    m.add("PRECISION_ULPS", frame::PRECISION_ULPS)?;
    m.add("TIE_RTOL", spectrum::TIE_RTOL)?;
    m.add("ALPHA_RTOL", spectrum::ALPHA_RTOL)?;
    m.add("MAX_COORDINATE", batch::MAX_COORDINATE)?;
    m.add("MAX_EMPTY_GROUPS", batch::MAX_EMPTY_GROUPS)?;
    m.add("MAX_UNION_NODES", spectrum::MAX_UNION_NODES)?;
    m.add("EARTH_RADIUS", sphere::EARTH_RADIUS)?;
    m.add("MAX_SPHERE_DEGREES", sphere::MAX_ANGLE_DEGREES)?;
    m.add("REASONS", group::REASON_NAMES.to_vec())?;
    m.add("LIMITED_BY", group::LIMITED_BY_NAMES.to_vec())?;
    Ok(())
}
