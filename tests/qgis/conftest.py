"""pyqgis_driver.py runs in QGIS's own Python (a subprocess), never in pytest."""

collect_ignore = ["pyqgis_driver.py"]
