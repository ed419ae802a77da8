"""Install geoalpha for QGIS's own Python, keeping QGIS's numpy.

Run this file with the Python interpreter QGIS uses (not another one):

- Linux (Debian, Ubuntu, Fedora): ``/usr/bin/python3 install_geoalpha.py``
- Windows: in the *OSGeo4W Shell* (Start menu, next to QGIS):
  ``python install_geoalpha.py``
- macOS: ``/Applications/QGIS-LTR.app/Contents/MacOS/bin/python3 install_geoalpha.py``
  (``QGIS.app`` for the latest release)

It creates a virtual environment that sees QGIS's packages
(``--system-site-packages``, default ``~/.geoalpha-qgis``; another folder with
``--env`` or the ``GEOALPHA_QGIS_ENV`` environment variable, which QGIS must
then see too) and pip-installs geoalpha there with a constraint file that pins
numpy, scipy, pandas, pyproj, fiona, GDAL and matplotlib to the versions QGIS's
Python already has. pip then installs only what is missing (shapely 2,
geopandas, ...) and never a second numpy, which would break QGIS's GDAL tools
("numpy.core.multiarray failed to import").

On Linux, shapely's wheel carries its own GEOS library, but inside QGIS the
GEOS functions resolve to the GEOS QGIS already loaded (ELF symbols are
global; Windows and macOS keep them apart). So shapely must be built for the
same GEOS: with QGIS's GEOS 3.11 (Debian 12, Ubuntu 24.04) the installer
asks for shapely 2.0.x (wheels with GEOS 3.11), from GEOS 3.13 on any
shapely 2.1+ wheel; with another GEOS it builds shapely from source against
QGIS's GEOS (``--no-binary shapely``: needs the GEOS headers and a C
compiler, e.g. ``apt install libgeos-dev build-essential``).

The geoalpha QGIS plugin adds that
environment to QGIS's Python when it loads. Nothing outside the folder is
changed; delete the folder to uninstall.

Only the standard library is used here, so the file also runs before
geoalpha is installed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

#: Packages that QGIS's Python may already have and that must stay as they
#: are: compiled against QGIS's numpy, or linking QGIS's GDAL/PROJ libraries.
PINNED = ("numpy", "scipy", "pandas", "pyproj", "fiona", "GDAL", "matplotlib")
DEFAULT_ENV = Path.home() / ".geoalpha-qgis"


def constraints(unpin: tuple[str, ...] = ()) -> list[str]:
    """Return ``name==version`` lines for the installed packages of ``PINNED``."""
    lines = []
    for name in PINNED:
        if name.lower() in {u.lower() for u in unpin}:
            continue
        try:
            lines.append(f"{name}=={metadata.version(name)}")
        except metadata.PackageNotFoundError:
            continue
    return lines


def qgis_geos() -> tuple[int, int] | None:
    """Return QGIS's GEOS (major, minor), or None outside QGIS's Python."""
    try:
        from qgis.core import Qgis
    except ImportError:
        return None
    major, minor = Qgis.geosVersion().split(".")[:2]
    return int(major), int(minor)


def shapely_pin(geos: tuple[int, int] | None) -> tuple[list[str], list[str]]:
    """Return constraint lines and pip options that match shapely to QGIS's GEOS."""
    if geos is None or not sys.platform.startswith("linux"):
        return [], []
    if geos == (3, 11):
        return ["shapely>=2.0,<2.1"], []
    if geos >= (3, 13):
        return [], []
    return [], ["--no-binary", "shapely"]


def env_python(env: Path) -> Path:
    """Return the interpreter of the virtual environment ``env``."""
    if os.name == "nt":
        return env / "Scripts" / "python.exe"
    return env / "bin" / "python"


def main(argv: list[str] | None = None) -> int:
    """Create the environment and pip-install geoalpha into it."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "spec",
        nargs="*",
        default=["geoalpha"],
        help="what to pip-install (default: geoalpha; a source folder works too)",
    )
    parser.add_argument(
        "--env",
        type=Path,
        default=Path(os.environ.get("GEOALPHA_QGIS_ENV") or DEFAULT_ENV),
        help=f"environment folder (default: $GEOALPHA_QGIS_ENV or {DEFAULT_ENV})",
    )
    parser.add_argument(
        "--unpin",
        action="append",
        default=[],
        metavar="NAME",
        help="let pip install its own NAME (e.g. fiona when QGIS's is older than "
        "geoalpha needs); the pip copy then shadows QGIS's inside QGIS",
    )
    parser.add_argument(
        "--dry-run", action="store_true", help="print the commands, run nothing"
    )
    args = parser.parse_args(argv)
    try:
        import numpy  # noqa: F401
    except ImportError:
        print(
            f"{sys.executable} has no numpy: this is not QGIS's Python. Run this "
            "file with the Python QGIS uses (see its first lines).",
            file=sys.stderr,
        )
        return 1
    pins = constraints(tuple(args.unpin))
    print(f"QGIS's Python: {sys.executable} ({sys.version.split()[0]})")
    print("Kept as installed: " + ", ".join(pins))
    geos = qgis_geos()
    if geos is None:
        print("Warning: qgis cannot be imported here; is this QGIS's Python?")
    shapely_lines, pip_options = shapely_pin(geos)
    pins += shapely_lines
    if geos is not None and (shapely_lines or pip_options):
        how = shapely_lines[0] if shapely_lines else "shapely built from source"
        print(f"QGIS's GEOS is {geos[0]}.{geos[1]}: {how}")
    python = env_python(args.env)
    create = [sys.executable, "-m", "venv", "--system-site-packages", str(args.env)]
    with tempfile.TemporaryDirectory() as tmp:
        constraint_file = Path(tmp) / "qgis-constraints.txt"
        constraint_file.write_text("\n".join(pins) + "\n", encoding="utf-8")
        install = [str(python), "-m", "pip", "install", "--upgrade"]
        install += [*pip_options, "-c", str(constraint_file), *args.spec]
        for command in ([] if python.exists() else [create]) + [install]:
            print("$ " + " ".join(command), flush=True)
            if not args.dry_run and subprocess.call(command) != 0:
                print(
                    "Failed; nothing in QGIS was changed. If pip found the pinned "
                    "versions too old for geoalpha, see --unpin.",
                    file=sys.stderr,
                )
                return 1
    if args.dry_run:
        print("Dry run: nothing was installed.")
        return 0
    print(
        f"Installed into {args.env}. Restart QGIS; the geoalpha plugin finds it "
        "there" + ("" if args.env == DEFAULT_ENV else " through GEOALPHA_QGIS_ENV")
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
