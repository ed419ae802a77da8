"""The Processing algorithm ``geoalpha:optimalalphahulls``."""

from __future__ import annotations

import math
import time
import warnings

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
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterField,
    QgsProcessingParameterNumber,
    QgsWkbTypes,
)
from qgis.PyQt.QtCore import QVariant

from . import dependencies

#: METHOD choices, as ``hull(method=)`` and ``geoalpha hull --method`` take them.
METHODS = ("alpha", "convex", "concave", "knn")
#: DEGENERATE choices, as ``hull(degenerate=)`` takes them.
DEGENERATE = ("buffer", "empty", "drop")
#: Output fields after the group fields, as the ``geoalpha hull`` table.
RESULT_FIELDS = (
    ("alpha", QVariant.Double),
    ("radius", QVariant.Double),
    ("n_points", QVariant.Int),
    ("n_parts", QVariant.Int),
    ("area_m2", QVariant.Double),
    ("crs_used", QVariant.String),
    ("method", QVariant.String),
)
_CHUNK = 1000  # features between progress reports and cancellation checks
_PLAIN = (str, int, float, bool)  # attribute types that need no conversion

HELP = " ".join(
    [
        "<p>One polygon per group of points: the optimal alpha shape, the tightest",
        "single polygon that contains every point of the group, with alpha chosen",
        "exactly for each group by the geoalpha library.</p>",
        "<p><b>Input layer</b>: points (multipoints count as their points); lines",
        "and polygons with <i>Use the vertices of lines and polygons</i>. Lon/lat",
        "layers are projected to a metric CRS for the computation; the hulls come",
        "back in the layer's CRS and their vertices are input points.</p>",
        "<p><b>Group by</b>: one hull per distinct value (several fields: per",
        "combination); none: one hull of all points. Features with an empty group",
        "value or no geometry are left out (the log gives the count).</p>",
        "<p><b>Method</b>: <i>alpha</i> the optimal alpha shape; <i>convex</i> the",
        "convex hull; <i>concave</i> GEOS concave hull (ratio 0.3); <i>knn</i>",
        "k-nearest-neighbour hull (from k=3).</p>",
        "<p><b>Groups without an alpha shape</b> (1-2 distinct points, or all on a",
        "line): <i>buffer</i> a 1 m buffer around the points, <i>empty</i> a null",
        "geometry, <i>drop</i> no feature. The log names these groups.</p>",
        "<p><b>Output fields</b>: the group fields, <i>alpha</i> (1/metre; empty",
        "for groups without an alpha shape and for concave/knn), <i>radius</i>",
        "(1/alpha, metres), <i>n_points</i>, <i>n_parts</i>, <i>area_m2</i>,",
        "<i>crs_used</i> (the metric CRS of the computation), <i>method</i>.</p>",
    ]
)


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


