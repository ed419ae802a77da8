"""The Processing algorithm ``geoalpha:optimalalphahulls``."""

from __future__ import annotations

import json
import math
import numbers
import time
import warnings
from pathlib import Path

from qgis.core import (
    Qgis,
    QgsFeature,
    QgsFeatureRequest,
    QgsFeatureSink,
    QgsField,
    QgsFields,
    QgsGeometry,
    QgsProcessing,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterField,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
    QgsUnitTypes,
    QgsWkbTypes,
)
from qgis.PyQt.QtCore import QUrl, QVariant

from . import dependencies

#: The options of ``geoalpha.hull()`` the plugin offers (kind, default,
#: choices, bounds, help) and those it leaves out, with why: written by
#: ``scripts/build_qgis_plugin.py`` from ``geoalpha._options.Options``.
SPEC = json.loads(
    (Path(__file__).resolve().parent / "hull_options.json").read_text("utf-8")
)
#: Each option is the parameter of its name in capitals (METHOD=convex in
#: qgis_process, as ``hull(method="convex")``). Its label in the dialog, where
#: the option name alone would not do.
LABELS = {
    "alpha": "Fixed alpha (1/metre) instead of the optimum",
    "holes": "Keep holes",
    "components": "Largest number of parts per group",
    "crs": "CRS of the computation (auto, sphere, a projected CRS, or none)",
    "search": "Search of the optimal alpha",
    "max_iterations": "Bisection steps (SEARCH=bisect)",
    "ratio": "Concave hull ratio (METHOD=concave)",
    "method": "Method",
    "k": "Starting neighbours (METHOD=knn)",
    "degenerate": "Groups without an alpha shape (1-2 points, or on a line)",
    "buffer": "Buffer width of groups without an alpha shape (metres)",
    "vertices": "Use the vertices of lines and polygons",
    "dropna": "Leave out features with an empty group value",
    "sort": "Sort the groups by value",
    "outliers": "Outliers per group: a fraction (0.02) or a count (3)",
    "outlier_unit": "What the outliers count: rows or locations",
    "suspicious": "Warn about hulls one location forces far out",
    "grow": "Grow every hull by (metres)",
}
#: Options shown under the dialog's "Advanced Parameters".
ADVANCED = ("alpha", "crs", "search", "max_iterations", "ratio", "k", "buffer")
#: Output field type of each dtype of the result table (geoalpha._frame.schema).
_FIELD_TYPES = {"f": QVariant.Double, "i": QVariant.Int, "u": QVariant.Int}
#: The fields of the WHY layer after the group fields (``geoalpha.explain()``);
#: lists of row labels become text of feature ids.
_WHY_FIELDS = {
    "radius": QVariant.Double,
    "alpha": QVariant.Double,
    "limited_by": QVariant.String,
    "critical_rows": QVariant.String,
    "radius_without_1": QVariant.Double,
    "area_m2_without_1": QVariant.Double,
    "rows_without_1": QVariant.String,
    "suspicious": QVariant.Bool,
}
#: A planar computation not in metres (CRS=none): the area in square ``unit``.
_PLANAR_WHY_FIELDS = {
    "radius": QVariant.Double,
    "alpha": QVariant.Double,
    "limited_by": QVariant.String,
    "critical_rows": QVariant.String,
    "radius_without_1": QVariant.Double,
    "area_without_1": QVariant.Double,
    "unit": QVariant.String,
    "rows_without_1": QVariant.String,
    "suspicious": QVariant.Bool,
}
_CHUNK = 1000  # features between progress reports and cancellation checks
_PLAIN = (str, int, float, bool)  # attribute types that need no conversion


