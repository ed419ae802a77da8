"""Keys as written (issue #36, item 3): a ``--by`` column of a CSV is text.

Zip code ``00501`` stays the string ``00501`` in every output format, and a
blank key is a dropped row named in the ``DroppedRowsWarning``, not a float
(no ``'530.0'`` in any message).
"""

from __future__ import annotations

import re

import geopandas as gpd
import pyogrio
import pytest
from cli_runner import run
from compat import requires_pyarrow

from geoalpha._io.files import read_points

# Two groups with an alpha shape, one of one point, and a blank key (row 7).
ZIPS_CSV = """zip,state,lon,lat
00501,NY,-73.00,40.80
00501,NY,-73.10,40.81
00501,NY,-73.05,40.90
01002,MA,-72.50,42.30
01002,MA,-72.60,42.40
01002,MA,-72.55,42.50
01002,MA,-72.52,42.45
,MA,-72.00,42.00
00530,NY,-72.10,42.10
"""
EXPECTED = ["00501", "00530", "01002"]


@pytest.fixture
def zips_csv(tmp_path):
    path = tmp_path / "zips.csv"
    path.write_text(ZIPS_CSV, encoding="utf-8")
    return path


def read_keys(path, column="zip") -> list:
    if path.suffix == ".parquet":
        return gpd.read_parquet(path)[column].tolist()
    return pyogrio.read_dataframe(path)[column].tolist()


FORMATS = [
    ".gpkg",
    ".shp",
    ".geojson",
    ".fgb",
    pytest.param(".parquet", marks=requires_pyarrow),
]


@pytest.mark.parametrize("suffix", FORMATS)
def test_zip_codes_keep_their_leading_zeros(zips_csv, tmp_path, suffix):
    out = tmp_path / f"zips{suffix}"
    result = run("hull", zips_csv, out, "--by", "zip")
    assert result.exit_code == 0, result.stderr
    assert sorted(read_keys(out)) == EXPECTED  # strings, as written (.fgb: reordered)
    if suffix != ".parquet":
        info = pyogrio.read_info(out)
        fields = dict(zip(info["fields"], info["dtypes"], strict=True))
        assert fields["zip"] == "object"  # a text field, not Integer64


def test_a_blank_key_is_a_dropped_row_named_in_the_warning(zips_csv, tmp_path):
    result = run("hull", zips_csv, tmp_path / "z.gpkg", "--by", "zip")
    assert result.exit_code == 0, result.stderr
    assert (
        "Warning: geoalpha dropped 1 of 9 rows: 1 with a missing group key "
        "(index 7; --no-dropna keeps them)"
    ) in result.stderr
    assert (
        "'00530' (1 row, 1 distinct point)" in result.stderr
    )  # the one-point group, by its key
    assert not re.search(r"\d\.0\b", result.stderr)  # no '530.0', no 501.0


def test_two_key_columns_are_both_text(zips_csv, tmp_path):
    out = tmp_path / "z.geojson"
    result = run("-q", "hull", zips_csv, out, "--by", "state,zip")
    assert result.exit_code == 0, result.stderr
    back = pyogrio.read_dataframe(out)
    assert list(zip(back["state"], back["zip"], strict=True)) == [
        ("MA", "01002"),
        ("NY", "00501"),
        ("NY", "00530"),
    ]


def test_other_columns_are_read_as_before(zips_csv):
    points = read_points(zips_csv, text=["zip"])
    assert points["zip"].tolist()[:2] == ["00501", "00501"]
    assert points["zip"].isna().tolist() == [False] * 7 + [True, False]
    assert points["lon"].dtype == float  # coordinates stay numbers
    # Without text=, pandas reads the numbers it sees (as documented).
    assert read_points(zips_csv)["zip"].tolist()[0] == 501
    assert read_points(zips_csv, text="zip")["zip"].tolist()[0] == "00501"
