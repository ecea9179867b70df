"""Folders of still frames: png/jpg/tif, sorted by name, read and written with OpenCV.

Images are returned in RGB(A) order with their own bit depth; writing keeps the name
and format of the input frame and is atomic (temporary name, then rename).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import cv2
import numpy as np

from ..errors import InputError, OutputError

__all__ = ["IMAGE_SUFFIXES", "list_frames", "read_image", "write_image"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


def _natural_key(path: Path) -> list[str | int]:
    """Sort key of a name with its runs of digits as numbers (``a9`` < ``a10``)."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.name)]


def list_frames(folder: str | os.PathLike) -> list[Path]:
    """Return the image files of ``folder`` in natural order of their names.

    Runs of digits compare as numbers: ``frame-99`` comes before ``frame-100``.

    Raises
    ------
    InputError
        If the folder holds no image.
    """
    folder = Path(folder)
    files = sorted((p for p in folder.iterdir()
                    if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES
                    and not p.name.startswith(".")), key=_natural_key)
    if not files:
        raise InputError(f"{folder}: no images ({', '.join(IMAGE_SUFFIXES)}) in this folder")
    return files


def read_image(path: str | os.PathLike) -> np.ndarray:
    """Read an image as RGB, RGBA or grey, keeping its bit depth.

    Raises
    ------
    InputError
        If the file cannot be decoded.
    """
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(f"{path}: not a readable image")
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    elif img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA)
    return img


def rgb8(img: np.ndarray) -> np.ndarray:
    """Return an 8-bit RGB copy of a grey, RGB or RGBA image of any integer depth."""
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    if img.dtype != np.uint8:
        img = (img.astype(np.float64) * 255.0 / np.iinfo(img.dtype).max).astype(np.uint8)
    return np.ascontiguousarray(img[..., :3])


def write_image(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an RGB(A)/grey image atomically; the format follows the file suffix."""
    path = Path(path)
    img = image
    if img.ndim == 3 and img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
    elif img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_RGBA2BGRA)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")
    try:
        ok = cv2.imwrite(str(tmp), img)
        if not ok:
            raise OutputError(f"{path}: cannot write image")
        os.replace(tmp, path)
    except cv2.error as exc:
        raise OutputError(f"{path}: cannot write image ({exc})") from None
    finally:
        if tmp.exists():
            tmp.unlink()