def _help() -> str:
    """Return the dialog's help: what the algorithm does, then each parameter's."""
    options = "".join(
        f"<p><b>{LABELS.get(name, name)}</b> ({name.upper()}): {spec['help']}</p>"
        for name, spec in SPEC["options"].items()
    )
    left_out = "; ".join(
        f"<i>{name}</i>: {why}" for name, why in SPEC["left_out"].items()
    )
    return " ".join(
        [
            "<p>One polygon per group of points: the optimal alpha shape, the",
            "tightest single polygon that contains every point of the group, with",
            "alpha chosen exactly for each group by the geoalpha library",
            "(<code>geoalpha.hull()</code>; each parameter below is its option of",
            "the same name).</p>",
            "<p><b>Input layer</b> (INPUT): points (multipoints count as their",
            "points). Lon/lat layers are projected to a metric CRS for the",
            "computation; the hulls come back in the layer's CRS. A layer without",
            "a CRS is refused unless CRS=none. A CSV file needs its coordinate",
            "columns: delimitedtext://file:///path/points.csv?type=csv&amp;",
            "xField=longitude&amp;yField=latitude&amp;crs=EPSG:4326.</p>",
            "<p><b>Group by</b> (FIELD): one hull per distinct value (several",
            "fields: per combination); none: one hull of all points. Features with",
            "no geometry are left out (the log gives the count).</p>",
            options,
            "<p><b>Output fields</b>: the group fields, then the columns of",
            "<code>geoalpha.hull()</code>'s result:",
            ", ".join(SPEC["result_columns"]) + "; alpha is in 1/metre, radius",
            "in metres. A planar computation not in metres (CRS=none) writes",
            "area and unit instead of area_m2.</p>",
            "<p><b>Why this shape</b> (WHY, optional): one feature per group,",
            "the critical triangle whose circumradius is the optimal radius, with",
            "the fields of <code>geoalpha.explain()</code>: "
            + ", ".join(_WHY_FIELDS)
            + " (with CRS=none not in metres: area_without_1 and unit); the rows are",
            "given as feature ids of the input layer. <b>Rows left out</b>",
            "(LEFT_OUT, optional): the input features the hulls leave out",
            "(OUTLIERS), with all their fields. Both need METHOD=alpha.</p>",
            f"<p>Not offered here: {left_out}.</p>",
        ]
    )


HELP = _help()


def _python_value(value):
    """Return a hashable Python value for a QGIS attribute (None for NULL)."""
    if value is None or (isinstance(value, QVariant) and value.isNull()):
        return None
    for method in ("toPyDateTime", "toPyDate", "toPyTime"):
        if hasattr(value, method):
            return getattr(value, method)()
    return value


def _number(value):
    """Return a float for QGIS (None for NaN: a NULL attribute)."""
    value = float(value)
    return None if math.isnan(value) else value


def _attribute(value):
    """Return a result value as a QGIS attribute (NaN: NULL)."""
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    return _number(value)


def _no_crs(crs) -> str:
    """Say that the layer has no CRS, as ``geoalpha hull`` says it, in QGIS's terms."""
    what = f" ({crs.description()})" if crs.isValid() and crs.description() else ""
    return (
        f"The input layer has no CRS{what}, and geoalpha does not guess: a hull "
        "in metres needs to know what the coordinates are. Set it in the layer's "
        "Properties > Source (or with Processing's 'Assign projection'), e.g. "
        "EPSG:4326 for longitude/latitude degrees or EPSG:27700 for British "
        "National Grid metres; or set CRS to none (CRS=none in qgis_process) to "
        "use the coordinates as planar numbers: alpha, radius and area are then "
        "in their unit, and the output has the fields area and unit instead of "
        "area_m2."
    )


def _no_geometry(layer, source, names) -> str:
    """Say that the layer is a table, and how to read a CSV's coordinates.

    The layer's file is named only when it is a file (a database source may
    hold a password); ``names`` are the (x, y) column names geoalpha knows.
    """
    path = layer.source().split("|")[0] if layer is not None else ""
    what = "The input layer"
    if path and Path(path).is_file():
        path = str(Path(path).resolve())
        what += f" ({path})"
        url = QUrl.fromLocalFile(path).toString()  # file:///..., spaces as %20
    else:
        url = "file:///path/to/points.csv"
    fields = {f.name().lower(): f.name() for f in source.fields()}
    x, y = next(
        ((fields[x], fields[y]) for x, y in names if x in fields and y in fields),
        ("X_COLUMN", "Y_COLUMN"),
    )
    return (
        f"{what} has no geometry: it is read as a table of "
        f"{source.fields().count()} fields. For the points of a CSV file, give "
        "its coordinate columns and their CRS, with INPUT (qgis_process, "
        "processing.run) as\n"
        f"  delimitedtext://{url}?type=csv&xField={x}&yField={y}&crs=EPSG:4326\n"
        "(crs=EPSG:4326 for longitude/latitude degrees; the EPSG code of "
        "projected coordinates), or in QGIS with Layer > Add Layer > Add "
        "Delimited Text Layer."
    )


