"""Every option of ``hull()`` reaches the computation on every path (issue #11).

The paths: the eager call, the accessor, ``n_jobs`` (through
the kernel's threads), dask-geopandas (the function and the accessor) and
the ``geoalpha hull`` command. Each option is set to a value that is not its
default, and the test records the :class:`~geoalpha._options.Options` that the
``compute`` stage of :mod:`geoalpha._frame.pipeline` receives.
"""

from __future__ import annotations

import dataclasses
import inspect
import warnings

import geopandas as gpd
import numpy as np
import pandas as pd
import pytest
import shapely
from click.testing import CliRunner
from compat import HAS_DASK, requires_dask

import geoalpha
from geoalpha import _core as kernel
from geoalpha._cli import _flags, main
from geoalpha._frame import pipeline
from geoalpha._options import FIELDS, NAMES, Options, Request
from geoalpha.errors import FLAGS, InvalidInputError, SearchWarning

#: A value that is not the default, for every option.
NON_DEFAULT = {
    "alpha": 0.002,
    "holes": True,
    "components": 2,
    "crs": "EPSG:27700",
    "method": "convex",
    "search": "ladder",
    "max_iterations": 7,
    "ratio": 0.5,
    "k": 5,
    "degenerate": "drop",
    "buffer": 2.5,
    "vertices": True,
    "dropna": False,
    "sort": False,
    "progress": False,
    "n_jobs": 2,
    "outliers": 1,
    "outlier_unit": "locations",
    "suspicious": False,
    "grow": 2.0,
    "overlap": "split",
}


def test_every_option_has_a_non_default_test_value():
    assert list(NON_DEFAULT) == list(NAMES)
    for field in FIELDS:
        assert NON_DEFAULT[field.name] != field.default, field.name
        Options(**{field.name: NON_DEFAULT[field.name]})  # a valid value


@pytest.fixture
def points():
    rng = np.random.default_rng(3)
    xy = np.array([-0.12, 51.5]) + rng.random((60, 2)) * [0.05, 0.03]
    return gpd.GeoDataFrame(
        {"g": np.repeat(["b", "a", "c"], 20)}, geometry=shapely.points(xy), crs=4326
    )


@pytest.fixture
def received(monkeypatch):
    """The Options of every compute stage, and the kwargs reaching the kernel."""
    calls = {"compute": [], "kernel": []}
    compute, run_kernel = pipeline.compute, kernel.solve

    def record_compute(points, proj, n_groups, options, **kwargs):
        calls["compute"].append(options)
        return compute(points, proj, n_groups, options, **kwargs)

    def record_kernel(*args, **kwargs):
        request = args[3] if len(args) > 3 else kwargs["request"]
        calls["kernel"].append(vars(request))
        return run_kernel(*args, **kwargs)

    monkeypatch.setattr(pipeline, "compute", record_compute)
    monkeypatch.setattr(kernel, "solve", record_kernel)
    return calls


def _eager(points, name, value):
    return geoalpha.hull(points, "g", **{name: value})


def _accessor(points, name, value):
    return points.alpha.hull("g", **{name: value})


def _n_jobs(points, name, value):
    return geoalpha.hull(points, "g", **{"n_jobs": 2, name: value})


def _dask(points, name, value):
    import dask_geopandas

    ddf = dask_geopandas.from_geopandas(points, npartitions=2)
    return geoalpha.hull(ddf, "g", **{name: value}).compute(scheduler="sync")


def _dask_accessor(points, name, value):
    import dask_geopandas

    ddf = dask_geopandas.from_geopandas(points, npartitions=2)
    return ddf.alpha.hull("g", **{name: value}).compute(scheduler="sync")


def _cli_flags() -> set[str]:
    hull_command = main.commands["hull"]
    return {opt for p in hull_command.params for opt in (*p.opts, *p.secondary_opts)}


def test_the_cli_options_are_built_from_options():
    """Every option is a flag of `geoalpha hull`, with its default, choices and help."""
    params = {p.name: p for p in main.commands["hull"].params}
    for field in FIELDS:
        meta = field.metadata["meta"]
        param = params[field.name]
        assert set(meta.flags[-1].split("/")) <= _cli_flags(), field.name
        assert param.default == field.default, field.name
        assert param.help == meta.help, field.name
        if meta.kind == "choice":  # shown in --help; checked by Options' check
            assert param.metavar == f"[{'|'.join(meta.choices)}]", field.name
    assert params["max_iterations"].opts == ["--max-iterations"]
    for name in ("grow", "progress"):  # the same options in `geoalpha demo`
        demo = next(p for p in main.commands["demo"].params if p.name == name)
        assert demo.to_info_dict() == params[name].to_info_dict()


