"""Rebuild unjello's camera table from the Gyroflow lens profiles (CC0).

Reads ``../shared/data/lens_profiles/gyroflow_lens_profiles.jsonl.gz`` (all 9,810
profiles of the Gyroflow ``lens_profiles`` repository, one JSON object a line, the profile
under ``profile``) and writes ``src/unjello/data/cameras.json.gz``: one row per camera
mode -- brand, model, lens or setting, calibrated width and height, frame rate -- with

- ``profiles``: how many profiles describe that mode;
- ``readout_ms``: the median of the non-zero ``frame_readout_time`` values its profiles
  state (negative: the other scan direction), ``readout_n`` how many state one and
  ``readout_agree`` how many of those lie within 5 % of the median (the profiles are
  user-contributed: the HERO5 Black's 2.7K 30 fps profiles say 26.7 and 33.4 ms);
- ``fx``, ``fy``, ``cx``, ``cy``, ``k``: the median camera matrix and fisheye distortion
  (OpenCV's four coefficients) at that width and height.

Usage::

    python scripts/camera_table.py [SOURCE] [-o src/unjello/data/cameras.json.gz]
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "data" / "lens_profiles" / "gyroflow_lens_profiles.jsonl.gz"
OUT = ROOT / "src" / "unjello" / "data" / "cameras.json.gz"
COLUMNS = ["brand", "model", "mode", "w", "h", "fps", "profiles", "readout_ms", "readout_n",
           "readout_agree", "fx", "fy", "cx", "cy", "k"]


def _text(value: object) -> str:
    return " ".join(str(value or "").split())


def build(source: Path) -> dict:
    """Return the table (a JSON document) built from the profiles in ``source``."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for line in gzip.open(source, "rt", encoding="utf-8"):
        prof = json.loads(line).get("profile") or {}
        dim = prof.get("calib_dimension") or {}
        fisheye = prof.get("fisheye_params") or {}
        brand, model = _text(prof.get("camera_brand")), _text(prof.get("camera_model"))
        if not brand or not model or not dim.get("w") or not dim.get("h"):
            continue
        mode = " ".join(x for x in (_text(prof.get("lens_model")),
                                    _text(prof.get("camera_setting"))) if x)
        fps = round(float(prof.get("fps") or 0.0), 2)
        groups[(brand, model, mode, int(dim["w"]), int(dim["h"]), fps)].append(
            {"readout": prof.get("frame_readout_time"), "matrix": fisheye.get("camera_matrix"),
             "k": fisheye.get("distortion_coeffs")})
    rows = []
    for key in sorted(groups, key=lambda k: (k[0].lower(), k[1].lower(), k[2].lower(), k[3:])):
        items = groups[key]
        stated = np.array([float(i["readout"]) for i in items
                           if isinstance(i["readout"], (int, float)) and i["readout"]])
        readout = float(np.median(stated)) if stated.size else None
        agree = int(np.sum(np.abs(stated - readout) <= 0.05 * abs(readout))) if stated.size \
            else 0
        mats = [np.asarray(i["matrix"], float) for i in items
                if isinstance(i["matrix"], list) and np.shape(i["matrix"]) == (3, 3)]
        ks = [np.asarray(i["k"], float) for i in items
              if isinstance(i["k"], list) and len(i["k"]) == 4]
        m = np.median(mats, axis=0) if mats else None
        rows.append([*key, len(items), None if readout is None else round(readout, 4),
                     int(stated.size), agree,
                     *((round(float(m[0, 0]), 2), round(float(m[1, 1]), 2),
                        round(float(m[0, 2]), 2), round(float(m[1, 2]), 2)) if m is not None
                       else (None,) * 4),
                     [round(float(v), 6) for v in np.median(ks, axis=0)] if ks else None])
    digest = hashlib.sha256(source.read_bytes()).hexdigest()
    return {"schema": "unjello.cameras", "version": 1,
            "source": "Gyroflow lens profiles (github.com/gyroflow/lens_profiles), all "
                      "profiles as collected in gyroflow_lens_profiles.jsonl.gz",
            "source_sha256": digest, "licence": "CC0-1.0 (the profiles are public domain)",
            "columns": COLUMNS, "rows": rows}


def main() -> None:
    """Build the table and write it atomically, byte for byte the same for the same input."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", nargs="?", type=Path, default=SOURCE)
    ap.add_argument("-o", "--output", type=Path, default=OUT)
    args = ap.parse_args()
    if not args.source.is_file():
        raise SystemExit(f"{args.source}: not found (the shared data lives beside the repo)")
    table = build(args.source)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.output.with_name(args.output.name + ".tmp")
    with gzip.GzipFile(tmp, "wb", mtime=0) as f:  # mtime 0: the same input, the same bytes
        f.write(json.dumps(table, separators=(",", ":")).encode())
    tmp.replace(args.output)
    n_read = sum(1 for r in table["rows"] if r[7] is not None)
    print(f"wrote {args.output}: {len(table['rows'])} camera modes, {n_read} with a readout, "
          f"{args.output.stat().st_size / 1024:.0f} KiB")


if __name__ == "__main__":
    main()