def _unset(value) -> bool:
    """Tell whether an optional parameter was left empty."""
    return (
        value is None or value == "" or (isinstance(value, QVariant) and value.isNull())
    )


def _wanted(parameters: dict, key: str) -> bool:
    """Tell whether an optional output (a feature sink) was asked for."""
    value = parameters.get(key)
    if _unset(value):
        return False
    sink = getattr(value, "sink", None)  # a QgsProcessingOutputLayerDefinition
    if sink is not None:
        value = sink.staticValue()
    return not _unset(value)


def _parameter(name: str, spec: dict):
    """Return the Processing parameter of the option ``name`` of ``hull()``."""
    key, kind, label = name.upper(), spec["kind"], LABELS.get(name, name)
    default = spec["default"]
    if kind == "bool":
        return QgsProcessingParameterBoolean(key, label, default)
    if kind == "choice":
        param = QgsProcessingParameterEnum(key, label)
        param.setOptions(spec["choices"])
        param.setUsesStaticStrings(True)  # METHOD=convex, as hull() takes it
        param.setDefaultValue(default)
        return param
    if kind == "crs":
        return QgsProcessingParameterString(key, label, default)
    number = (
        QgsProcessingParameterNumber.Integer
        if kind == "int"
        else QgsProcessingParameterNumber.Double
    )
    param = QgsProcessingParameterNumber(
        key, label, number, default, optional=spec["optional"]
    )
    if spec["low"] is not None:  # an open bound (BUFFER > 0): hull() says it
        param.setMinimum(spec["low"])
    if spec["high"] is not None:
        param.setMaximum(spec["high"])
    return param