def _cli(points, name, value, tmp_path):
    table = pd.DataFrame(points.drop(columns="geometry"))
    table["lon"], table["lat"] = points.geometry.x, points.geometry.y
    table.to_csv(tmp_path / "p.csv", index=False)
    meta = dataclasses.fields(Options)[NAMES.index(name)].metadata["meta"]
    flag = meta.flags[-1]
    if meta.kind == "bool":
        positive, _, negative = flag.partition("/")
        args = [positive if value else negative]
    else:
        args = [flag, str(value)]
    out = tmp_path / "h.gpkg"
    runner = CliRunner()
    result = runner.invoke(
        main, ["hull", str(tmp_path / "p.csv"), str(out), "--by", "g", *args]
    )
    if result.exit_code != 0 and "no hull to write" not in result.output + str(
        getattr(result, "stderr", "")
    ):
        raise AssertionError(result.output)


PATHS = {
    "eager": _eager,
    "accessor": _accessor,
    "n_jobs": _n_jobs,
    "dask": pytest.param(_dask, marks=requires_dask),
    "dask accessor": pytest.param(_dask_accessor, marks=requires_dask),
    "cli": _cli,
}


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("path", list(PATHS.values()), ids=list(PATHS))
def test_every_option_arrives_on_every_path(points, received, tmp_path, path, name):
    value = NON_DEFAULT[name]
    dask_path = path in (_dask, _dask_accessor)
    args = (points, name, value) + ((tmp_path,) if path is _cli else ())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if dask_path and name == "n_jobs":  # dask spreads partitions itself
            with pytest.raises(InvalidInputError, match="does not apply to dask"):
                path(*args)
            return
        result = path(*args)
    assert received["compute"], "the compute stage was not reached"
    if dask_path and name == "overlap":  # split by dask's second pass, over them all
        assert received["compute"][-1].overlap == "keep"  # (the partitions)
        assert {"area_ceded_m2", "neighbours"} <= set(result.columns)
        return
    for options in received["compute"]:
        assert getattr(options, name) == value, (name, options)
    if path is _n_jobs or name == "n_jobs":
        assert received["kernel"], "n_jobs did not reach the kernel"
        for kwargs in received["kernel"]:
            assert kwargs["n_jobs"] == 2
            if name in ("holes", "components"):
                assert kwargs[name] == value


# --- bad rows: one behaviour on every path (#24) --------------------------------

NAN = float("nan")
#: Bad rows (index label -> geometry) that every path must treat alike: the
#: same result and the same warnings, or the same error. Rows 3 and 7 are in
#: group "b", 45 in group "c" (the first and the second dask partition).
BAD_ROWS = {
    "NaN coordinates": {3: shapely.Point(NAN, NAN), 45: shapely.Point(NAN, 51.51)},
    "NaN in a MultiPoint": {
        7: shapely.MultiPoint([(NAN, NAN), (-0.1, 51.51)]),
        45: shapely.Point(-0.1, NAN),
    },
    "infinite coordinates": {3: shapely.Point(np.inf, 51.51), 45: None},
    "empty geometries": {3: shapely.Point(), 45: shapely.MultiPoint()},
    "None geometries": {3: None, 7: None, 45: None},
    "non-point geometries": {
        3: shapely.LineString([(-0.1, 51.5), (-0.09, 51.51)]),
        45: shapely.box(-0.1, 51.5, -0.09, 51.51),
        7: None,
    },
    "a missing key and a None geometry": {3: None, "key": {7: None, 45: None}},
}
#: Options that change what becomes of bad rows (as ``(name, value)``).
ROW_OPTIONS = {
    "defaults": ("sort", True),
    "vertices": ("vertices", True),
    "no dropna": ("dropna", False),
}