class OptimalAlphaHulls(QgsProcessingAlgorithm):
    """Optimal alpha hulls by group (``geoalpha.hull``) as a Processing algorithm."""

    INPUT = "INPUT"
    VERTICES = "VERTICES"
    FIELD = "FIELD"
    HOLES = "HOLES"
    COMPONENTS = "COMPONENTS"
    METHOD = "METHOD"
    DEGENERATE = "DEGENERATE"
    OUTPUT = "OUTPUT"

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
        """Declare the parameters (their names are the qgis_process keys)."""
        self.addParameter(
            QgsProcessingParameterFeatureSource(
                self.INPUT, "Input layer", [QgsProcessing.TypeVectorAnyGeometry]
            )
        )
        self.addParameter(
            QgsProcessingParameterBoolean(
                self.VERTICES, "Use the vertices of lines and polygons", False
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
        self.addParameter(
            QgsProcessingParameterBoolean(self.HOLES, "Keep holes", False)
        )
        self.addParameter(
            QgsProcessingParameterNumber(
                self.COMPONENTS,
                "Largest number of parts per group",
                QgsProcessingParameterNumber.Integer,
                1,
                minValue=1,
            )
        )
        self.addParameter(
            self._static(
                QgsProcessingParameterEnum(self.METHOD, "Method"),
                METHODS,
            )
        )
        # OUTLIERS goes here, once geoalpha.hull() has outliers=: a
        # QgsProcessingParameterNumber (fraction or count of points a group may
        # leave out) and one line in _options().
        self.addParameter(
            self._static(
                QgsProcessingParameterEnum(
                    self.DEGENERATE,
                    "Groups without an alpha shape (1-2 points, or on a line)",
                ),
                DEGENERATE,
            )
        )
        self.addParameter(
            QgsProcessingParameterFeatureSink(
                self.OUTPUT, "Alpha hulls", QgsProcessing.TypeVectorPolygon
            )
        )

    @staticmethod
    def _static(param, choices):
        """Make the enum take its values by name (METHOD=convex), as hull() does."""
        param.setOptions(list(choices))
        param.setUsesStaticStrings(True)
        param.setDefaultValue(choices[0])
        return param

    def _options(self, parameters, context) -> dict:
        """Keyword arguments of ``geoalpha.hull`` from the parameter values."""
        return {
            "vertices": self.parameterAsBoolean(parameters, self.VERTICES, context),
            "holes": self.parameterAsBoolean(parameters, self.HOLES, context),
            "components": self.parameterAsInt(parameters, self.COMPONENTS, context),
            "method": self.parameterAsEnumString(parameters, self.METHOD, context),
            "degenerate": self.parameterAsEnumString(
                parameters, self.DEGENERATE, context
            ),
        }

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
        crs = source.sourceCrs()
        if not crs.isValid():
            raise QgsProcessingException(
                "The input layer has no CRS; set one in its Layer Properties > Source"
            )

        # 1. Read geometries (as WKB) and group values: 0-40 %.
        started = time.perf_counter()
        in_fields = source.fields()
        indices = [in_fields.lookupField(name) for name in names]
        request = QgsFeatureRequest().setSubsetOfAttributes(indices)
        total = max(source.featureCount(), 1)
        curved = QgsWkbTypes.isCurvedType(source.wkbType())
        wkb, raw = [], [[] for _ in names]
        for i, feature in enumerate(source.getFeatures(request)):
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
            crs=crs.authid() if crs.authid().startswith("EPSG:") else crs.toWkt(),
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
        fields = QgsFields()
        for name in names:
            fields.append(QgsField(in_fields.field(name)))
        for name, kind in RESULT_FIELDS:
            fields.append(QgsField(name, kind))
        sink, dest_id = self.parameterAsSink(
            parameters, self.OUTPUT, context, fields, QgsWkbTypes.MultiPolygon, crs
        )
        if sink is None:
            raise QgsProcessingException(self.invalidSinkError(parameters, self.OUTPUT))
        shapes = shapely.to_wkb(
            np.asarray(result.geometry.values, dtype=object), output_dimension=2
        )
        for i, row in enumerate(result.itertuples(index=False)):
            if i % _CHUNK == 0:
                if feedback.isCanceled():
                    return {}
                feedback.setProgress(90.0 + 10.0 * i / max(len(result), 1))
            values = dict(zip(result.columns, row, strict=True))
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
                [
                    *keys,
                    _number(values["alpha"]),
                    _number(values["radius"]),
                    int(values["n_points"]),
                    int(values["n_parts"]),
                    _number(values["area_m2"]),
                    str(values["crs_used"]),
                    str(values["method"]),
                ]
            )
            if not sink.addFeature(feature, QgsFeatureSink.FastInsert):
                raise QgsProcessingException(
                    self.writeFeatureError(sink, parameters, "")
                )
        feedback.setProgress(100)
        feedback.pushInfo(
            f"{len(result):,} hulls written (seconds: reading "
            f"{read - started:.2f}, hull() {computed - read:.2f}, writing "
            f"{time.perf_counter() - computed:.2f})"
        )
        return {self.OUTPUT: dest_id}
