"""Run the geoalpha Processing algorithm under real QGIS (PyQGIS, offscreen).

Run by QGIS's own Python (``/usr/bin/python3`` on Debian), not the project's:
``python3 pyqgis_driver.py POINTS.gpkg OUT_DIR`` prints one JSON object with
what tests/test_qgis_plugin.py checks. The plugin is loaded as QGIS loads it
(``classFactory(None).initProcessing()``) from ``QGIS_PLUGINPATH``.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from qgis.core import (
    Qgis,
    QgsApplication,
    QgsProcessingFeedback,
    QgsProcessingModelAlgorithm,
    QgsProcessingModelChildAlgorithm,
    QgsProcessingModelChildParameterSource,
    QgsProcessingModelOutput,
    QgsProcessingModelParameter,
    QgsProcessingParameterFeatureSource,
    QgsVectorLayer,
)

ALG = "geoalpha:optimalalphahulls"


class Feedback(QgsProcessingFeedback):
    """Keeps the log and progress; cancels once progress reaches ``cancel_at``."""

    def __init__(self, cancel_at=None):
        super().__init__()
        self.warnings, self.infos, self.progress = [], [], []
        self.cancel_at = cancel_at

    def pushWarning(self, text):
        self.warnings.append(text)

    def pushInfo(self, text):
        self.infos.append(text)

    def setProgress(self, value):
        self.progress.append(value)
        if self.cancel_at is not None and value >= self.cancel_at:
            self.cancel()
        super().setProgress(value)


def layer_report(path):
    """Fields (name, type name) and features (attributes, WKB hex) of a layer."""
    layer = QgsVectorLayer(str(path), "out", "ogr")
    if not layer.isValid():
        return None
    fields = [(f.name(), f.typeName()) for f in layer.fields() if f.name() != "fid"]
    features = []
    for feature in layer.getFeatures():
        attrs = {n: feature[n] for n, _ in fields}
        attrs = {k: (None if v is None or v == NULL else v) for k, v in attrs.items()}
        geometry = feature.geometry()
        features.append(
            {
                "attributes": attrs,
                "wkb": None if geometry.isNull() else bytes(geometry.asWkb()).hex(),
                "wkb_type": geometry.wkbType(),
            }
        )
    return {
        "fields": fields,
        "features": features,
        "crs": layer.crs().authid(),
        "wkb_type": layer.wkbType(),
    }


def misses(points, hulls, keys):
    """Points whose own group hull does not contain them, by QGIS's spatial join."""
    joined = processing.run(
        "native:joinattributesbylocation",
        {
            "INPUT": str(points),
            "JOIN": str(hulls),
            "PREDICATE": [0],  # intersects: boundary included (vertices are points)
            "JOIN_FIELDS": keys,
            "METHOD": 0,  # one feature per matching hull
            "DISCARD_NONMATCHING": False,
            "PREFIX": "hull_",
            "OUTPUT": "memory:",
        },
    )["OUTPUT"]
    found, own = {}, {}
    for feature in joined.getFeatures():
        key = tuple(feature[k] for k in keys)
        if any(v == NULL for v in key) or feature.geometry().isNull():
            continue  # dropped rows have no hull of their own
        own[feature["fid"]] = key
        found.setdefault(feature["fid"], set()).add(
            tuple(feature["hull_" + k] for k in keys)
        )
    bad = [fid for fid, key in own.items() if key not in found[fid]]
    return {"checked": len(own), "outside": bad}


def model(points, out):
    """A one-step model (as the graphical modeler builds it) run headless."""
    m = QgsProcessingModelAlgorithm("hulls by state", "geoalpha tests")
    m.addModelParameter(
        QgsProcessingParameterFeatureSource("points", "points"),
        QgsProcessingModelParameter("points"),
    )
    child = QgsProcessingModelChildAlgorithm(ALG)
    child.setChildId("hulls")
    child.addParameterSources(
        "INPUT", [QgsProcessingModelChildParameterSource.fromModelParameter("points")]
    )
    child.addParameterSources(
        "FIELD", [QgsProcessingModelChildParameterSource.fromStaticValue(["state"])]
    )
    child.addParameterSources(
        "METHOD", [QgsProcessingModelChildParameterSource.fromStaticValue("convex")]
    )
    output = QgsProcessingModelOutput("hulls_out")
    output.setChildId("hulls")
    output.setChildOutputName("OUTPUT")
    child.setModelOutputs({"hulls_out": output})
    m.addChildAlgorithm(child)
    m.updateDestinationParameters()
    model_file = Path(out).with_suffix(".model3")
    m.toFile(str(model_file))
    result = processing.run(m, {"points": str(points), "hulls:hulls_out": str(out)})
    return {"output": str(result["hulls:hulls_out"]), "file": str(model_file)}