def _outcome(path, points, tmp_path, option):
    """What a user sees: ("error", message) or ("result", rows, warnings)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if path is _cli_file:
                return path(points, tmp_path, option)
            hulls = path(points, *option)
        except InvalidInputError as err:
            return ("error", str(err))
    shown = [
        (w.category.__name__, str(w.message))
        for w in caught
        if issubclass(w.category, geoalpha.GeoAlphaWarning)
    ]
    return ("result", _rows_of(hulls), shown)


def _rows_of(hulls) -> list:
    """The result, comparable with ``==`` (a missing key or alpha as None)."""

    def value(v):
        return None if pd.isna(v) else v

    return [
        (value(g), n, value(a), shapely.to_wkb(geom))
        for g, n, a, geom in zip(
            hulls["g"], hulls["n_points"], hulls["alpha"], hulls.geometry, strict=True
        )
    ]


def _cli_file(points, tmp_path, option):
    """``geoalpha hull`` on the points in a GeoPackage (CSV holds no lines)."""
    from cli_runner import run

    points.to_file(tmp_path / "bad.gpkg")
    out = tmp_path / "h.gpkg"
    flags = {"vertices": ["--vertices"], "dropna": ["--no-dropna"]}.get(option[0], [])
    result = run("hull", tmp_path / "bad.gpkg", out, "--by", "g", *flags)
    lines = result.stderr.splitlines()
    errors = [line[7:] for line in lines if line.startswith("Error: ")]
    if errors:
        return ("error", errors)
    shown = [line[9:] for line in lines if line.startswith("Warning: ")]
    return ("result", _rows_of(gpd.read_file(out)), shown)


@pytest.mark.parametrize("option", list(ROW_OPTIONS.values()), ids=list(ROW_OPTIONS))
@pytest.mark.parametrize("bad", list(BAD_ROWS))
@pytest.mark.parametrize(
    "path", [*list(PATHS.values())[:-1], _cli_file], ids=[*list(PATHS)[:-1], "cli"]
)
def test_bad_rows_get_one_behaviour_on_every_path(points, tmp_path, path, bad, option):
    """NaN, infinite, empty, None and non-point rows, as the eager call treats them.

    ``POINT (NaN NaN)`` used to raise eagerly and be dropped (as an empty
    point, by the WKB of the shuffle) with dask; dask counted dropped rows
    and named bad rows per partition.
    """
    for label, geometry in BAD_ROWS[bad].items():
        if label == "key":
            for row, key in geometry.items():
                points.loc[row, "g"] = key
        else:
            points.loc[label, "geometry"] = geometry
    expected = _outcome(_eager, points, tmp_path, option)
    got = _outcome(path, points, tmp_path, option)
    if bad == "NaN coordinates" and option[0] == "sort":
        assert expected[0] == "result"
        assert expected[2] == [
            (
                "DroppedRowsWarning",
                "hull() dropped 2 of 60 rows: 2 with a missing or empty geometry or "
                "NaN coordinates (index 3, 45)",
            )
        ]
    if path is _cli_file:
        if bad == "NaN in a MultiPoint":
            # A GeoPackage holds POINT (NaN NaN) as POINT EMPTY: the command
            # must agree with hull() on what the file holds.
            points.to_file(tmp_path / "held.gpkg")
            points = gpd.read_file(tmp_path / "held.gpkg")
        # the same messages, naming the command's flags
        token = FLAGS.set(_flags(main.commands["hull"]))
        try:
            expected = _outcome(_eager, points, tmp_path, option)
        finally:
            FLAGS.reset(token)
        if expected[0] == "error":
            expected = ("error", [expected[1]])
        else:
            expected = (*expected[:2], [m for _, m in expected[2]])
    assert got == expected


def test_every_default_is_its_own_checked_value():
    # Options skips the check of a value that is its field's default object,
    # so every default must be what the check makes of it, of the same type.
    for field in FIELDS:
        checked = field.metadata["meta"].check(field.name, field.default)
        assert checked == field.default, field.name
        assert type(checked) is type(field.default), field.name
    with pytest.raises(InvalidInputError, match="components"):
        Options(components=0)  # a value other than the default is checked


def test_hull_signature_and_docstring_come_from_options():
    params = inspect.signature(geoalpha.hull).parameters
    assert list(params) == ["gdf", "by", *NAMES]
    for field in FIELDS:
        assert params[field.name].default == field.default
        assert params[field.name].kind is inspect.Parameter.KEYWORD_ONLY
        assert f"\n    {field.name} : " in geoalpha.hull.__doc__
    accessor = inspect.signature(gpd.GeoDataFrame.alpha.hull).parameters
    assert list(accessor)[-len(NAMES) :] == list(NAMES)


def test_unknown_and_bad_options_name_the_option(points):
    with pytest.raises(InvalidInputError, match=r"^hull\(\) got unknown option.*holez"):
        geoalpha.hull(points, "g", holez=True)
    with pytest.raises(InvalidInputError, match=r"^outlier_rows\(\) got unknown"):
        geoalpha.outlier_rows(points, "g", holez=True)
    with pytest.raises(InvalidInputError, match="components must be an integer >= 1"):
        points.alpha.hull("g", components=0)
    with pytest.raises(InvalidInputError, match="holes must be True or False"):
        geoalpha.hull(points, "g", holes="yes")
    with pytest.raises(InvalidInputError, match="crs= must be a projected"):
        geoalpha.hull(points, "g", crs="EPSG:4326")


@requires_dask
def test_dask_honours_max_iterations(points):
    """``geoalpha.hull(ddf, search="bisect", max_iterations=3)`` used to drop it."""
    import dask_geopandas

    ddf = dask_geopandas.from_geopandas(points, npartitions=2)
    options = {"search": "bisect", "max_iterations": 3, "crs": None}
    with pytest.warns(SearchWarning, match="max_iterations=3"):
        eager = geoalpha.hull(points, "g", **options)
    for lazy in (geoalpha.hull(ddf, "g", **options), ddf.alpha.hull("g", **options)):
        with pytest.warns(SearchWarning, match="max_iterations=3"):
            out = lazy.compute(scheduler="sync")
        np.testing.assert_array_equal(out["alpha"], eager["alpha"])
    assert HAS_DASK


def test_numpy_scalars_are_accepted_and_booleans_are_not_numbers():
    assert Options(holes=np.True_, components=np.int64(2)).components == 2
    assert Options(alpha=np.float32(0.5)).alpha == 0.5
    with pytest.raises(InvalidInputError, match="components must be an integer"):
        Options(components=True)
    with pytest.raises(InvalidInputError, match="k must be an integer >= 1"):
        Options(k=2.5)


def test_a_number_option_keeps_ints_and_floats_apart():
    """What ``outliers=`` (a count or a fraction) will need: kind="number"."""
    from geoalpha import _options as options

    meta = options.OptionMeta(kind="number", low=0.0, doc="", flags=("--q",))
    assert meta.check("q", 3) == 3 and isinstance(meta.check("q", 3), int)
    assert meta.check("q", 0.25) == 0.25
    with pytest.raises(InvalidInputError, match="q must be a finite number >= 0"):
        meta.check("q", -1)


@pytest.mark.parametrize(
    ("option", "message"),
    [
        ({"holes": "yes"}, "holes must be True or False; got 'yes'"),
        ({"components": 0}, "components must be an integer >= 1; got 0"),
        ({"components": np.int64(0)}, "components must be an integer >= 1; got 0"),
        ({"components": 2.5}, "components must be an integer >= 1; got 2.5"),
        ({"search": "fast"}, "search must be one of 'exact', 'ladder', 'bisect'"),
        ({"max_iterations": 0}, "max_iterations must be an integer >= 1; got 0"),
        ({"outliers": 1.5}, "outliers must be a fraction in [0, 1) or a count >= 0"),
        (
            {"n_jobs": 0},
            "n_jobs must be a positive integer, or -1 or None (every core); got 0",
        ),
    ],
)
def test_the_array_api_checks_options_as_hull_does(points, option, message):
    """One check (options.py) and one message, for hull() and the array API."""
    xy = shapely.get_coordinates(points.geometry.array)
    calls = [
        lambda: geoalpha.hull(points, "g", **option),
        lambda: geoalpha.alpha_shapes(xy, **option),
    ]
    if "n_jobs" not in option:
        calls.append(lambda: geoalpha.optimal_alpha(xy, **option))
    for call in calls:
        with pytest.raises(InvalidInputError) as caught:
            call()
        assert str(caught.value).startswith(message)


def test_the_array_api_defaults_are_those_of_options():
    """The array API (and the layers below) spell defaults out: those of Options."""
    import typing

    from geoalpha._arrays import optimal, search
    from geoalpha._frame import crs
    from geoalpha._options import SEARCHES, defaults

    functions = (
        geoalpha.alpha_shapes,
        geoalpha.optimal_alpha,
        geoalpha.alpha_shape,
        search.bisect_alpha,  # the layers below options.py: no import of it
        Request,  # what options.py hands the kernel
        crs.metric_crs,
    )
    for func in functions:
        params = inspect.signature(func).parameters
        shared = [name for name in params if name in NAMES and name != "alpha"]
        assert shared, func
        for name in shared:
            assert params[name].default == defaults()[name], (func, name)
    assert typing.get_args(optimal.Search) == SEARCHES
