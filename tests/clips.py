"""Small test clips: written with PyAV (pan video, audio, VFR pts, rotation), or simulated."""

from fractions import Fraction

import av
import numpy as np

from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming


def pole_pan(scene, share, readout, near=1.3, frames=10, size=(320, 180)):
    """A pan of ``share`` of the width a frame past flat poles ``near`` times as near,
    spaced as ``benchmarks/edges.py`` spaces them, simulated: (frames, pole layers)."""
    from unjello.simulate import pole_layers

    w = size[0]
    motion = Motion("pan", speed=share * w)
    d = motion(np.linspace(-1.0, frames + 1.0, 64))[:, 0]
    apart = max(120.0, 2 * near * share * 640)
    layers = pole_layers(motion, size, (float(d.min()), float(d.max())), near,
                         gap=(apart, apart + 140.0))
    return list(simulate(scene, motion, SensorTiming(readout), frames, size=size,
                         layers=layers)), layers


def motion_file_error(path, sim):
    """Mean per-scanline displacement error of a motion JSON against the simulator's truth,
    and the uncorrected error (px)."""
    from unjello.trajectory import Trajectory

    frames = Trajectory.load(path).frames
    err = np.mean([np.abs(f.displacement - s.motion.displacement).mean()
                   for f, s in zip(frames, sim, strict=True)])
    return err, np.mean([np.abs(s.motion.displacement).mean() for s in sim])


def make_clip(path, scene, *, n=8, size=(192, 144), fps=30, audio=True, rotation=0,
              pts=None, speed=6.0, readout=1.0, pix_fmt="yuv420p", keyint=None):
    """Write a rolling-shutter pan; return the list of video pts written."""
    frames = [s.rolling for s in simulate(scene, Motion("pan", speed=speed),
                                          SensorTiming(readout), n, size=size)]
    tb = Fraction(1, 15360)
    pts = list(pts) if pts is not None else [int(i * 15360 / fps) for i in range(n)]
    out = av.open(str(path), "w")
    vs = out.add_stream("libx264", rate=fps)
    vs.width, vs.height = size
    vs.pix_fmt = pix_fmt
    vs.time_base = tb
    vs.codec_context.time_base = tb
    vs.options = {"crf": "12", "preset": "ultrafast", **({"g": str(keyint)} if keyint else {})}
    if rotation:
        vs.set_display_rotation(rotation)
    ast = out.add_stream("aac", rate=48000) if audio else None
    for i, img in enumerate(frames):
        fr = av.VideoFrame.from_ndarray(img, format="rgb24").reformat(format=pix_fmt)
        fr.pts = pts[i]
        fr.time_base = tb
        for p in vs.encode(fr):
            out.mux(p)
    if ast is not None:
        t = np.arange(int(48000 * n / fps)) / 48000
        wave = (0.2 * np.sin(2 * np.pi * 440 * t)).astype(np.float32)
        for k in range(0, wave.size - 1024, 1024):
            af = av.AudioFrame.from_ndarray(wave[None, k:k + 1024], format="fltp",
                                            layout="mono")
            af.sample_rate = 48000
            af.pts = k
            for p in ast.encode(af):
                out.mux(p)
        for p in ast.encode():
            out.mux(p)
    for p in vs.encode():
        out.mux(p)
    out.close()
    return pts


def video_pts(path):
    with av.open(str(path)) as c:
        return [f.pts for f in c.decode(video=0)]


def audio_packets(path):
    with av.open(str(path)) as c:
        return [(p.pts, bytes(p)) for p in c.demux(audio=0) if p.dts is not None]