def batch(points, out_dir):
    """Two rows in the Processing batch dialog (as the user fills it), run."""
    from processing.gui.BatchAlgorithmDialog import BatchAlgorithmDialog
    from processing.tools import dataobjects

    algorithm = QgsApplication.processingRegistry().createAlgorithmById(ALG)
    dialog = BatchAlgorithmDialog(algorithm)
    panel = dialog.mainWidget()
    context = dataobjects.createContext()
    while panel.batchRowCount() < 2:
        panel.addRow()
    rows = [("state", "alpha"), ("region", "convex")]
    for row, (field, method) in enumerate(rows):
        values = {"INPUT": str(points), "FIELD": [field], "METHOD": method}
        for name, value in values.items():
            column = panel.parameter_to_column[name]
            panel.wrappers[row][column].setParameterValue(value, context)
        column = panel.parameter_to_column["OUTPUT"]
        panel.tblParameters.cellWidget(row + 1, column).setValue(
            str(out_dir / f"batch_{field}.gpkg")
        )
    # runAlgorithm() runs the rows one after the other before it returns; a
    # row that raises leaves only a traceback in the message log: keep it.
    errors = []

    def logged(message, tag, level):
        if level == Qgis.Critical:
            errors.append(f"{tag}: {message}")

    QgsApplication.messageLog().messageReceived.connect(logged)
    try:
        dialog.runAlgorithm()
    finally:
        QgsApplication.messageLog().messageReceived.disconnect(logged)
    outputs = [out_dir / f"batch_{field}.gpkg" for field, _ in rows]
    report = {
        field: layer_report(p) for (field, _), p in zip(rows, outputs, strict=True)
    }
    report["errors"] = errors
    return report


def main():
    points, out_dir = Path(sys.argv[1]), Path(sys.argv[2])
    report = {}
    keys = ["state", "region"]
    feedback = Feedback()
    result = processing.run(
        ALG,
        {"INPUT": str(points), "FIELD": keys, "OUTPUT": str(out_dir / "by2.gpkg")},
        feedback=feedback,
    )
    report["by2"] = {
        "result": str(result["OUTPUT"]),
        "warnings": feedback.warnings,
        "infos": feedback.infos,
        "progress": feedback.progress,
        "layer": layer_report(out_dir / "by2.gpkg"),
        "input_fields": layer_report(points)["fields"],
        "join": misses(points, out_dir / "by2.gpkg", keys),
    }
    # Why this shape (issue #35): the optional WHY and LEFT_OUT layers.
    feedback = Feedback()
    result = processing.run(
        ALG,
        {
            "INPUT": str(points),
            "FIELD": ["state"],
            "OUTLIERS": 1,
            "OUTLIER_UNIT": "locations",
            "OUTPUT": str(out_dir / "why_hulls.gpkg"),
            "WHY": str(out_dir / "why.gpkg"),
            "LEFT_OUT": str(out_dir / "left_out.gpkg"),
        },
        feedback=feedback,
    )
    report["why"] = {
        "outputs": sorted(result),
        "hulls": layer_report(out_dir / "why_hulls.gpkg"),
        "why": layer_report(out_dir / "why.gpkg"),
        "left_out": layer_report(out_dir / "left_out.gpkg"),
        "warnings": feedback.warnings,
    }
    try:
        processing.run(
            ALG,
            {
                "INPUT": str(points),
                "METHOD": "convex",
                "OUTPUT": "memory:",
                "WHY": "memory:",
            },
        )
        report["why"]["convex"] = None
    except Exception as err:
        report["why"]["convex"] = str(err)
    # Every option passed through.
    for name, options in (
        ("holes", {"HOLES": True, "COMPONENTS": 3, "DEGENERATE": "empty"}),
        ("concave", {"METHOD": "concave", "DEGENERATE": "drop"}),
    ):
        target = out_dir / f"{name}.gpkg"
        processing.run(
            ALG,
            {
                "INPUT": str(points),
                "FIELD": ["state"],
                "OUTPUT": str(target),
                **options,
            },
        )
        report[name] = layer_report(target)
    # A memory layer output (the toolbox's default "temporary layer").
    memory = processing.run(ALG, {"INPUT": str(points), "OUTPUT": "memory:"})
    layer = memory["OUTPUT"]
    report["memory"] = {
        "count": layer.featureCount(),
        "fields": [f.name() for f in layer.fields()],
    }
    # Cancelled once reading is under way: no output, a clean stop.
    feedback = Feedback(cancel_at=0)
    try:
        result = processing.run(
            ALG,
            {"INPUT": str(points), "OUTPUT": str(out_dir / "cancel.gpkg")},
            feedback=feedback,
        )
        report["cancel"] = {"result": {k: str(v) for k, v in result.items()}}
    except Exception as err:  # processing.run raises when the run gives nothing
        report["cancel"] = {"error": str(err)}
    report["cancel"]["written"] = (out_dir / "cancel.gpkg").exists()
    report["cancel"]["progress"] = feedback.progress
    report["model"] = model(points, out_dir / "model.gpkg")
    report["model"]["layer"] = layer_report(out_dir / "model.gpkg")
    report["batch"] = batch(points, out_dir)
    # Bad input: an error in the log, not a traceback.
    try:
        processing.run(
            ALG,
            {
                "INPUT": str(points),
                "FIELD": ["name"],
                "COMPONENTS": 0,
                "OUTPUT": "memory:",
            },
        )
        report["bad"] = None
    except Exception as err:
        report["bad"] = str(err)
    print("JSON:" + json.dumps(report))


if __name__ == "__main__":
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    app = QgsApplication([], True)  # widgets for the batch dialog
    app.initQgis()
    sys.path.insert(0, "/usr/share/qgis/python/plugins")
    import processing
    from processing.core.Processing import Processing
    from qgis.core import NULL

    Processing.initialize()
    for folder in os.environ.get("QGIS_PLUGINPATH", "").split(os.pathsep):
        if folder:
            sys.path.insert(0, folder)
    import geoalpha_qgis

    plugin = geoalpha_qgis.classFactory(None)
    plugin.initProcessing()
    main()
    plugin.unload()
    # exitQgis() of a GUI application can hang at exit (seen with a fresh
    # QGIS_CUSTOM_CONFIG_PATH offscreen); the report is out, so leave now.
    sys.stdout.flush()
    os._exit(0)
