"""Input and output at the edges: video files (PyAV) and folders of frames (OpenCV)."""

from .frames import IMAGE_SUFFIXES, list_frames, read_image, write_image
from .video import VideoInfo, VideoReader, VideoWriter, probe

__all__ = ["IMAGE_SUFFIXES", "list_frames", "read_image", "write_image", "VideoInfo",
           "VideoReader", "VideoWriter", "probe"]
