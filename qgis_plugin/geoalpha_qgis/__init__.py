"""geoalpha QGIS plugin: a Processing provider with the "Optimal alpha hulls" algorithm.

The plugin folder is ``geoalpha_qgis``, not ``geoalpha``: QGIS puts the
plugins folder on ``sys.path``, so a plugin called ``geoalpha`` would hide the
geoalpha library it runs.
"""


def classFactory(iface):
    """Return the plugin object QGIS loads (also without a GUI, in qgis_process)."""
    from .plugin import GeoAlphaPlugin

    return GeoAlphaPlugin(iface)
