"""Output folders the commands write into: checked before any work, so a bad ``--out`` costs nothing."""

from __future__ import annotations

from pathlib import Path


def check_out_folder(option: str, folder: str | Path) -> Path:
    """``folder`` as a Path if it is a folder or can be made one; ValueError naming ``option`` when it, or the
    nearest of its parents that exists, is a file (``mkdir`` would fail after the computation otherwise)."""
    path = Path(folder)
    for p in (path, *path.parents):
        if p.exists():
            if not p.is_dir():
                what = "is a file" if p == path else f"lies under {p}, a file"
                raise ValueError(f"{option} {path}: {what}, not a folder; give a folder")
            return path
    return path