class OptimalAlphaHulls(QgsProcessingAlgorithm):
    """Optimal alpha hulls by group (``geoalpha.hull``) as a Processing algorithm."""

    INPUT = "INPUT"
    FIELD = "FIELD"
    OUTPUT = "OUTPUT"
    WHY = "WHY"
    LEFT_OUT = "LEFT_OUT"

    def createInstance(self):
        """Return a new copy (QGIS runs each execution on its own instance)."""
        return OptimalAlphaHulls()

    def name(self):
        """Algorithm id within the provider."""
        return "optimalalphahulls"

    def displayName(self):
        """Name shown in the toolbox."""
        return "Optimal alpha hulls"

    def group(self):
        """Toolbox group."""
        return "Hulls"

    def groupId(self):
        """Toolbox group id."""
        return "hulls"

    def tags(self):
        """Words the toolbox search finds the algorithm by."""
        return "alpha,shape,concave,convex,hull,knn,group,polygon,geoalpha".split(",")

    def shortHelpString(self):
        """Help shown beside the dialog."""
        return HELP

    def canExecute(self):
        """Refuse to run, saying how to install, when geoalpha is missing."""
        try:
            dependencies.load()
        except dependencies.MissingGeoalpha as err:
            return False, str(err)
        return True, ""

    def initAlgorithm(self, config=None):
        """Declare the parameters: INPUT, FIELD, one per option of hull(), OUTPUT."""
        self.addParameter(
            QgsProcessingParameterFeatureSource(
                self.INPUT, "Input layer", [QgsProcessing.TypeVectorAnyGeometry]
            )
        )
        self.addParameter(
            QgsProcessingParameterField(
                self.FIELD,
                "Group by field(s)",
                parentLayerParameterName=self.INPUT,
                type=QgsProcessingParameterField.Any,
                allowMultiple=True,
                optional=True,
            )
        )
        for name, spec in SPEC["options"].items():
            param = _parameter(name, spec)
            param.setHelp(spec["help"])
            if name in ADVANCED:
                param.setFlags(
                    param.flags() | QgsProcessingParameterDefinition.FlagAdvanced
                )
            self.addParameter(param)
        self.addParameter(
            QgsProcessingParameterFeatureSink(
                self.OUTPUT, "Alpha hulls", QgsProcessing.TypeVectorPolygon
            )
        )
        self.addParameter(
            QgsProcessingParameterFeatureSink(
                self.WHY,
                "Why this shape (the critical triangles)",
                QgsProcessing.TypeVectorPolygon,
                optional=True,
                createByDefault=False,
            )
        )
        self.addParameter(
            QgsProcessingParameterFeatureSink(
                self.LEFT_OUT,
                "Rows left out (outliers)",
                QgsProcessing.TypeVectorAnyGeometry,
                optional=True,
                createByDefault=False,
            )
        )

    def _options(self, parameters, context) -> dict:
        """Keyword arguments of ``geoalpha.hull`` from the parameter values.

        Each value goes to ``hull()`` as given, which checks it; only the
        spelling is QGIS's: an empty ALPHA is None, CRS=none is None, and an
        OUTLIERS of a whole number is a count, else a fraction.
        """
        options = {}
        for name, spec in SPEC["options"].items():
            key, kind = name.upper(), spec["kind"]
            if kind == "bool":
                value = self.parameterAsBoolean(parameters, key, context)
            elif kind == "choice":
                value = self.parameterAsEnumString(parameters, key, context)
            elif kind == "crs":
                value = self.parameterAsString(parameters, key, context).strip()
                value = None if value.lower() == "none" else value or spec["default"]
            elif spec["optional"] and _unset(parameters.get(key)):
                value = None
            elif kind == "int":
                value = self.parameterAsInt(parameters, key, context)
            else:
                value = self.parameterAsDouble(parameters, key, context)
                if kind == "number" and value.is_integer():
                    value = int(value)
            options[name] = value
        return options

    def processAlgorithm(self, parameters, context, feedback):
        """Read the layer, run ``geoalpha.hull`` and write one feature per group."""
        try:
            geoalpha = dependencies.load()
        except dependencies.MissingGeoalpha as err:
            raise QgsProcessingException(str(err)) from err
        import geopandas as gpd
        import numpy as np
        import shapely

        source = self.parameterAsSource(parameters, self.INPUT, context)
        if source is None:
            raise QgsProcessingException(
                self.invalidSourceError(parameters, self.INPUT)
            )
        names = self.parameterAsFields(parameters, self.FIELD, context)
        options = self._options(parameters, context)
        if QgsWkbTypes.geometryType(source.wkbType()) == QgsWkbTypes.NullGeometry:
            from geoalpha._io.files import COORDINATE_NAMES

            layer = self.parameterAsVectorLayer(parameters, self.INPUT, context)
            raise QgsProcessingException(_no_geometry(layer, source, COORDINATE_NAMES))
        crs = source.sourceCrs()
        # GeoPackages without a CRS come as a valid "Undefined SRS" without
        # units: no CRS either (the coordinates may be in km, feet, ...).
        planar_input = (
            not crs.isValid() or crs.mapUnits() == QgsUnitTypes.DistanceUnknownUnit
        )
        if planar_input and options["crs"] is not None:
            raise QgsProcessingException(_no_crs(crs))

        explain = _wanted(parameters, self.WHY) or _wanted(parameters, self.LEFT_OUT)
        if explain and options["method"] != "alpha":
            raise QgsProcessingException(
                "The layers 'Why this shape' (WHY) and 'Rows left out' (LEFT_OUT) "
                "explain the optimal alpha shape: use them with METHOD=alpha; "
                f"got METHOD={options['method']}"
            )

        # 1. Read geometries (as WKB) and group values: 0-40 %.
        started = time.perf_counter()
        in_fields = source.fields()
        indices = [in_fields.lookupField(name) for name in names]
        request = QgsFeatureRequest().setSubsetOfAttributes(indices)
        total = max(source.featureCount(), 1)
        curved = QgsWkbTypes.isCurvedType(source.wkbType())
        wkb, raw, fids = [], [[] for _ in names], []
        for i, feature in enumerate(source.getFeatures(request)):
            fids.append(feature.id())
            if i % _CHUNK == 0:
                if feedback.isCanceled():
                    return {}
                feedback.setProgress(40.0 * i / total)
            geometry = feature.geometry()
            if geometry.isNull():
                wkb.append(None)
            else:
                if curved:
                    geometry = QgsGeometry(geometry.constGet().segmentize())
                wkb.append(bytes(geometry.asWkb()))
            if names:
                attributes = feature.attributes()
                for column, index in zip(raw, indices, strict=True):
                    column.append(attributes[index])
        # Group values as Python values (NULL -> None, QDate -> date, ...), and
        # back from them to the attributes as read, for the output features.
        columns = [
            [v if type(v) in _PLAIN else _python_value(v) for v in column]
            for column in raw
        ]
        originals = [
            {_python_value(v): v for v in column if type(v) not in _PLAIN}
            for column in raw
        ]
        frame = gpd.GeoDataFrame(
            dict(zip(names, columns, strict=True)),
            geometry=shapely.from_wkb(np.array(wkb, dtype=object)),
            crs=None
            if planar_input
            else crs.authid()
            if crs.authid().startswith("EPSG:")
            else crs.toWkt(),
        )
        if feedback.isCanceled():
            return {}

        # 2. The hulls, in one call: 40-90 %.
        feedback.setProgress(40)
        read = time.perf_counter()
        mismatch = dependencies.geos_mismatch(shapely.geos_version, Qgis.geosVersion())
        if mismatch:
            feedback.pushWarning(mismatch)
        feedback.pushInfo(
            f"geoalpha {geoalpha.__version__} (numpy {np.__version__}, shapely "
            f"{shapely.__version__}, GEOS {shapely.geos_version_string}): hulls of "
            f"{len(frame):,} features "
            f"grouped by {', '.join(names) or '(no field: one hull)'}"
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                if explain:
                    from geoalpha._hulls import hull_and_why

                    result, why, left_out = hull_and_why(
                        frame, by=list(names) or None, progress=False, **options
                    )
                else:
                    result = geoalpha.hull(
                        frame, by=list(names) or None, progress=False, **options
                    )
            except geoalpha.GeoAlphaError as err:
                hint = ""
                if "vertices=True" in str(err) and not options["vertices"]:
                    hint = (
                        "\nIn QGIS: tick 'Use the vertices of lines and polygons' "
                        "(VERTICES=true in qgis_process)."
                    )
                raise QgsProcessingException(f"{err}{hint}") from err
        for warning in caught:
            feedback.pushWarning(f"{warning.category.__name__}: {warning.message}")
        if feedback.isCanceled():
            return {}
        feedback.setProgress(90)
        computed = time.perf_counter()

        # 3. One feature per group: 90-100 %.
        table = result  # (planar input: hull() wrote area and unit already)
        columns = [c for c in table.columns if c not in (*names, table.geometry.name)]
        fields = QgsFields()
        for name in names:
            fields.append(QgsField(in_fields.field(name)))
        for name in columns:
            kind = _FIELD_TYPES.get(table.dtypes[name].kind, QVariant.String)
            fields.append(QgsField(name, kind))
        sink, dest_id = self.parameterAsSink(
            parameters, self.OUTPUT, context, fields, QgsWkbTypes.MultiPolygon, crs
        )
        if sink is None:
            raise QgsProcessingException(self.invalidSinkError(parameters, self.OUTPUT))
        shapes = shapely.to_wkb(
            np.asarray(result.geometry.values, dtype=object), output_dimension=2
        )
        for i, row in enumerate(table.itertuples(index=False)):
            if i % _CHUNK == 0:
                if feedback.isCanceled():
                    return {}
                feedback.setProgress(90.0 + 10.0 * i / max(len(table), 1))
            values = dict(zip(table.columns, row, strict=True))
            keys = [
                seen.get(_python_value(values[name]), values[name])
                for seen, name in zip(originals, names, strict=True)
            ]
            feature = QgsFeature(fields)
            geometry = QgsGeometry()
            geometry.fromWkb(shapes[i])
            if not geometry.isEmpty():
                geometry.convertToMultiType()
                feature.setGeometry(geometry)
            feature.setAttributes(
                [*keys, *(_attribute(values[name]) for name in columns)]
            )
            if not sink.addFeature(feature, QgsFeatureSink.FastInsert):
                raise QgsProcessingException(
                    self.writeFeatureError(sink, parameters, "")
                )
        outputs = {self.OUTPUT: dest_id}
        if explain:
            outputs |= self._write_explained(
                parameters, context, source, (fields, names, originals), why, fids
            )
            outputs |= self._write_left_out(
                parameters, context, source, left_out.to_numpy(), fids
            )
        feedback.setProgress(100)
        feedback.pushInfo(
            f"{len(result):,} hulls written (seconds: reading "
            f"{read - started:.2f}, hull() {computed - read:.2f}, writing "
            f"{time.perf_counter() - computed:.2f})"
        )
        return outputs

    def _write_explained(self, parameters, context, source, keys, why, fids) -> dict:
        """Write ``geoalpha.explain()``'s critical triangles to WHY, if asked."""
        if not _wanted(parameters, self.WHY):
            return {}
        import numpy as np
        import shapely

        hull_fields, names, originals = keys
        fields = QgsFields()
        for name in names:
            fields.append(QgsField(hull_fields.field(name)))
        # explain()'s columns: area_without_1 and unit with CRS=none not in m
        why_fields = _PLANAR_WHY_FIELDS if "unit" in why.columns else _WHY_FIELDS
        for name, kind in why_fields.items():
            fields.append(QgsField(name, kind))
        sink, dest_id = self.parameterAsSink(
            parameters,
            self.WHY,
            context,
            fields,
            QgsWkbTypes.Polygon,
            source.sourceCrs(),
        )
        if sink is None:
            raise QgsProcessingException(self.invalidSinkError(parameters, self.WHY))
        shapes = shapely.to_wkb(
            np.asarray(why.geometry.values, dtype=object), output_dimension=2
        )
        for i, row in enumerate(why.itertuples(index=False)):
            values = dict(zip(why.columns, row, strict=True))
            attributes = [
                seen.get(_python_value(values[name]), values[name])
                for seen, name in zip(originals, names, strict=True)
            ]
            for name in why_fields:
                value = values[name]
                if isinstance(value, list):  # row labels: the features' ids
                    value = ", ".join(str(fids[label]) for label in value)
                elif name == "suspicious":
                    value = bool(value)
                attributes.append(_attribute(value))
            feature = QgsFeature(fields)
            if shapes[i] is not None:
                geometry = QgsGeometry()
                geometry.fromWkb(shapes[i])
                feature.setGeometry(geometry)
            feature.setAttributes(attributes)
            if not sink.addFeature(feature, QgsFeatureSink.FastInsert):
                raise QgsProcessingException(
                    self.writeFeatureError(sink, parameters, self.WHY)
                )
        return {self.WHY: dest_id}

    def _write_left_out(self, parameters, context, source, mask, fids) -> dict:
        """Copy the input features the hulls leave out to LEFT_OUT, if asked."""
        if not _wanted(parameters, self.LEFT_OUT):
            return {}
        sink, dest_id = self.parameterAsSink(
            parameters,
            self.LEFT_OUT,
            context,
            source.fields(),
            source.wkbType(),
            source.sourceCrs(),
        )
        if sink is None:
            raise QgsProcessingException(
                self.invalidSinkError(parameters, self.LEFT_OUT)
            )
        wanted = [fids[i] for i, out in enumerate(mask) if out]
        if wanted:
            request = QgsFeatureRequest().setFilterFids(wanted)
            for feature in source.getFeatures(request):
                if not sink.addFeature(feature, QgsFeatureSink.FastInsert):
                    raise QgsProcessingException(
                        self.writeFeatureError(sink, parameters, self.LEFT_OUT)
                    )
        return {self.LEFT_OUT: dest_id}
