"""The "geoalpha" Processing provider."""

from __future__ import annotations

from qgis.core import QgsProcessingProvider

from .algorithm import OptimalAlphaHulls


class GeoAlphaProvider(QgsProcessingProvider):
    """Processing provider ``geoalpha``: optimal alpha hulls by group."""

    def id(self):
        """Return the provider id, the prefix of algorithm ids (``geoalpha:...``)."""
        return "geoalpha"

    def name(self):
        """Name shown in the Processing toolbox."""
        return "geoalpha"

    def longName(self):
        """Name with a short description."""
        return "geoalpha: optimal alpha shapes"

    def loadAlgorithms(self):
        """Add the provider's algorithms."""
        self.addAlgorithm(OptimalAlphaHulls())
