"""Build the installable ZIP of the geoalpha QGIS plugin.

``python scripts/build_qgis_plugin.py`` writes ``dist/geoalpha_qgis-VERSION.zip``
(VERSION from ``qgis_plugin/geoalpha_qgis/metadata.txt``), ready for QGIS's
*Plugins > Manage and Install Plugins... > Install from ZIP*. The archive holds
one folder, ``geoalpha_qgis/``, with the plugin and the repository's LICENSE;
entries are sorted and dated 1980-01-01, so the same sources give the same
bytes. The ZIP itself needs only the standard library.

Before zipping, :func:`write_options` (re)writes the plugin's
``hull_options.json``, the options of ``geoalpha.hull()`` as the plugin offers
them, from :class:`geoalpha._options.Options` (the one definition: defaults,
choices, bounds, help), and the result columns of :mod:`geoalpha._frame.schema`; it
imports this checkout's geoalpha (with numpy and pandas). The file is
committed, so that the plugin works from a checkout; ``tests/test_qgis_plugin.py``
checks it is up to date.
"""

from __future__ import annotations

import argparse
import configparser
import json
import re
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "qgis_plugin" / "geoalpha_qgis"
OPTIONS_FILE = PLUGIN / "hull_options.json"
#: Options of hull() the plugin does not offer, and why (said in its help and
#: docs). Every other option becomes the Processing parameter of its name in
#: capitals; tests/test_qgis_plugin.py checks that the two cover Options.
LEFT_OUT = {
    "progress": "QGIS shows the progress of the algorithm itself",
    "n_jobs": "the compiled kernel already spreads the groups over every core, "
    "in threads of the QGIS process",
}
#: Command-line words in the help texts of Options that are not an option.
_WORDS = {"--by": "FIELD"}
#: Command-line sentences said otherwise in QGIS.
_PHRASES = {
    "for input without a CRS the same as --crs-in none": "the only choice for a "
    "layer without a CRS, whose output then has area and unit instead of area_m2",
}


def _qgis_terms(text: str, flags: dict[str, tuple[str, tuple]]) -> str:
    """Say ``--method concave`` as ``METHOD=concave``, ``--ratio`` as ``RATIO``."""

    def term(match: re.Match) -> str:
        flag, word = match.group(1), match.group(2)
        if flag in _WORDS:
            return _WORDS[flag] + (f" {word}" if word else "")
        name, choices = flags.get(flag, (flag, ()))
        if word and word in choices:
            return f"{name}={word}"
        return name + (f" {word}" if word else "")

    for phrase, qgis in _PHRASES.items():
        text = text.replace(phrase, qgis)
    return re.sub(r"(--[a-z][a-z-]*)(?: ([a-z]+)\b)?", term, text)


def options_spec() -> dict:
    """Return the options of ``geoalpha.hull()`` the plugin offers, from ``Options``.

    Returns
    -------
    dict
        ``{"options": {name: {...}}, "left_out": LEFT_OUT, "result_columns":
        geoalpha._frame.schema.DTYPES}``; each option has its ``kind``, ``default``,
        ``choices``, ``low``, ``high``, ``low_open``, ``optional`` and
        ``help`` (the command's help text, with the flags said as the plugin's
        parameters: ``METHOD=concave``).
    """
    sys.path.insert(0, str(ROOT))
    try:
        from geoalpha._frame.schema import DTYPES  # needs numpy and pandas
        from geoalpha._options import FIELDS
    finally:
        sys.path.pop(0)
    flags = {}
    for field in FIELDS:
        meta = field.metadata["meta"]
        choices = meta.choices + (("none", "auto") if meta.kind == "crs" else ())
        for spelling in meta.flags:
            for flag in spelling.split("/"):
                flags[flag] = (field.name.upper(), choices)
    options = {}
    for field in FIELDS:
        if field.name in LEFT_OUT:
            continue
        meta = field.metadata["meta"]
        options[field.name] = {
            "kind": meta.kind,
            "default": field.default,
            "choices": list(meta.choices),
            "low": meta.low,
            "high": meta.high,
            "low_open": meta.low_open,
            "optional": meta.optional,
            "help": _qgis_terms(meta.help, flags),
        }
    return {"options": options, "left_out": LEFT_OUT, "result_columns": DTYPES}


def options_text() -> str:
    """Return the text of ``hull_options.json`` (see :func:`options_spec`)."""
    return json.dumps(options_spec(), indent=1, ensure_ascii=False) + "\n"


def write_options() -> Path:
    """Write ``hull_options.json`` into the plugin folder and return its path."""
    OPTIONS_FILE.write_text(options_text(), encoding="utf-8")
    return OPTIONS_FILE


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
    try:
        print(f"Wrote {write_options()}")
    except ImportError as err:  # geoalpha's dependencies missing: the ZIP still
        print(f"Kept {OPTIONS_FILE} as it is (cannot import geoalpha: {err})")
    target = build(args.out)
    print(f"Wrote {target} ({target.stat().st_size:,} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
