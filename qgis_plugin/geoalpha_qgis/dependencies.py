"""Find the geoalpha library for QGIS's Python, or say how to install it.

``install_geoalpha.py`` (in this folder) installs geoalpha into a virtual
environment on top of QGIS's Python (default ``~/.geoalpha-qgis``, or the
folder named by the ``GEOALPHA_QGIS_ENV`` environment variable). This module
puts that environment's ``site-packages`` on ``sys.path`` before QGIS's own
packages folder, so that the packages pip added there (shapely 2, geopandas)
win over older system copies, while numpy and everything else pinned by the
installer come from QGIS's Python.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ENV_VAR = "GEOALPHA_QGIS_ENV"
HERE = Path(__file__).resolve().parent
INSTALLER = HERE / "install_geoalpha.py"


class MissingGeoalpha(ImportError):
    """geoalpha (or one of its dependencies) cannot be imported in QGIS's Python."""


def env_dir() -> Path:
    """Return the folder of the geoalpha environment for QGIS."""
    return Path(os.environ.get(ENV_VAR) or Path.home() / ".geoalpha-qgis")


def site_packages(env: Path) -> Path:
    """Return the ``site-packages`` folder of the virtual environment ``env``."""
    if os.name == "nt":
        return env / "Lib" / "site-packages"
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    return env / "lib" / version / "site-packages"


def add_env_to_path() -> Path | None:
    """Put the environment's ``site-packages`` on ``sys.path``; return it if found."""
    folder = site_packages(env_dir())
    if not folder.is_dir():
        return None
    entry = str(folder)
    if entry not in sys.path:
        # Before the first packages folder: after PYTHONPATH and the standard
        # library, ahead of QGIS's (possibly older) shapely or geopandas.
        position = next(
            (
                i
                for i, p in enumerate(sys.path)
                if p.rstrip("/\\").endswith(("site-packages", "dist-packages"))
            ),
            len(sys.path),
        )
        sys.path.insert(position, entry)
    return folder


def clone_folder(here: Path = HERE) -> Path | None:
    """Return the geoalpha clone this plugin folder lies in (a symlink followed).

    Examples
    --------
    >>> clone_folder(Path("/nowhere/qgis_plugin/geoalpha_qgis")) is None
    True
    """
    root = here.parent.parent
    try:
        text = (root / "pyproject.toml").read_text(encoding="utf-8")
    except OSError:
        return None
    return root if 'name = "geoalpha"' in text else None


def install_message(error: BaseException | None = None, *, here: Path = HERE) -> str:
    """Say that geoalpha is missing and how to install it on each platform.

    The commands name what to install from: this plugin's own clone when it
    lies in one, else ``WHEEL``, explained below them (a downloaded wheel, or a
    clone's folder).
    """
    numpy_version = sys.modules["numpy"].__version__ if "numpy" in sys.modules else "?"
    clone, installer = clone_folder(here), here / INSTALLER.name
    what = f'"{clone}"' if clone is not None else "WHEEL"
    lines = [
        "The geoalpha Python library is not installed for QGIS's Python "
        f"(Python {sys.version.split()[0]}, numpy {numpy_version}; looked in "
        f"{site_packages(env_dir())}).",
        "Install it with the script in this plugin's folder, run by QGIS's own "
        "Python (it keeps QGIS's numpy), then restart QGIS:",
        f'  Linux:   /usr/bin/python3 "{installer}" {what}',
        f'  Windows: in the OSGeo4W Shell: python "{installer}" {what}',
        "  macOS:   /Applications/QGIS-LTR.app/Contents/MacOS/bin/python3 "
        f'"{installer}" {what}  (QGIS.app for the latest release)',
    ]
    if clone is not None:
        lines.append(
            f"({clone} is the geoalpha clone this plugin comes from: building it "
            "needs Rust >= 1.88; a downloaded wheel file in its place needs none.)"
        )
    else:
        lines.append(
            "WHEEL: the geoalpha wheel for your platform, downloaded from the "
            "release (geoalpha-<version>-cp310-abi3-<platform>.whl; needs no "
            "Rust), or the folder of a geoalpha clone (needs Rust >= 1.88)."
        )
    lines += [
        "Do not pip-install geoalpha into QGIS's Python without it: a second "
        "numpy breaks QGIS's GDAL tools.",
    ]
    if error is not None:
        lines.append(f"({type(error).__name__}: {error})")
    return "\n".join(lines)


def geos_mismatch(
    shapely_geos: tuple[int, ...], qgis_geos: str, platform: str = sys.platform
) -> str | None:
    """Say why shapely's GEOS may misbehave inside QGIS, or return None.

    On Linux, the GEOS functions a shapely wheel calls resolve to the GEOS
    QGIS has loaded; a shapely built for a newer GEOS than QGIS's then calls
    functions that are missing or behave differently there.

    Examples
    --------
    >>> geos_mismatch((3, 13, 1), "3.11.1-CAPI-1.17.1", "linux")[:36]
    'shapely was built for GEOS 3.13, but'
    >>> geos_mismatch((3, 11, 4), "3.11.1-CAPI-1.17.1", "linux") is None
    True
    >>> geos_mismatch((3, 13, 1), "3.11.1-CAPI-1.17.1", "win32") is None
    True
    """
    if not platform.startswith("linux"):
        return None
    qgis = tuple(int(part) for part in qgis_geos.split("-")[0].split(".")[:2])
    if tuple(shapely_geos[:2]) <= qgis:
        return None
    return (
        f"shapely was built for GEOS {shapely_geos[0]}.{shapely_geos[1]}, but "
        f"QGIS runs GEOS {qgis[0]}.{qgis[1]}, whose functions shapely calls here; "
        f"reinstall with {INSTALLER}, which picks a matching shapely"
    )


def load():
    """Import and return the geoalpha library, or raise :class:`MissingGeoalpha`."""
    add_env_to_path()
    try:
        import geopandas  # noqa: F401 - hull() needs it; say so now, not midway

        import geoalpha
    except ImportError as err:
        raise MissingGeoalpha(install_message(err)) from err
    if not hasattr(geoalpha, "hull"):  # another module called geoalpha
        raise MissingGeoalpha(
            install_message(ImportError(f"{geoalpha.__file__} has no hull()"))
        )
    return geoalpha
