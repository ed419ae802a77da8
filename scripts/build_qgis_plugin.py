"""Build the installable ZIP of the geoalpha QGIS plugin.

``python scripts/build_qgis_plugin.py`` writes ``dist/geoalpha_qgis-VERSION.zip``
(VERSION from ``qgis_plugin/geoalpha_qgis/metadata.txt``), ready for QGIS's
*Plugins > Manage and Install Plugins... > Install from ZIP*. The archive holds
one folder, ``geoalpha_qgis/``, with the plugin and the repository's LICENSE;
entries are sorted and dated 1980-01-01, so the same sources give the same
bytes. Only the standard library is used.
"""

from __future__ import annotations

import argparse
import configparser
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "qgis_plugin" / "geoalpha_qgis"


def plugin_files() -> list[Path]:
    """Return the plugin's files (no caches, no compiled Python), sorted."""
    return sorted(
        p
        for p in PLUGIN.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"
    )


def version() -> str:
    """Return the plugin version from metadata.txt."""
    meta = configparser.ConfigParser()
    meta.read(PLUGIN / "metadata.txt", encoding="utf-8")
    return meta["general"]["version"]


def build(out_dir: Path) -> Path:
    """Write the ZIP into ``out_dir`` and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"{PLUGIN.name}-{version()}.zip"
    entries = [(p, p.relative_to(PLUGIN.parent).as_posix()) for p in plugin_files()]
    entries.append((ROOT / "LICENSE", f"{PLUGIN.name}/LICENSE"))
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        for path, name in sorted(entries, key=lambda e: e[1]):
            info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, path.read_bytes())
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "dist", help="folder")
    args = parser.parse_args(argv)
    target = build(args.out)
    print(f"Wrote {target} ({target.stat().st_size:,} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
