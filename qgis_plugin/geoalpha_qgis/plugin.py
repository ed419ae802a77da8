"""The plugin object: registers the Processing provider with QGIS."""

from __future__ import annotations

from qgis.core import QgsApplication

from .provider import GeoAlphaProvider


class GeoAlphaPlugin:
    """Adds the "geoalpha" Processing provider (GUI, modeler, batch, qgis_process)."""

    def __init__(self, iface=None):
        self.iface = iface
        self.provider: GeoAlphaProvider | None = None

    def initProcessing(self):
        """Register the provider; qgis_process calls only this."""
        if self.provider is None:
            self.provider = GeoAlphaProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):
        """Register the provider when QGIS starts with a GUI."""
        self.initProcessing()

    def unload(self):
        """Remove the provider when the plugin is disabled or reloaded."""
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
