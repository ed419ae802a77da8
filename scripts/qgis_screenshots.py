"""Render the README's QGIS screenshots from real QGIS.

Run with QGIS's own Python, after ``install_geoalpha.py`` (README, "QGIS plugin"):

    xvfb-run -a /usr/bin/python3 scripts/qgis_screenshots.py

(``QT_QPA_PLATFORM=offscreen`` works too, with plainer widgets). It loads the
plugin from ``qgis_plugin/`` as QGIS does, opens the Processing dialog of
"Optimal alpha hulls" on the bundled US airports (western states, grouped by
``state``) and saves it to ``docs/qgis_dialog.png``; then runs the algorithm
and renders the hulls, coloured by state, under the airports with QGIS's map
renderer to ``docs/qgis_map.png``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from qgis.core import (
    QgsApplication,
    QgsCategorizedSymbolRenderer,
    QgsCoordinateReferenceSystem,
    QgsCoordinateTransform,
    QgsMapRendererParallelJob,
    QgsMapSettings,
    QgsMarkerSymbol,
    QgsPalLayerSettings,
    QgsProject,
    QgsRendererCategory,
    QgsSymbol,
    QgsTextFormat,
    QgsVectorLayer,
    QgsVectorLayerSimpleLabeling,
)
from qgis.PyQt.QtCore import QSize, Qt
from qgis.PyQt.QtGui import QColor, QFont, QImage

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
ALG = "geoalpha:optimalalphahulls"
STATES = ("WA", "OR", "CA", "NV", "ID", "MT", "WY", "UT", "AZ", "CO", "NM")
# Colour-blind-safe qualitative colours (Okabe-Ito and Tol), one per state.
COLOURS = (
    "#E69F00 #56B4E9 #009E73 #F0E442 #0072B2 #D55E00 #CC79A7 #999933 #44AA99 "
    "#882255 #88CCEE"
).split()


def save_small(image: QImage, path: Path) -> None:
    """Save as an 8-bit palette PNG (a few dozen kB)."""
    image.convertToFormat(QImage.Format_Indexed8, Qt.ThresholdDither).save(str(path))
    print(f"Wrote {path} ({path.stat().st_size:,} bytes)")


def airports() -> QgsVectorLayer:
    """Return the bundled airports CSV of the western states as a point layer."""
    from geoalpha import datasets

    uri = (
        f"{datasets.path('us_airports').as_uri()}?delimiter=,&xField=longitude"
        "&yField=latitude&crs=EPSG:4326&detectTypes=yes"
    )
    layer = QgsVectorLayer(uri, "US airports", "delimitedtext")
    layer.setSubsetString(f'"state" IN ({", ".join(map(repr, STATES))})')
    if not layer.isValid() or layer.featureCount() == 0:
        raise SystemExit(f"cannot read the airports ({uri})")
    return layer


def dialog_png(layer: QgsVectorLayer, path: Path) -> None:
    """Open the algorithm's Processing dialog, filled in, and save a picture."""
    from processing.gui.AlgorithmDialog import AlgorithmDialog

    algorithm = QgsApplication.processingRegistry().createAlgorithmById(ALG)
    dialog = AlgorithmDialog(algorithm)
    dialog.setParameters({"INPUT": layer, "FIELD": ["state"]})
    dialog.resize(860, 600)
    dialog.show()
    for _ in range(20):
        QgsApplication.processEvents()
    save_small(dialog.grab().toImage(), path)
    dialog.close()


def map_png(points: QgsVectorLayer, path: Path) -> None:
    """Run the algorithm and render hulls by state under the points."""
    import processing

    hulls = processing.run(
        ALG, {"INPUT": points, "FIELD": ["state"], "OUTPUT": "memory:"}
    )["OUTPUT"]
    categories = []
    for colour, state in zip(COLOURS, STATES, strict=True):
        symbol = QgsSymbol.defaultSymbol(hulls.geometryType())
        symbol.setColor(QColor(colour))
        symbol.setOpacity(0.6)
        symbol.symbolLayer(0).setStrokeColor(QColor("#333333"))
        categories.append(QgsRendererCategory(state, symbol, state))
    hulls.setRenderer(QgsCategorizedSymbolRenderer("state", categories))
    label = QgsPalLayerSettings()
    label.fieldName = "state"
    text = QgsTextFormat()
    text.setFont(QFont("DejaVu Sans", 10, QFont.Bold))
    text.setSize(10)
    text.buffer().setEnabled(True)
    label.setFormat(text)
    hulls.setLabeling(QgsVectorLayerSimpleLabeling(label))
    hulls.setLabelsEnabled(True)
    points.setRenderer(
        points.renderer().__class__(
            QgsMarkerSymbol.createSimple(
                {
                    "name": "circle",
                    "size": "1.1",
                    "color": "black",
                    "outline_style": "no",
                }
            )
        )
    )
    settings = QgsMapSettings()
    albers = QgsCoordinateReferenceSystem("EPSG:5070")  # CONUS Albers, metres
    settings.setDestinationCrs(albers)
    settings.setLayers([points, hulls])
    extent = QgsCoordinateTransform(
        hulls.crs(), albers, QgsProject.instance()
    ).transformBoundingBox(hulls.extent())
    extent.scale(1.05)
    settings.setExtent(extent)
    settings.setOutputSize(QSize(600, 640))
    settings.setBackgroundColor(QColor("white"))
    job = QgsMapRendererParallelJob(settings)
    job.start()
    job.waitForFinished()
    save_small(job.renderedImage(), path)


def main() -> None:
    """Render both pictures into docs/."""
    app = QgsApplication([], True)
    app.initQgis()
    sys.path.insert(0, os.path.join(app.pkgDataPath(), "python", "plugins"))
    from processing.core.Processing import Processing

    Processing.initialize()
    sys.path.insert(0, str(ROOT / "qgis_plugin"))
    import geoalpha_qgis
    from geoalpha_qgis import dependencies

    dependencies.load()  # geoalpha from its environment, as the plugin finds it
    plugin = geoalpha_qgis.classFactory(None)
    plugin.initProcessing()
    points = airports()
    QgsProject.instance().addMapLayer(points)
    dialog_png(points, DOCS / "qgis_dialog.png")
    map_png(points, DOCS / "qgis_map.png")
    plugin.unload()
    app.exitQgis()


if __name__ == "__main__":
    main()
