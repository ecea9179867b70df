"""The encoders editors use, each with its own options, containers and pixel formats.

libx264 and libx265 take a CRF and a speed preset; ProRes (``prores_ks``) and DNxHR
(``dnxhd``) take a profile, which decides their pixel format (ProRes 422 profiles 10-bit
4:2:2, 4444 10-bit 4:4:4; DNxHR LB/SQ/HQ 8-bit 4:2:2, HQX 10-bit 4:2:2, 444 10-bit 4:4:4);
FFV1 is lossless and keeps what it is given. The pair of codec and container is checked
before any frame is read (:func:`check_output`), and the output keeps the input's pixel
format where the codec has it (:func:`output_format`); otherwise the picture is converted
once, on the way into the encoder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..errors import SettingsError

__all__ = ["Codec", "CODECS", "check_output", "output_format", "encoder_options",
           "keeps_full_range"]

_MP4ISH = (".mp4", ".m4v", ".mov", ".mkv", ".nut", ".ts", ".m2ts", ".mts")


@dataclass(frozen=True)
class Codec:
    """What one encoder takes.

    Attributes
    ----------
    name : str
        FFmpeg's encoder name.
    containers : tuple of str
        File suffixes it may be written into.
    formats : tuple of str
        Pixel formats it encodes, the preferred first.
    profiles : dict
        Profile name -> (the encoder's ``profile`` value, its pixel format); empty for a
        codec without profiles.
    default_profile : str
        The profile used when none is given.
    crf : bool
        Takes ``crf`` and the x264/x265 speed ``preset``.
    full_range : bool
        Its files can say that the levels are full range (0-255); ProRes and DNxHR are
        read as limited range by editors, so full-range input is converted for them.
    """

    name: str
    containers: tuple[str, ...]
    formats: tuple[str, ...]
    profiles: dict[str, tuple[str, str]] = field(default_factory=dict)
    default_profile: str = ""
    crf: bool = False
    full_range: bool = True


_X = ("yuv420p", "yuv422p", "yuv444p", "yuv420p10le", "yuv422p10le", "yuv444p10le")

CODECS: dict[str, Codec] = {c.name: c for c in (
    Codec("libx264", _MP4ISH + (".avi",), _X, crf=True),
    Codec("libx265", _MP4ISH, _X, crf=True),
    Codec("prores_ks", (".mov", ".mkv", ".nut"), ("yuv422p10le", "yuv444p10le"), {
        "proxy": ("0", "yuv422p10le"), "lt": ("1", "yuv422p10le"),
        "standard": ("2", "yuv422p10le"), "hq": ("3", "yuv422p10le"),
        "4444": ("4", "yuv444p10le"), "4444xq": ("5", "yuv444p10le")}, "hq",
          full_range=False),
    Codec("dnxhd", (".mov", ".mxf", ".mkv", ".nut"), ("yuv422p", "yuv422p10le", "yuv444p10le"), {
        "dnxhr_lb": ("dnxhr_lb", "yuv422p"), "dnxhr_sq": ("dnxhr_sq", "yuv422p"),
        "dnxhr_hq": ("dnxhr_hq", "yuv422p"), "dnxhr_hqx": ("dnxhr_hqx", "yuv422p10le"),
        "dnxhr_444": ("dnxhr_444", "yuv444p10le")}, "dnxhr_hq", full_range=False),
    Codec("ffv1", (".mkv", ".avi", ".nut"), ("yuv420p", "yuv422p", "yuv444p", "yuv420p10le",
                                             "yuv422p10le", "yuv444p10le")),
    # Uncompressed frames: a pipe's default (NUT or y4m), read by the next program.
    Codec("rawvideo", (".nut", ".y4m", ".mkv", ".avi"), _X),
)}

#: The container a pipe's format stands for (its file suffix).
FORMAT_SUFFIX = {"nut": ".nut", "yuv4mpegpipe": ".y4m", "matroska": ".mkv", "mpegts": ".ts"}


def check_output(codec: str, profile: str | None, dst: Path, fmt: str | None = None) -> None:
    """Refuse a codec the container cannot hold, or a profile the codec does not have.

    Codecs this table does not know are left to FFmpeg (it says what is wrong when the
    stream is opened).

    Raises
    ------
    SettingsError
        One line saying what would work.
    """
    known = CODECS.get(codec)
    if known is None:
        if profile:
            raise SettingsError(f"profile= is for prores_ks and dnxhd, not {codec}")
        return
    suffix = FORMAT_SUFFIX.get(fmt or "", dst.suffix.lower())
    if fmt and fmt not in FORMAT_SUFFIX:
        raise SettingsError(f"format {fmt!r}: use one of {', '.join(FORMAT_SUFFIX)}")
    if suffix and suffix not in known.containers:
        said = f"the {fmt} format" if fmt else suffix
        raise SettingsError(f"{codec} cannot be written into {said} (use "
                            f"{', '.join(known.containers)})")
    if profile and not known.profiles:
        raise SettingsError(f"{codec} has no profiles (profile= is for prores_ks and dnxhd)")
    if profile and profile not in known.profiles:
        raise SettingsError(f"{codec} profile {profile!r}: use one of "
                            f"{', '.join(known.profiles)}")


def output_format(codec: str, profile: str | None, planes_format: str) -> str:
    """Return the pixel format the encoder is given: the input's where the codec has it.

    A profile's pixel format wins (ProRes 4444 is 4:4:4, DNxHR HQX 10-bit); a codec that
    cannot take the input's format gets its preferred one of the same bit depth if it has
    one.
    """
    known = CODECS.get(codec)
    if known is None:
        return planes_format
    if known.profiles:
        return known.profiles[profile or known.default_profile][1]
    if planes_format in known.formats:
        return planes_format
    deep = "10" in planes_format
    same = [f for f in known.formats if ("10" in f) == deep]
    return (same or list(known.formats))[0]


def keeps_full_range(codec: str) -> bool:
    """Whether ``codec`` may carry full-range levels as they are (else: limited range)."""
    known = CODECS.get(codec)
    return known is None or known.full_range


def encoder_options(codec: str, crf: int, preset: str, profile: str | None) -> dict[str, str]:
    """Return the encoder's own options: CRF and preset for x264/x265, a profile for others."""
    known = CODECS.get(codec)
    if known is None:
        return {}
    if known.crf:
        if codec == "libx264" and crf == 0:  # lossless at any bit depth
            return {"qp": "0", "preset": preset}
        quiet = {"x265-params": "log-level=error"} if codec == "libx265" else {}
        return {"crf": str(crf), "preset": preset, **quiet}
    if known.profiles:
        return {"profile": known.profiles[profile or known.default_profile][0]}
    return {}
